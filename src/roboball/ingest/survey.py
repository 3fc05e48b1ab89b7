"""`roboball manifest DIR`: a campaign's MANIFEST.csv written from a folder of logs.

Every CSV below the folder is a recording (first column ``time_s``) or one of the authors'
native logs (roboball.ingest.importers, told apart by their header).  Its kind and settings come
from its sidecar first, then from the native format (the kind it records), then from the flags,
which fill in only what the files do not say; what cannot be told is refused in one line naming
the file and the flag to give.  The manifest is checked by the same reader the workflow uses
(roboball.ingest.manifest) before it replaces anything."""
from __future__ import annotations

import csv
import io
import os
from pathlib import Path

from roboball.errors import RoboballError
from roboball.kinds import PRESSURE_REQUIRED, RECORDED

__all__ = ["survey", "write_manifest"]


def survey(raw_dir: str | Path, kind: str | None = None, pressure_kpa: str | None = None,
           steer_joint: str | None = None, ramp_angle_deg: float | None = None, name: str = "") -> list[dict]:
    """The manifest rows of every log below `raw_dir` (sorted by path): file, kind,
    pressure_kpa, steer_joint, ramp_angle_deg, name, campaign.  `kind` is taken for logs whose
    sidecar and format do not give one (and for native logs the format allows it for);
    `pressure_kpa` (kPa, or "unknown") for shell, ramp and coupled logs without one;
    `steer_joint` for shell releases, `ramp_angle_deg` for ramp runs, `name` as the campaign's."""
    from roboball.ingest.importers import NATIVE_FORMATS, detect_format
    from roboball.ingest.sidecar import read_sidecar

    raw_dir = Path(raw_dir)
    if not raw_dir.is_dir():
        raise RoboballError(f"{raw_dir}: not a folder of recordings")
    if kind is not None and kind not in RECORDED:
        raise RoboballError(f"--kind {kind}: unknown kind; valid kinds: {', '.join(RECORDED)}")
    pressure_kpa = _pressure_flag(pressure_kpa)
    files = sorted(p for p in raw_dir.rglob("*.csv") if p.name != "MANIFEST.csv" and not p.name.startswith("."))
    if not files:
        raise RoboballError(f"{raw_dir}: no .csv recordings found")
    rows, seen = [], {}
    for path in files:
        rel = path.relative_to(raw_dir).as_posix()
        fmt = detect_format(path)               # a one-line error for a header it does not know
        side, _ = read_sidecar(path)
        side = side or {}
        allowed = RECORDED if fmt == "recording" else NATIVE_FORMATS[fmt]["kinds"]
        k = side.get("kind") or (kind if kind in allowed else None) or \
            (None if fmt == "recording" else NATIVE_FORMATS[fmt]["kind"])
        if k is None:
            raise RoboballError(f"{path}: kind unknown (no sidecar {path.stem}.json with a kind); give --kind "
                                f"({', '.join(RECORDED)}) or write the sidecar")
        p = side.get("pressure_kpa")
        p = "" if p is None else str(p)
        if not p and k in (*PRESSURE_REQUIRED, "steer_coupled") and pressure_kpa:
            p = pressure_kpa
        if not p and k in PRESSURE_REQUIRED:
            raise RoboballError(f"{path}: a {k} log without a shell pressure (none in a sidecar); give "
                                "--pressure-kpa P (gauge, kPa), or --pressure-kpa unknown if it was not logged")
        stem = path.stem
        if stem in seen:
            raise RoboballError(f"{path}: same name as {seen[stem]}; results are named after the file, so rename one")
        seen[stem] = path
        rows.append({"file": rel, "kind": k, "pressure_kpa": p,
                     "steer_joint": str(side.get("steer_joint") or (steer_joint if k == "shell_rock" and steer_joint
                                                                    else "")),
                     "ramp_angle_deg": _angle(side.get("ramp_angle_deg"), ramp_angle_deg if k == "ramp" else None),
                     "name": "", "campaign": name})
    return rows


def write_manifest(raw_dir: str | Path, rows: list[dict], force: bool = False, out: str | Path | None = None) -> Path:
    """Write `rows` as ``<raw_dir>/MANIFEST.csv``, or as `out` (a folder of logs that must stay as
    it is: an archive, a read-only share; `file` paths stay relative to `raw_dir`), after the
    workflow's reader has accepted them (nothing is written when it does not); an existing
    manifest is replaced only with `force`."""
    from roboball.atomic import write_text_atomic
    from roboball.ingest.manifest import COLUMNS, read_manifest

    path = Path(out) if out else Path(raw_dir) / "MANIFEST.csv"
    if path.exists() and not force:
        raise RoboballError(f"{path}: exists; give --force to replace it")
    if not path.parent.is_dir():
        raise RoboballError(f"{path}: its folder {path.parent} does not exist")
    if not os.access(path.parent, os.W_OK):
        hint = "" if out else "; give --out FILE to keep the manifest elsewhere (make figures RAW=DIR MANIFEST=FILE)"
        raise RoboballError(f"{path}: the folder {path.parent} is not writable{hint}")
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(COLUMNS), lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    tmp = write_text_atomic(path.parent / f".{path.name}.check.csv", buf.getvalue())
    try:
        read_manifest(raw_dir, tmp)
    finally:
        os.unlink(tmp)
    return write_text_atomic(path, buf.getvalue())


def _pressure_flag(text: str | None) -> str:
    if text is None or str(text).strip() == "":
        return ""
    if str(text).strip().lower() == "unknown":
        return "unknown"
    try:
        p = float(text)
    except ValueError:
        raise RoboballError(f"--pressure-kpa {text!r}: give the gauge pressure in kPa, or 'unknown'") from None
    if not p > 0:
        raise RoboballError(f"--pressure-kpa {text}: a gauge pressure must be positive (kPa)")
    return f"{p:g}"


def _angle(side_value, flag) -> str:
    v = side_value if side_value is not None else flag
    return "" if v is None else f"{float(v):g}"
