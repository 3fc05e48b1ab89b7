"""Recordings: the one format every measured or simulated log is read from and written to.

A recording is a CSV file (first column ``time_s``, then signal columns named
``<signal>_<unit>``) plus a JSON sidecar with the same stem that says what experiment it is
(``kind``) and at which shell pressure (``pressure_kpa``); see
``../shared/specs/recordings.md``.  Simulations write the same format, so measured and
simulated runs go through the same code.

The reader is deliberately strict and explains itself: anything wrong with a file raises
:class:`RecordingError` with ONE line ``"<file>: <where>: <what is wrong>[; <what to do>]"``,
naming the line (1-based, the header is line 1) and column where that makes sense.  It
accepts the harmless quirks of real logs: CRLF line endings, a UTF-8 byte-order mark, blank
lines, and exact duplicate time stamps.  :func:`normalise` then drops the duplicates and
reports gaps so downstream code never divides by a zero time step.
"""
from __future__ import annotations

import csv
import difflib
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import pandas as pd

from roboball.atomic import csv_text, json_dumps_stable, write_texts_atomic
from roboball.errors import RoboballError
from roboball.kinds import ANGLE_SIGNALS, KNOWN_SIGNALS, MAIN_SIGNAL, PRESSURE_REQUIRED, RECORDED

__all__ = [
    "RecordingError",
    "Recording",
    "KINDS",
    "KNOWN_SIGNALS",
    "MAIN_SIGNAL",
    "ANGLE_SIGNALS",
    "DEFAULT_RAMP_ANGLE_DEG",
    "MAX_PRESSURE_KPA",
    "read_recording",
    "write_recording",
    "normalise",
    "sidecar_path",
    "check_meta",
    "recording_from_columns",
]


class RecordingError(RoboballError):
    """A recording (CSV or sidecar) is missing, malformed or physically implausible."""


KINDS = RECORDED
DEFAULT_RAMP_ANGLE_DEG = 16.0  # robot-facts.md: the paper's ramp
MAX_PRESSURE_KPA = 500.0  # far above any inflatable shell; larger values are unit mistakes
NS_TIME_LIMIT = 1e9  # time_s values beyond this are nanosecond (or epoch) stamps
NS_STEP_LIMIT = 1e6  # a median step of more than 11 days is a nanosecond step

NATIVE_HEADERS = {
    "steer_timestamp": "the authors' native steer-stand log (steer_timestamp, pend_angle)",
    "timestamp": "the authors' native shell log (timestamp in ns, ball_roll.position, ...)",
}

_NUMBER = re.compile(r"^[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?$")
_NONFINITE = re.compile(r"^[+-]?(?:nan|inf|infinity)$", re.IGNORECASE)


# --------------------------------------------------------------------------------------
# The Recording object
# --------------------------------------------------------------------------------------
@dataclass
class Recording:
    """A validated recording: `data` (first column ``time_s``, SI signal columns), `meta`
    (the sidecar merged with command-line overrides; unknown keys preserved) and the
    `path` it came from (None for in-memory recordings)."""

    data: pd.DataFrame
    meta: dict = field(default_factory=dict)
    path: Path | None = None

    @property
    def time(self) -> np.ndarray:
        """Sample times in seconds."""
        return self.data["time_s"].to_numpy(dtype=float)

    @property
    def signals(self) -> list[str]:
        """Signal column names (everything after ``time_s``)."""
        return [c for c in self.data.columns if c != "time_s"]

    def has_signal(self, name: str) -> bool:
        return self._column_for(name) is not None

    def _column_for(self, name: str) -> str | None:
        if name in self.data.columns:
            return name
        for col in self.data.columns:
            if col != "time_s" and col.startswith(name + "_") and col in KNOWN_SIGNALS:
                return col
        return None

    def signal(self, name: str) -> np.ndarray:
        """Values of one signal; `name` is a column (``steer_angle_rad``) or its signal
        part (``steer_angle``)."""
        col = self._column_for(name)
        if col is None:
            raise RecordingError(
                f"{self.label}: column {name}: not in this recording "
                f"(columns: {', '.join(self.data.columns)})"
            )
        return self.data[col].to_numpy(dtype=float)

    @property
    def kind(self) -> str:
        return self.meta.get("kind")

    @property
    def pressure_kpa(self) -> float | None:
        p = self.meta.get("pressure_kpa")
        return None if p is None else float(p)

    @property
    def ramp_angle_deg(self) -> float | None:
        a = self.meta.get("ramp_angle_deg")
        return None if a is None else float(a)

    @property
    def ramp_exit_s(self) -> float | None:
        a = self.meta.get("ramp_exit_s")
        return None if a is None else float(a)

    @property
    def label(self) -> str:
        """What error messages call this recording: its file, or meta["name"]."""
        if self.path is not None:
            return str(self.path)
        return str(self.meta.get("name", "<recording>"))

    def main_signal(self) -> str:
        """Name of the column that carries the experiment's response: steer_angle_rad
        (steer_stand), drive_angle_rad (drive_stand), pipe_angle_rad (shell_rock),
        drive_rate_rad_s (ramp)."""
        try:
            return MAIN_SIGNAL[self.kind]
        except KeyError:
            raise RecordingError(f"{self.label}: kind: unknown kind {self.kind!r}")

    def main_values(self) -> np.ndarray:
        """Values of :meth:`main_signal`."""
        return self.signal(self.main_signal())


