"""The campaign's list of recordings, ``raw_data/MANIFEST.csv``, read and checked before the
workflow plans anything (columns ``file``, ``kind``, optional ``pressure_kpa``; others ignored)."""
from __future__ import annotations

import csv
import math
import os
from pathlib import Path

from roboball.errors import ConfigError
from roboball.ingest.validate import MAX_PRESSURE_KPA
from roboball.kinds import NOT_YET, RECORDED, not_yet_message

__all__ = ["read_manifest"]


def read_manifest(raw_dir: str | Path) -> dict[str, dict]:
    """The campaign's recordings from ``<raw_dir>/MANIFEST.csv`` (columns ``file``, ``kind``,
    optional ``pressure_kpa``; others ignored), checked before the workflow plans anything.

    Returns stem -> {"src": path, "kind": kind, "pressure_kpa": text or ""}.  Raises a one-line
    :class:`ConfigError` naming the manifest line for a missing file, an unknown kind (or one the
    workflow does not handle yet: roboball.kinds.NOT_YET), a pressure
    that is not a gauge pressure in kPa, or two recordings with the same stem (their results
    would overwrite each other)."""
    raw_text = os.fspath(raw_dir)      # paths are joined as given (they end up in the results)
    raw_dir = Path(raw_dir)
    path = raw_dir / "MANIFEST.csv"
    rows = _rows(path)
    out: dict[str, dict] = {}
    lines: dict[str, int] = {}
    for line, r in rows:
        if not any(r.values()):
            continue
        where = f"{path}: line {line}"
        text = _checked_row(r, where, raw_dir)
        stem = os.path.splitext(os.path.basename(r["file"]))[0]
        if stem in out:
            raise ConfigError(f"{where}: {r['file']}: same name as line {lines[stem]} ({stem}); results are named "
                              "after the file, so rename one of them")
        out[stem] = {"src": os.path.join(raw_text, r["file"]), "kind": r["kind"], "pressure_kpa": text}
        lines[stem] = line
    if not out:
        raise ConfigError(f"{path}: no recordings listed")
    return out


def _rows(path: Path) -> list[tuple[int, dict[str, str]]]:
    """The manifest's rows (line number, column -> stripped text); the header must name the
    columns file and kind."""
    if not path.exists():
        raise ConfigError(f"{path}: not found; list the recordings in it (file,kind,pressure_kpa) "
                          "or rebuild the virtual campaign with 'make raw-data'")
    with open(path, newline="", encoding="utf-8-sig") as fh:
        reader = csv.DictReader(fh)
        columns = [c.strip() for c in (reader.fieldnames or [])]
        missing = [c for c in ("file", "kind") if c not in columns]
        if missing:
            raise ConfigError(f"{path}: line 1 (header): missing column {', '.join(missing)} "
                              f"(columns: {', '.join(columns) or 'none'}); the header must start file,kind,pressure_kpa")
        return [(i, {k.strip(): (v or "").strip() for k, v in r.items() if k is not None})
                for i, r in enumerate(reader, start=2)]


def _checked_row(r: dict[str, str], where: str, raw_dir: Path) -> str:
    """Check one row: the file exists, the kind is known, the pressure (if given) is a gauge
    pressure in kPa.  Returns the pressure's text ("" if not given)."""
    if not r["file"]:
        raise ConfigError(f"{where}: column file: empty; give the recording's path relative to {raw_dir}")
    src = raw_dir / r["file"]
    if not src.is_file():
        raise ConfigError(f"{where}: {r['file']}: file not found in {raw_dir}; fix the path or remove the line")
    if r["kind"] not in RECORDED:
        valid = [k for k in RECORDED if k not in NOT_YET["pipeline"]]
        raise ConfigError(f"{where}: column kind: unknown kind {r['kind']!r}; valid kinds: {', '.join(valid)}")
    if r["kind"] in NOT_YET["pipeline"]:
        raise ConfigError(f"{where}: {r['file']}: {not_yet_message(r['kind'], 'pipeline')}; remove the line")
    text = r.get("pressure_kpa", "")
    if text.lower() not in ("", "nan", "none", "null"):
        try:
            p = float(text)
        except ValueError:
            raise ConfigError(f"{where}: column pressure_kpa: {text!r} is not a number; give the gauge pressure "
                              "in kPa or leave it empty")
        if not (math.isfinite(p) and 0.0 < p <= MAX_PRESSURE_KPA):
            raise ConfigError(f"{where}: column pressure_kpa: {text} kPa is outside (0, {MAX_PRESSURE_KPA:g}] kPa; "
                              "give the shell gauge pressure in kPa (1 psi = 6.895 kPa)")
    return text
