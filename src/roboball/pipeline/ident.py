"""Identification stages: ingest, release detection, decay extraction, shell regressions."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from roboball.atomic import write_csv_atomic, write_json_atomic
from roboball.errors import RoboballError

STAGES = ("ingest", "decay", "shell_regression")


def _float_or_none(x):
    """A flag value as float, or None when it is empty or not a number ("", "None", "null",
    and "nan", which is how the campaign MANIFEST writes a pressure that does not apply)."""
    if x is None or str(x).strip().lower() in ("", "none", "null", "nan"):
        return None
    try:
        return float(x)
    except ValueError:
        raise RoboballError(f"--pressure-kpa {x!r}: not a number; give the gauge pressure in kPa or leave it empty")


def ingest(src: str, out_csv: str, out_releases: str, qc_png: str, kind: str = "", pressure_kpa: str = "") -> None:
    """Validate and normalise one recording (native formats imported), find its releases,
    write the normalised recording, a releases JSON and a QC plot."""
    from roboball.ingest.importers import read_any
    from roboball.ingest.recording import normalise, write_recording

    flags = {}
    if kind:
        flags["kind"] = kind
    pressure = _float_or_none(pressure_kpa)
    if pressure is not None:
        flags["pressure_kpa"] = pressure
    rec = normalise(read_any(src, **flags))
    # Imported only once the file is known to be good, so bad input fails fast (scipy is slow to load).
    from roboball.ingest.releases.find import require_releases

    rels = require_releases(rec)
    write_recording(out_csv, rec)
    write_json_atomic(out_releases, {"source": str(src), "kind": rec.kind, "pressure_kpa": rec.pressure_kpa,
                                     "signal": rec.main_signal(), "releases": [r.as_dict() for r in rels]})
    from roboball.figures.style import qc_plot
    qc_plot(rec, rels, qc_png)


def _releases(path):
    from roboball.ingest.releases.record import Release
    with open(path, encoding="utf-8") as fh:
        data = json.load(fh)
    return [Release(**r) for r in data["releases"]]


def decay(recording: str, releases: str, out_csv: str) -> None:
    """Damping ratio and frequency of every release (damped-sine fit, log-decrement check)."""
    from roboball.identify.shell.decay import decay_table
    from roboball.ingest.recording import read_recording

    rec = read_recording(recording)
    table = decay_table(rec, _releases(releases))
    table.insert(0, "recording", Path(recording).stem)
    write_csv_atomic(table, out_csv)


def shell_regression(decay_csvs: list, out_points: str, out_table: str) -> None:
    """zeta(p) = a exp(b p) and omega_n(p) = c + d p over all shell releases, with 95% CIs."""
    from roboball.identify.shell.regress import regression_table

    pts = pd.concat([pd.read_csv(p) for p in sorted(decay_csvs)], ignore_index=True)
    pts = pts[np.isfinite(pts.pressure_kpa)]
    if pts.empty:
        raise RoboballError("shell regression: no shell_rock release with a known pressure")
    write_csv_atomic(pts, out_points)
    write_csv_atomic(regression_table(pts), out_table)
