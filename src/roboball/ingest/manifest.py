"""A campaign's list of recordings, ``MANIFEST.csv``, read and checked before the workflow plans
anything.

Columns: ``file`` (path relative to the campaign's folder) and ``kind``; optional
``pressure_kpa`` (a gauge pressure, empty to take it from the recording's sidecar, ``unknown``
where it was never logged, ``nan`` where it does not matter), ``steer_joint`` (shell releases:
locked, free or unknown), ``ramp_angle_deg``, ``name`` (the recording's name in the results;
default: the file's stem) and ``campaign`` (the campaign's name in figure titles).  Other
columns (the virtual campaign's ``run`` and checksums) are ignored.  ``roboball manifest DIR``
writes one for a folder of logs (roboball.ingest.survey)."""
from __future__ import annotations

import csv
import math
import os
import re
from pathlib import Path

from roboball.errors import ConfigError, RoboballError
from roboball.ingest.validate import MAX_PRESSURE_KPA
from roboball.kinds import NOT_YET, PRESSURE_REQUIRED, RECORDED, not_yet_message

__all__ = ["read_manifest", "manifest_name", "STEER_JOINTS", "UNKNOWN", "COLUMNS"]

# The written column order (roboball manifest); a reader needs only file and kind.
COLUMNS = ("file", "kind", "pressure_kpa", "steer_joint", "ramp_angle_deg", "name", "campaign")
STEER_JOINTS = ("locked", "free", "unknown")
UNKNOWN = "unknown"                  # a pressure that was never logged, said so on purpose
_NOT_GIVEN = ("", "nan", "none", "null")
# a recording's name becomes file names and Snakemake wildcards
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.\-]*$")


def read_manifest(raw_dir: str | Path, manifest: str | Path | None = None) -> dict[str, dict]:
    """The campaign's recordings from its manifest (``<raw_dir>/MANIFEST.csv`` unless `manifest`
    names another file; `file` paths are relative to `raw_dir` either way).

    Returns name -> {"src", "kind", "pressure_kpa" (text: a number, "" or "unknown"),
    "steer_joint", "ramp_angle_deg" (text), "campaign", "where" (manifest and line)}.  Raises a
    one-line :class:`ConfigError` naming the manifest line for a missing file, an unknown kind, a
    pressure that is not a gauge pressure in kPa, a shell or ramp recording whose pressure is
    given nowhere, a native log whose header is not recognised, or two recordings with the same
    name (their results would overwrite each other)."""
    raw_text = os.fspath(raw_dir)      # paths are joined as given (they end up in the results)
    raw_dir = Path(raw_dir)
    path = Path(manifest) if manifest else raw_dir / "MANIFEST.csv"
    out: dict[str, dict] = {}
    lines: dict[str, int] = {}
    for line, r in _rows(path):
        if not any(r.values()):
            continue
        where = f"{path}: line {line}"
        entry = _checked_row(r, where, raw_dir)
        stem = r.get("name") or os.path.splitext(os.path.basename(r["file"]))[0]
        if not _NAME.match(stem):
            raise ConfigError(f"{where}: {r['file']}: name {stem!r} must be letters, digits, '_', '-' or '.'; "
                              "give column name")
        if stem in out:
            raise ConfigError(f"{where}: {r['file']}: same name as line {lines[stem]} ({stem}); results are named "
                              "after the file, so rename one of them (or give column name)")
        out[stem] = {"src": os.path.join(raw_text, r["file"]), **entry, "where": where}
        lines[stem] = line
    if not out:
        raise ConfigError(f"{path}: no recordings listed")
    return out


def manifest_name(recordings: dict) -> str:
    """The campaign's name its manifest gives (column campaign), or ""."""
    return next((r["campaign"] for r in recordings.values() if r.get("campaign")), "")


def _rows(path: Path) -> list[tuple[int, dict[str, str]]]:
    """The manifest's rows (line number, column -> stripped text); the header must name the
    columns file and kind."""
    if not path.exists():
        raise ConfigError(f"{path}: not found; list the recordings in it (file,kind,pressure_kpa; "
                          "'roboball manifest DIR' writes one, 'roboball manifest DIR --out FILE' elsewhere for "
                          "make figures RAW=DIR MANIFEST=FILE) or rebuild the virtual campaign with 'make raw-data'")
    with open(path, newline="", encoding="utf-8-sig") as fh:
        reader = csv.DictReader(fh)
        columns = [c.strip() for c in (reader.fieldnames or [])]
        missing = [c for c in ("file", "kind") if c not in columns]
        if missing:
            raise ConfigError(f"{path}: line 1 (header): missing column {', '.join(missing)} "
                              f"(columns: {', '.join(columns) or 'none'}); the header must start file,kind,pressure_kpa")
        return [(i, {k.strip(): (v or "").strip() for k, v in r.items() if k is not None})
                for i, r in enumerate(reader, start=2)]