def sidecar_path(path: str | Path) -> Path:
    """The JSON sidecar belonging to a recording CSV: same folder, same stem, ``.json``."""
    path = Path(path)
    return path.with_suffix(".json") if path.suffix else path.with_name(path.name + ".json")


# --------------------------------------------------------------------------------------
# Low-level CSV table parsing with precise diagnostics
# --------------------------------------------------------------------------------------
def _err(file: Any, where: str, what: str, todo: str | None = None) -> RecordingError:
    msg = f"{file}: {where}: {what}"
    if todo:
        msg += f"; {todo}"
    return RecordingError(msg)


def _read_text(path: Path) -> str:
    if not path.exists():
        raise _err(path, "file", "not found", "check the path")
    if path.is_dir():
        raise _err(path, "file", "is a folder, not a CSV file")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise _err(path, "file", f"cannot be read ({exc.strerror})")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise _err(path, f"line {line}", "not UTF-8 text", "save the file as UTF-8 CSV")
    if not text.strip():
        raise _err(path, "file", "empty file (no header, no data)", "re-export the recording")
    return text


def _split_lines(text: str) -> list[str]:
    """Split on LF, CRLF or lone CR without treating other Unicode separators as breaks."""
    return re.split(r"\r\n|\n|\r", text)


def _fields(line: str) -> list[str]:
    """The comma-separated fields of one CSV line (the csv module only when a field is quoted)."""
    return next(csv.reader([line])) if '"' in line else line.split(",")


