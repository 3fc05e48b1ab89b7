"""Identification stages: ingest, release detection, decay extraction, shell regressions."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from roboball.atomic import write_csv_atomic, write_json_atomic
from roboball.errors import RoboballError

STAGES = ("ingest", "decay", "shell_regression", "shell_constant_laws")


def _float_or_none(x):
    """A flag value as float, or None when it is empty or not a number ("", "None", "null",
    "nan", which is how the campaign MANIFEST writes a pressure that does not apply, and
    "unknown", a pressure that was never logged)."""
    if x is None or str(x).strip().lower() in ("", "none", "null", "nan", "unknown"):
        return None
    try:
        return float(x)
    except ValueError:
        raise RoboballError(f"--pressure-kpa {x!r}: not a number; give the gauge pressure in kPa or leave it empty")


def ingest(src: str, out_csv: str, out_releases: str, qc_png: str, kind: str = "", pressure_kpa: str = "",
           ramp_angle_deg: str = "") -> None:
    """Validate and normalise one recording (native formats imported), find its releases,
    write the normalised recording, a releases JSON and a QC plot.  `kind`, `pressure_kpa` and
    `ramp_angle_deg` (the campaign manifest's) override the recording's sidecar."""
    from roboball.ingest.importers import read_any
    from roboball.ingest.recording import normalise, write_recording

    flags = {}
    if kind:
        flags["kind"] = kind
    pressure = _float_or_none(pressure_kpa)
    if pressure is not None:
        flags["pressure_kpa"] = pressure
    if _float_or_none(ramp_angle_deg) is not None:
        flags["ramp_angle_deg"] = float(ramp_angle_deg)
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


def shell_constant_laws(decay_csvs: list, out_table: str) -> None:
    """The shell laws of a campaign whose releases cannot give a regression (one pressure, or
    none logged): zeta and omega_n held at the releases' means, the same at every pressure
    (zeta_b = omega_n_d = 0), with their standard errors; the table reads like the regression's
    (roboball.sim.schedule.ShellLaws), and its row pressure_free says what it is."""
    pts = pd.concat([pd.read_csv(p) for p in sorted(decay_csvs)], ignore_index=True)
    pts = pts[np.isfinite(pts.zeta) & np.isfinite(pts.omega_n_rad_s)]
    if pts.empty:
        raise RoboballError(f"{' '.join(decay_csvs)}: no shell release with a damping ratio and frequency to take "
                            "the shell laws from")
    n = len(pts)

    def row(name, values, unit):
        se = float(np.std(values, ddof=1) / np.sqrt(n)) if n > 1 else float("nan")
        v = float(np.mean(values))
        return {"name": name, "value": v, "se": se, "ci95_low": v - 1.96 * se, "ci95_high": v + 1.96 * se,
                "unit": unit, "n_points": n, "dof": n - 1}

    zero = {"value": 0.0, "se": 0.0, "ci95_low": 0.0, "ci95_high": 0.0, "n_points": n, "dof": n - 1}
    table = pd.DataFrame([row("zeta_a", pts.zeta, "-"), {"name": "zeta_b", **zero, "unit": "1/kPa"},
                          row("omega_n_c", pts.omega_n_rad_s, "rad/s"), {"name": "omega_n_d", **zero, "unit": "rad/s/kPa"},
                          {"name": "pressure_free", **zero, "value": 1.0, "unit": "-"}])
    write_csv_atomic(table, out_table)
