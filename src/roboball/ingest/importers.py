"""Importers for the paper authors' native log formats (recordings.md, bottom), told apart by
their header:

* steer-stand log: ``steer_timestamp`` (s), ``pend_angle`` (rad)
  -> ``time_s`` (shifted to start at 0), ``steer_angle_rad``; kind ``steer_stand``.
* shell log: ``timestamp`` (integer nanoseconds), ``ball_roll.position`` (rad),
  ``ball_roll.velocity`` (rad/s) -> ``time_s`` (seconds from the first sample),
  ``pipe_angle_rad``, ``pipe_rate_rad_s``; kind ``shell_rock``.
* coupled steer-direction test: ``timestamp`` (ns), ``ball_roll.position`` (rad, the pipe
  angle), ``roll_joint.position`` (rad, the steer joint angle) -> ``time_s``,
  ``pipe_angle_rad``, ``steer_angle_rad``; kind ``steer_coupled``.
* steer-stand trial: ``timestamp`` (ns), ``roll_joint.position`` (rad),
  ``roll_joint.velocity`` (rad/s) -> ``time_s``, ``steer_angle_rad``, ``steer_rate_rad_s``;
  kind ``steer_stand``.

Native logs carry no sidecar, so kind and pressure come from flags, from a sidecar placed
next to the log if there is one, or from defaults.  A shell or coupled log without a known
pressure is imported with ``pressure_kpa = None`` and ``meta["pressure_source"] = "unknown"``
(the real logs' pressure was not recorded); code that needs the pressure must check.

The converted data pass the same validation as any recording (monotone time, radians,
finite numbers) and the errors have the same one-line form.
"""
from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from roboball.ingest.csvtable import fields, parse_numeric_csv, read_text, split_lines
from roboball.ingest.errors import recording_error
from roboball.ingest.recording import Recording, read_recording
from roboball.ingest.sidecar import read_sidecar
from roboball.ingest.validate import check_meta, check_values

__all__ = ["NATIVE_FORMATS", "detect_format", "import_native", "read_any"]

# format name -> required native columns (in the order of the native header), what each becomes,
# default kind, allowed kinds, what error messages call the log, and whether the shell's pressure
# matters (then an unknown one is flagged).  Detection tries them in this order.
NATIVE_FORMATS = {
    "steer_log": {
        "columns": ("steer_timestamp", "pend_angle"),
        "signals": {"pend_angle": "steer_angle_rad"},
        "kind": "steer_stand",
        "kinds": ("steer_stand",),
        "what": "steer log",
        "shell": False,
    },
    "shell_log": {
        "columns": ("timestamp", "ball_roll.position", "ball_roll.velocity"),
        "signals": {"ball_roll.position": "pipe_angle_rad", "ball_roll.velocity": "pipe_rate_rad_s"},
        "kind": "shell_rock",
        "kinds": ("shell_rock",),
        "what": "shell log",
        "shell": True,
    },
    "coupled_log": {
        "columns": ("timestamp", "ball_roll.position", "roll_joint.position"),
        "signals": {"ball_roll.position": "pipe_angle_rad", "roll_joint.position": "steer_angle_rad"},
        "kind": "steer_coupled",
        "kinds": ("steer_coupled", "shell_rock"),   # its pipe angle alone is a shell rocking record
        "what": "coupled steer log",
        "shell": True,
    },
    "steer_trial_log": {
        "columns": ("timestamp", "roll_joint.position", "roll_joint.velocity"),
        "signals": {"roll_joint.position": "steer_angle_rad", "roll_joint.velocity": "steer_rate_rad_s"},
        "kind": "steer_stand",
        "kinds": ("steer_stand",),
        "what": "steer-stand trial log",
        "shell": False,
    },
}


def _header_of(path: Path) -> list[str]:
    text = read_text(path)
    for line in split_lines(text):
        if line.strip():
            return [h.strip() for h in next(csv.reader([line]))]
    raise recording_error(path, "file", "empty file (no header, no data)")