def parse_numeric_csv(path: Path, text: str | None = None) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Parse a numeric CSV with a header row.

    Returns (header, values[n_rows, n_cols], line_numbers[n_rows]) where line numbers are
    1-based positions in the file (header = line 1).  Blank lines are skipped.  Raises
    :class:`RecordingError` naming line and column for: header only, rows with too few or
    too many fields (a short *last* line is reported as truncated), empty, non-numeric and
    non-finite cells.
    """
    path = Path(path)
    if text is None:
        text = _read_text(path)
    lines = _split_lines(text)
    numbered = [(i + 1, ln) for i, ln in enumerate(lines) if ln.strip()]
    if not numbered:
        raise _err(path, "file", "empty file (no header, no data)", "re-export the recording")
    header_no, header_line = numbered[0]
    header = [h.strip() for h in next(csv.reader([header_line]))]
    for j, name in enumerate(header):
        if not name:
            raise _err(path, f"line {header_no} (header), column {j + 1}", "empty column name")
    seen: dict[str, int] = {}
    for j, name in enumerate(header):
        if name in seen:
            raise _err(
                path, f"line {header_no} (header)",
                f"column {name} appears twice (columns {seen[name] + 1} and {j + 1})",
                "keep one of them",
            )
        seen[name] = j
    rows = numbered[1:]
    if not rows:
        raise _err(path, "file", "header only, no data rows", "the recording is empty; re-export it")
    ncol = len(header)
    values = np.empty((len(rows), ncol), dtype=float)
    line_numbers = np.empty(len(rows), dtype=np.int64)
    last = len(rows) - 1
    for r, (line_no, line) in enumerate(rows):
        fields = _fields(line)
        if len(fields) != ncol or (r == last and fields[-1].strip() == "" and ncol > 1):
            if r == last and len(fields) <= ncol:
                raise _err(
                    path, f"line {line_no}",
                    f"truncated last line ({len(fields)} of {ncol} fields"
                    + (", last one empty" if len(fields) == ncol else "") + ")",
                    "delete the partial line or re-export the recording",
                )
            raise _err(
                path, f"line {line_no}",
                f"has {len(fields)} field{'s' if len(fields) != 1 else ''} but the header has {ncol}",
                "every row needs one value per column",
            )
        for j, cell in enumerate(fields):
            s = cell.strip()
            if _NUMBER.match(s):
                values[r, j] = float(s)
                continue
            col = header[j]
            if s == "":
                raise _err(path, f"line {line_no}, column {col}", "empty cell", "fill in a number")
            if _NONFINITE.match(s):
                raise _err(
                    path, f"line {line_no}, column {col}",
                    f"non-finite value {s!r} (NaN or infinity)",
                    "remove or interpolate the sample",
                )
            raise _err(
                path, f"line {line_no}, column {col}",
                f"{s[:40]!r} is not a number",
                "fix the cell or delete the row",
            )
        line_numbers[r] = line_no
    return header, values, line_numbers


# --------------------------------------------------------------------------------------
# Semantic checks shared by the reader, the importers and the writer
# --------------------------------------------------------------------------------------
def _suggest_signal(name: str) -> str | None:
    """The known signal an unknown column name most probably meant, or None."""
    lowered = name.lower()
    match = difflib.get_close_matches(lowered, KNOWN_SIGNALS, n=1, cutoff=0.75)
    if match:
        return match[0]
    base = re.sub(r"_(deg|degrees|rad|radians)(_s)?$", "", lowered)
    for known in KNOWN_SIGNALS:
        if known.startswith(base + "_"):
            return known
    return None


def check_columns(file: Any, header: list[str], kind: str | None = None) -> None:
    """First column must be time_s; every other column a known signal; the kind's main
    signal must be present."""
    first = header[0]
    if first != "time_s":
        if first in NATIVE_HEADERS:
            raise _err(
                file, "line 1 (header), column 1",
                f"first column is {first!r}, not 'time_s': this is {NATIVE_HEADERS[first]}",
                "import it with roboball.ingest.importers.read_any / import_native",
            )
        hint = "name it time_s (seconds)" if "time" in first.lower() else "the first column must be time_s (seconds)"
        raise _err(file, "line 1 (header), column 1", f"first column is {first!r}, expected 'time_s'", hint)
    signals = header[1:]
    if not signals:
        raise _err(
            file, "line 1 (header)", "no signal column after time_s",
            f"add one of: {', '.join(KNOWN_SIGNALS)}",
        )
    for j, name in enumerate(signals, start=2):
        if name in KNOWN_SIGNALS:
            continue
        if name == "time_s":
            raise _err(file, f"line 1 (header), column {j}", "time_s appears again after column 1")
        guess = _suggest_signal(name)
        if name.lower().endswith(("_deg", "_deg_s", "_degrees")):
            todo = f"convert degrees to radians and name it {guess}" if guess else "convert degrees to radians"
            raise _err(file, f"line 1 (header), column {j}", f"column {name!r} is in degrees; units must be SI", todo)
        if guess:
            raise _err(file, f"line 1 (header), column {j}", f"unknown signal column {name!r}", f"did you mean {guess!r}?")
        raise _err(
            file, f"line 1 (header), column {j}", f"unknown signal column {name!r}",
            f"known signals: {', '.join(KNOWN_SIGNALS)}",
        )
    if kind in MAIN_SIGNAL and MAIN_SIGNAL[kind] not in signals:
        raise _err(
            file, "line 1 (header)",
            f"missing column {MAIN_SIGNAL[kind]} needed for kind {kind} (columns: {', '.join(header)})",
            "add the column or check the kind",
        )


def check_values(
    file: Any,
    header: list[str],
    values: np.ndarray,
    line_numbers: np.ndarray | None = None,
    kind: str | None = None,
) -> None:
    """Time in seconds and never decreasing, not all equal; angles in radians."""
    n = values.shape[0]
    lines = line_numbers if line_numbers is not None else np.arange(2, n + 2)
    if not np.all(np.isfinite(values)):
        r, j = np.argwhere(~np.isfinite(values))[0]
        raise _err(file, f"line {lines[r]}, column {header[j]}", f"non-finite value {float(values[r, j])}",
                   "remove or interpolate the sample")
    t = values[:, 0]
    dt = np.diff(t)
    pos = dt[dt > 0]
    med = float(np.median(pos)) if pos.size else 0.0
    tmax = float(np.max(np.abs(t)))
    if tmax > NS_TIME_LIMIT or med > NS_STEP_LIMIT:
        raise _err(
            file, "column time_s",
            f"values up to {tmax:.4g} (median step {med:.4g}) look like nanoseconds, not seconds",
            "use the importer (roboball.ingest.importers.read_any) or convert to seconds from the first sample",
        )
    back = np.nonzero(dt < 0)[0]
    if back.size:
        r = back[0] + 1
        raise _err(
            file, f"line {lines[r]}, column time_s",
            f"time goes backwards ({float(t[r]):.9g} s after {float(t[r - 1]):.9g} s on line {lines[r - 1]})",
            "sort the rows by time or remove the out-of-order sample",
        )
    if n < 2:
        raise _err(file, "file", "only one data row; a recording needs at least two samples")
    if not pos.size:
        raise _err(file, "column time_s", f"all {n} timestamps are equal ({float(t[0]):.9g} s)",
                   "the time column is broken; re-export the recording")
    for j, name in enumerate(header):
        if name not in ANGLE_SIGNALS:
            continue
        if name == "drive_angle_rad" and kind == "ramp":
            continue  # the drive joint is continuous: a rolling robot turns it many times
        bad = np.nonzero(np.abs(values[:, j]) > 2 * math.pi)[0]
        if bad.size:
            r = bad[0]
            raise _err(
                file, f"line {lines[r]}, column {name}",
                f"|value| {abs(values[r, j]):.4g} exceeds 2*pi: looks like degrees, not radians",
                "convert to radians (multiply by pi/180)",
            )


def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, (bool, np.bool_))


def check_meta(
    meta: dict,
    file: Any,
    sources: Mapping[str, str] | None = None,
    time_range: tuple[float, float] | None = None,
    allow_unknown_pressure: bool = False,
) -> dict:
    """Validate and complete recording metadata; returns a new dict.

    `allow_unknown_pressure` lets a shell/ramp recording have ``pressure_kpa = None``
    (imported native logs whose pressure was never logged).

    `sources` maps a key to where it came from ("sidecar x.json", "flag --kind") for the
    error message.  A ramp recording without ``ramp_angle_deg`` gets the paper's 16 deg and
    ``ramp_angle_deg_source = "default"``.
    """
    sources = dict(sources or {})
    meta = dict(meta)

    def where(key: str) -> str:
        src = sources.get(key)
        return f"field {key} ({src})" if src else f"field {key}"

    kind = meta.get("kind")
    if kind is None:
        raise _err(file, where("kind"), "missing", f"give one of {', '.join(KINDS)} in the sidecar or with --kind")
    if kind not in KINDS:
        guess = difflib.get_close_matches(str(kind), KINDS, n=1, cutoff=0.6)
        todo = f"did you mean {guess[0]!r}?" if guess else f"valid kinds: {', '.join(KINDS)}"
        raise _err(file, where("kind"), f"unknown kind {kind!r}", todo)

    p = meta.get("pressure_kpa")
    if p is None:
        # An imported native log whose pressure was never logged says so explicitly.
        unknown_ok = allow_unknown_pressure or meta.get("pressure_source") == "unknown"
        if kind in PRESSURE_REQUIRED and not unknown_ok:
            raise _err(
                file, where("pressure_kpa"), f"missing: kind {kind} needs the shell gauge pressure",
                "add pressure_kpa to the sidecar or pass --pressure-kpa",
            )
        meta["pressure_kpa"] = None
    else:
        if not _is_number(p) or not math.isfinite(float(p)):
            raise _err(file, where("pressure_kpa"), f"{p!r} is not a number", "give the gauge pressure in kPa")
        if not (0.0 < float(p) <= MAX_PRESSURE_KPA):
            raise _err(
                file, where("pressure_kpa"),
                f"{p} kPa is outside (0, {MAX_PRESSURE_KPA:g}] kPa",
                "give the shell gauge pressure in kPa (1 psi = 6.895 kPa)",
            )
        meta["pressure_kpa"] = float(p)

    a = meta.get("ramp_angle_deg")
    if a is None:
        meta.pop("ramp_angle_deg", None)
        if kind == "ramp":
            meta["ramp_angle_deg"] = DEFAULT_RAMP_ANGLE_DEG
            meta["ramp_angle_deg_source"] = "default"
    else:
        if not _is_number(a) or not math.isfinite(float(a)):
            raise _err(file, where("ramp_angle_deg"), f"{a!r} is not a number", "give the ramp angle in degrees")
        if not (0.0 < float(a) < 90.0):
            raise _err(file, where("ramp_angle_deg"), f"{a} deg is outside (0, 90) deg", "give the ramp angle in degrees")
        meta["ramp_angle_deg"] = float(a)
        meta.setdefault("ramp_angle_deg_source", sources.get("ramp_angle_deg", "sidecar").split(" ")[0])

    e = meta.get("ramp_exit_s")
    if e is not None:
        if not _is_number(e) or not math.isfinite(float(e)):
            raise _err(file, where("ramp_exit_s"), f"{e!r} is not a number", "give the time in seconds")
        if time_range is not None and float(e) < time_range[0]:
            raise _err(
                file, where("ramp_exit_s"),
                f"{e} s is before the first sample ({time_range[0]:g} s)",
                "give the time the robot left the ramp, in the recording's time base",
            )
        meta["ramp_exit_s"] = float(e)
    return meta


def _read_sidecar(csv_path: Path) -> tuple[dict | None, Path]:
    side = sidecar_path(csv_path)
    if not side.exists():
        return None, side
    try:
        text = side.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError:
        raise _err(side, "file", "sidecar is not UTF-8 text")
    except OSError as exc:
        raise _err(side, "file", f"sidecar cannot be read ({exc.strerror})")
    if not text.strip():
        raise _err(side, "file", "sidecar is empty", 'write e.g. {"kind": "steer_stand", "pressure_kpa": null}')
    try:
        meta = json.loads(text)
    except json.JSONDecodeError as exc:
        raise _err(side, f"line {exc.lineno}, column {exc.colno}", f"malformed JSON ({exc.msg})",
                   'fix the sidecar, e.g. {"kind": "shell_rock", "pressure_kpa": 13.8}')
    if not isinstance(meta, dict):
        raise _err(side, "file", f"sidecar must hold a JSON object, found {type(meta).__name__}",
                   'write e.g. {"kind": "steer_stand", "pressure_kpa": null}')
    return meta, side


def recording_from_columns(
    file: Any,
    header: list[str],
    values: np.ndarray,
    meta: dict,
    line_numbers: np.ndarray | None = None,
    sources: Mapping[str, str] | None = None,
    path: Path | None = None,
) -> Recording:
    """Validate parsed columns plus metadata and build a :class:`Recording`."""
    meta = check_meta(meta, file, sources, time_range=(float(values[0, 0]), float(values[-1, 0])) if len(values) else None)
    check_columns(file, header, meta["kind"])
    check_values(file, header, values, line_numbers, meta["kind"])
    data = pd.DataFrame({name: values[:, j].astype(float) for j, name in enumerate(header)})
    return Recording(data=data, meta=meta, path=path)


# --------------------------------------------------------------------------------------
# Public reader / writer
# --------------------------------------------------------------------------------------
def read_recording(
    path: str | Path,
    kind: str | None = None,
    pressure_kpa: float | None = None,
    ramp_angle_deg: float | None = None,
    ramp_exit_s: float | None = None,
) -> Recording:
    """Read and validate a recording CSV and its sidecar.

    Flags (`kind`, `pressure_kpa`, `ramp_angle_deg`, `ramp_exit_s`) override the
    sidecar; the sidecar may be absent only if `kind` is given.  Raises
    :class:`RecordingError` (one line) on any problem; see the module docstring.
    """
    path = Path(path)
    text = _read_text(path)
    header, values, line_numbers = parse_numeric_csv(path, text)
    # Column problems are reported before sidecar problems: they are the more basic mistake.
    check_columns(path, header, None)
    sidecar, side = _read_sidecar(path)
    if sidecar is None and kind is None:
        raise _err(
            path, f"sidecar {side.name}", "missing (it says which experiment this is)",
            f'write {side.name} with e.g. {{"kind": "steer_stand", "pressure_kpa": null}} or pass --kind',
        )
    meta = dict(sidecar or {})
    sources = {k: f"sidecar {side.name}" for k in meta}
    for key, val in (("kind", kind), ("pressure_kpa", pressure_kpa),
                     ("ramp_angle_deg", ramp_angle_deg), ("ramp_exit_s", ramp_exit_s)):
        if val is not None:
            meta[key] = val
            sources[key] = "flag --" + key.replace("_", "-")
            if key == "ramp_angle_deg":
                meta["ramp_angle_deg_source"] = "flag"
    return recording_from_columns(path, header, values, meta, line_numbers, sources, path=path)


def normalise(rec: Recording) -> Recording:
    """Make a recording safe for numerical work.

    Drops exact duplicate time stamps (keeps the first sample of each), and records in
    ``meta["gaps"]`` every interval ``(start_s, end_s)`` whose step exceeds 3x the median
    step (irregular loggers drop samples; fits must not interpolate across them blindly),
    plus ``meta["n_duplicates_dropped"]`` and ``meta["median_dt_s"]``.  Units stay SI.
    """
    t = rec.time
    keep = np.ones(len(t), dtype=bool)
    if len(t) > 1:
        keep[1:] = np.diff(t) != 0
    data = rec.data.loc[keep].reset_index(drop=True)
    tk = t[keep]
    dt = np.diff(tk)
    meta = dict(rec.meta)
    meta["n_duplicates_dropped"] = int((~keep).sum())
    if dt.size:
        med = float(np.median(dt))
        big = np.nonzero(dt > 3.0 * med)[0]
        meta["gaps"] = [(float(tk[i]), float(tk[i + 1])) for i in big]
        meta["median_dt_s"] = med
    else:
        meta["gaps"] = []
        meta["median_dt_s"] = None
    return Recording(data=data, meta=meta, path=rec.path)


def write_recording(
    path: str | Path,
    data: pd.DataFrame | Recording,
    meta: dict | None = None,
    float_format: str = "repr",
) -> Path:
    """Write a recording CSV and its sidecar (same stem, ``.json``), atomically and with
    deterministic bytes.  The data and metadata are validated first with the same rules
    as the reader, so nothing unreadable is ever written.  Returns the CSV path."""
    path = Path(path)
    if isinstance(data, Recording):
        meta = dict(data.meta) if meta is None else meta
        data = data.data
    if meta is None:
        raise RecordingError(f"{path}: sidecar: no metadata given; pass meta={{'kind': ...}}")
    header = [str(c) for c in data.columns]
    if not header:
        raise _err(path, "data", "no columns")
    try:
        values = data.to_numpy(dtype=float)
    except (TypeError, ValueError) as exc:
        raise _err(path, "data", f"non-numeric column ({exc})")
    if values.shape[0] == 0:
        raise _err(path, "data", "no rows to write")
    rec = recording_from_columns(path, header, values, dict(meta))
    out = pd.DataFrame({h: values[:, j] for j, h in enumerate(header)})
    csv_body = csv_text(out, float_format=float_format)
    json_body = json_dumps_stable(rec.meta)
    # One step for the pair: a crash can leave a CSV without sidecar (refused by the reader),
    # never new data next to an old sidecar.
    write_texts_atomic([(path, csv_body), (sidecar_path(path), json_body)])
    return path