def _checked_row(r: dict[str, str], where: str, raw_dir: Path) -> dict:
    """Check one row: the file exists and is a recording or a native log, the kind is known,
    the settings are valid and a shell or ramp recording's pressure is given somewhere."""
    if not r["file"]:
        raise ConfigError(f"{where}: column file: empty; give the recording's path relative to {raw_dir}")
    src = raw_dir / r["file"]
    if not src.is_file():
        raise ConfigError(f"{where}: {r['file']}: file not found in {raw_dir}; fix the path or remove the line")
    kind = r["kind"]
    if kind not in RECORDED:
        valid = [k for k in RECORDED if k not in NOT_YET["pipeline"]]
        raise ConfigError(f"{where}: column kind: unknown kind {kind!r}; valid kinds: {', '.join(valid)}")
    if kind in NOT_YET["pipeline"]:
        raise ConfigError(f"{where}: {r['file']}: {not_yet_message(kind, 'pipeline')}; remove the line")
    _check_format(src, where, r["file"])
    side = _sidecar(src, where)
    pressure = _pressure(r.get("pressure_kpa", ""), side, kind, where, r["file"])
    steer = r.get("steer_joint", "") or str(side.get("steer_joint") or "")
    if steer and steer not in STEER_JOINTS:
        raise ConfigError(f"{where}: column steer_joint: {steer!r}; give {', '.join(STEER_JOINTS)} or leave it empty")
    angle = r.get("ramp_angle_deg", "")
    if angle.lower() not in _NOT_GIVEN:
        try:
            ok = 0.0 < float(angle) < 90.0
        except ValueError:
            ok = False
        if not ok:
            raise ConfigError(f"{where}: column ramp_angle_deg: {angle!r} is not a ramp angle in degrees (0-90)")
    else:
        angle = ""
    return {"kind": kind, "pressure_kpa": pressure, "steer_joint": steer, "ramp_angle_deg": angle,
            "campaign": r.get("campaign", "")}


def _check_format(src: Path, where: str, name: str) -> None:
    """A recording (first column time_s) or one of the authors' native logs, by its header."""
    from roboball.ingest.importers import detect_format
    try:
        detect_format(src)
    except RoboballError as exc:
        raise ConfigError(f"{where}: {name}: {str(exc).replace(str(src) + ': ', '', 1)}") from None


def _sidecar(src: Path, where: str) -> dict:
    """The recording's sidecar (an empty dict without one)."""
    from roboball.ingest.sidecar import read_sidecar
    try:
        side, _ = read_sidecar(src)
    except RoboballError as exc:
        raise ConfigError(f"{where}: {exc}") from None
    return side or {}


def _pressure(text: str, side: dict, kind: str, where: str, name: str) -> str:
    """The recording's pressure as text: the manifest's, else the sidecar's; "unknown" only where
    said so; "" where it does not matter.  A shell or ramp recording must have one."""
    if text.lower() == UNKNOWN:
        if kind == "ramp":
            raise ConfigError(f"{where}: {name}: a ramp run's pressure cannot be unknown (every ramp model "
                              "needs it); give column pressure_kpa in kPa")
        return UNKNOWN
    if text.lower() in _NOT_GIVEN:
        p = side.get("pressure_kpa")
        text = "" if p is None else str(p)
    if text.lower() in _NOT_GIVEN:
        if kind in PRESSURE_REQUIRED:
            raise ConfigError(f"{where}: {name}: a {kind} recording needs its shell pressure: give column "
                              "pressure_kpa (or 'unknown' if it was not logged), a sidecar's pressure_kpa, or "
                              "'roboball manifest --pressure-kpa P'")
        return ""
    try:
        p = float(text)
    except ValueError:
        raise ConfigError(f"{where}: column pressure_kpa: {text!r} is not a number; give the gauge pressure "
                          "in kPa, 'unknown', or leave it empty") from None
    if not (math.isfinite(p) and 0.0 < p <= MAX_PRESSURE_KPA):
        raise ConfigError(f"{where}: column pressure_kpa: {text} kPa is outside (0, {MAX_PRESSURE_KPA:g}] kPa; "
                          "give the shell gauge pressure in kPa (1 psi = 6.895 kPa)")
    return text