def detect_format(path: str | Path) -> str:
    """Which format a CSV file is in: "recording" or one of NATIVE_FORMATS ("steer_log",
    "shell_log", "coupled_log", "steer_trial_log"), judged from its header row (the first
    format, in NATIVE_FORMATS' order, whose columns it starts with or holds).  Raises
    RecordingError if it is none of them."""
    path = Path(path)
    header = _header_of(path)
    if header and header[0] == "time_s":
        return "recording"
    for name, spec in NATIVE_FORMATS.items():
        if header[: len(spec["columns"])] == list(spec["columns"]) or set(spec["columns"]) <= set(header):
            return name
    raise recording_error(
        path, "line 1 (header)",
        f"not a recording (first column time_s) nor a known native log (columns: {', '.join(header)})",
        "expected time_s,...; " + "; ".join(",".join(spec["columns"]) for spec in NATIVE_FORMATS.values()),
    )


def _integer_cells(path: Path, text: str, line_numbers, j: int, what: str) -> np.ndarray:
    """Column `j` of the given (1-based) file lines as exact int64 (parse_numeric_csv reads
    floats, which hold integers only up to 2**53); a one-line error for a cell that is not an
    integer within int64."""
    lines = split_lines(text)
    out = np.empty(len(line_numbers), dtype=np.int64)
    for r, n in enumerate(line_numbers):
        line = lines[int(n) - 1]
        cell = fields(line)[j].strip()
        try:
            v = int(cell)
        except ValueError:
            raise recording_error(path, f"line {int(n)}, column timestamp", f"{cell[:40]!r} is not an integer number of "
                                  "nanoseconds", f"the {what}'s timestamp column must be integer nanoseconds") from None
        if not -2 ** 63 <= v < 2 ** 63:
            raise recording_error(path, f"line {int(n)}, column timestamp", f"{cell[:40]} is beyond 64-bit integers",
                                  f"the {what}'s timestamp column must be integer nanoseconds")
        out[r] = v
    return out


def import_native(
    path: str | Path,
    kind: str | None = None,
    pressure_kpa: float | None = None,
    ramp_angle_deg: float | None = None,
    ramp_exit_s: float | None = None,
) -> Recording:
    """Convert one of the authors' native logs (NATIVE_FORMATS) into a :class:`Recording` (in
    memory; use :func:`roboball.ingest.recording.write_recording` to save it).

    Time is shifted to start at 0; the offset is kept in ``meta["time_offset_s"]``
    (steer log, seconds) or ``meta["time_offset_ns"]`` (the logs stamped in integer ns).
    """
    path = Path(path)
    fmt = detect_format(path)
    if fmt == "recording":
        raise recording_error(path, "line 1 (header)", "already a recording (first column time_s), not a native log",
                              "read it with read_recording or read_any")
    spec = NATIVE_FORMATS[fmt]
    text = read_text(path)
    header, values, line_numbers = parse_numeric_csv(path, text)
    col = {name: header.index(name) for name in spec["columns"]}
    meta, sources = _meta(path, fmt, kind=kind, pressure_kpa=pressure_kpa, ramp_angle_deg=ramp_angle_deg,
                          ramp_exit_s=ramp_exit_s)
    if fmt == "steer_log":
        out_header, out = _steer_columns(path, values, col, meta)
    else:
        out_header, out = _ns_columns(path, text, values, line_numbers, col, spec, meta, sources)
    meta["source_format"] = fmt
    meta["source_file"] = path.name

    # Same checks as a recording; pressure may be unknown for an imported shell log.
    check_values(path, out_header, out, line_numbers, meta["kind"])
    checked = check_meta(meta, path, sources, allow_unknown_pressure=True)
    data = pd.DataFrame({h: out[:, j] for j, h in enumerate(out_header)})
    return Recording(data=data, meta=checked, path=path)


def _meta(path: Path, fmt: str, **flags: Any) -> tuple[dict[str, Any], dict[str, str]]:
    """The native log's metadata: a sidecar beside it if there is one, overridden by the flags
    that are not None, the format's kind by default.  Returns (meta, where each key came from)."""
    spec = NATIVE_FORMATS[fmt]
    sidecar, side = read_sidecar(path)
    meta: dict[str, Any] = dict(sidecar or {})
    sources = {k: f"sidecar {side.name}" for k in meta}
    for key in ("kind", "pressure_kpa", "ramp_angle_deg", "ramp_exit_s"):
        val = flags[key]
        if val is not None:
            meta[key] = val
            sources[key] = "flag --" + key.replace("_", "-")
    meta.setdefault("kind", spec["kind"])
    if meta["kind"] not in spec["kinds"]:
        raise recording_error(
            path, "field kind",
            f"a {spec['what']} can only be kind {' or '.join(spec['kinds'])}, not {meta['kind']!r}",
            "drop --kind or use the matching log",
        )
    return meta, sources


def _steer_columns(path: Path, values: np.ndarray, col: dict[str, int], meta: dict) -> tuple[list[str], np.ndarray]:
    """The steer log as (header, values) of a recording; its time offset goes into `meta`."""
    t = values[:, col["steer_timestamp"]]
    if np.all(np.isfinite(t)) and np.nanmax(np.abs(t)) > 1e9:
        raise recording_error(path, "column steer_timestamp", f"values up to {np.nanmax(np.abs(t)):.4g} are not seconds",
                              "the steer log's timestamps must be in seconds")
    offset = float(t[0])
    time_s = t - offset
    out_header = ["time_s", "steer_angle_rad"]
    out = np.column_stack([time_s, values[:, col["pend_angle"]]])
    meta["time_offset_s"] = offset
    return out_header, out


def _nanoseconds(path: Path, text: str, values: np.ndarray, line_numbers: np.ndarray, j: int,
                 what: str) -> np.ndarray:
    """Column `j` (the integer-nanosecond ``timestamp``) as exact int64; a one-line error for
    stamps that are not integers or far too fine for nanoseconds."""
    raw = values[:, j]
    frac = np.nonzero(np.isfinite(raw) & (raw != np.round(raw)))[0]
    if frac.size:
        r = int(frac[0])
        raise recording_error(
            path, f"line {line_numbers[r]}, column timestamp",
            f"{raw[r]:.9g} is not an integer number of nanoseconds",
            f"the {what}'s timestamp column must be integer nanoseconds",
        )
    # Integer nanoseconds up to ~9e15 are exact in float64; beyond that (epoch nanoseconds,
    # ~1.7e18) the cells of the very rows parse_numeric_csv read are read again as Python integers.
    if np.all(np.isfinite(raw)) and np.max(np.abs(raw)) < 2 ** 53:
        t_ns = raw.astype(np.int64)
    else:
        t_ns = _integer_cells(path, text, line_numbers, j, what)
    steps = np.diff(t_ns)
    pos = steps[steps > 0]
    if pos.size and np.median(pos) < 1e3:
        raise recording_error(
            path, "column timestamp",
            f"median step {np.median(pos):.4g} is far too small for nanoseconds",
            f"the {what}'s timestamp column must be integer nanoseconds",
        )
    return t_ns


def _ns_columns(path: Path, text: str, values: np.ndarray, line_numbers: np.ndarray, col: dict[str, int],
                spec: dict, meta: dict, sources: dict[str, str]) -> tuple[list[str], np.ndarray]:
    """A log stamped in integer nanoseconds as (header, values) of a recording: its stamps turned
    into seconds from the first sample, its columns renamed (spec["signals"]); the offset and,
    for a shell on the ground, where the pressure came from go into `meta`."""
    t_ns = _nanoseconds(path, text, values, line_numbers, col["timestamp"], spec["what"])
    offset_ns = int(t_ns[0])
    time_s = (t_ns - offset_ns).astype(float) * 1e-9
    out_header = ["time_s"] + list(spec["signals"].values())
    out = np.column_stack([time_s] + [values[:, col[native]] for native in spec["signals"]])
    meta["time_offset_ns"] = offset_ns
    if spec["shell"]:
        if meta.get("pressure_kpa") is None:
            meta["pressure_kpa"] = None
            meta["pressure_source"] = "unknown"
        else:
            meta.setdefault("pressure_source", sources.get("pressure_kpa", "sidecar").split(" ")[0])
    return out_header, out


def read_any(path: str | Path, **flags: Any) -> Recording:
    """Read a recording or a native log, whichever `path` is.  `flags` are those of
    :func:`roboball.ingest.recording.read_recording` (kind, pressure_kpa, ramp_angle_deg,
    ramp_exit_s); None values are ignored."""
    path = Path(path)
    flags = {k: v for k, v in flags.items() if v is not None}
    allowed = {"kind", "pressure_kpa", "ramp_angle_deg", "ramp_exit_s"}
    unknown = set(flags) - allowed
    if unknown:
        raise TypeError(f"read_any: unknown flag(s) {sorted(unknown)}")
    if detect_format(path) == "recording":
        return read_recording(path, **flags)
    return import_native(path, **flags)
