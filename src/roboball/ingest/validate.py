"""The checks every recording passes, whether read, imported or written: its columns (time_s first,
then known signals, the kind's main signal present), its values (time in seconds and never
decreasing, angles in radians) and its metadata (kind, shell pressure, ramp angle and exit
time).  Each failure is a one-line :class:`~roboball.ingest.errors.RecordingError`."""
from __future__ import annotations

import difflib
import math
import re
from typing import Any, Callable, Mapping

import numpy as np

from roboball.ingest.errors import recording_error
from roboball.kinds import ANGLE_SIGNALS, KNOWN_SIGNALS, MAIN_SIGNAL, PRESSURE_REQUIRED, RECORDED, SECOND_SIGNAL

__all__ = ["DEFAULT_RAMP_ANGLE_DEG", "MAX_PRESSURE_KPA", "check_columns", "check_values", "check_meta"]

DEFAULT_RAMP_ANGLE_DEG = 16.0  # robot-facts.md: the paper's ramp
MAX_PRESSURE_KPA = 500.0  # far above any inflatable shell; larger values are unit mistakes
NS_TIME_LIMIT = 1e9  # time_s values beyond this are nanosecond (or epoch) stamps
NS_STEP_LIMIT = 1e6  # a median step of more than 11 days is a nanosecond step

NATIVE_HEADERS = {
    "steer_timestamp": "the authors' native steer-stand log (steer_timestamp, pend_angle)",
    "timestamp": "one of the authors' native logs with timestamps in ns (shell rocking, coupled steer test or "
                 "steer-stand trial)",
}


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
    signal (and its second signal, if it has one) must be present."""
    first = header[0]
    if first != "time_s":
        if first in NATIVE_HEADERS:
            raise recording_error(
                file, "line 1 (header), column 1",
                f"first column is {first!r}, not 'time_s': this is {NATIVE_HEADERS[first]}",
                "import it with roboball.ingest.importers.read_any / import_native",
            )
        hint = "name it time_s (seconds)" if "time" in first.lower() else "the first column must be time_s (seconds)"
        raise recording_error(file, "line 1 (header), column 1", f"first column is {first!r}, expected 'time_s'", hint)
    signals = header[1:]
    if not signals:
        raise recording_error(
            file, "line 1 (header)", "no signal column after time_s",
            f"add one of: {', '.join(KNOWN_SIGNALS)}",
        )
    for j, name in enumerate(signals, start=2):
        if name in KNOWN_SIGNALS:
            continue
        if name == "time_s":
            raise recording_error(file, f"line 1 (header), column {j}", "time_s appears again after column 1")
        guess = _suggest_signal(name)
        if name.lower().endswith(("_deg", "_deg_s", "_degrees")):
            todo = f"convert degrees to radians and name it {guess}" if guess else "convert degrees to radians"
            raise recording_error(file, f"line 1 (header), column {j}", f"column {name!r} is in degrees; units must be SI", todo)
        if guess:
            raise recording_error(file, f"line 1 (header), column {j}", f"unknown signal column {name!r}", f"did you mean {guess!r}?")
        raise recording_error(
            file, f"line 1 (header), column {j}", f"unknown signal column {name!r}",
            f"known signals: {', '.join(KNOWN_SIGNALS)}",
        )
    for needed in (MAIN_SIGNAL.get(kind), SECOND_SIGNAL.get(kind)):
        if needed is not None and needed not in signals:
            raise recording_error(
                file, "line 1 (header)",
                f"missing column {needed} needed for kind {kind} (columns: {', '.join(header)})",
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
        raise recording_error(file, f"line {lines[r]}, column {header[j]}", f"non-finite value {float(values[r, j])}",
                              "remove or interpolate the sample")
    t = values[:, 0]
    dt = np.diff(t)
    pos = dt[dt > 0]
    med = float(np.median(pos)) if pos.size else 0.0
    tmax = float(np.max(np.abs(t)))
    if tmax > NS_TIME_LIMIT or med > NS_STEP_LIMIT:
        raise recording_error(
            file, "column time_s",
            f"values up to {tmax:.4g} (median step {med:.4g}) look like nanoseconds, not seconds",
            "use the importer (roboball.ingest.importers.read_any) or convert to seconds from the first sample",
        )
    back = np.nonzero(dt < 0)[0]
    if back.size:
        r = back[0] + 1
        raise recording_error(
            file, f"line {lines[r]}, column time_s",
            f"time goes backwards ({float(t[r]):.9g} s after {float(t[r - 1]):.9g} s on line {lines[r - 1]})",
            "sort the rows by time or remove the out-of-order sample",
        )
    if n < 2:
        raise recording_error(file, "file", "only one data row; a recording needs at least two samples")
    if not pos.size:
        raise recording_error(file, "column time_s", f"all {n} timestamps are equal ({float(t[0]):.9g} s)",
                              "the time column is broken; re-export the recording")
    for j, name in enumerate(header):
        if name not in ANGLE_SIGNALS:
            continue
        if name == "drive_angle_rad" and kind == "ramp":
            continue  # the drive joint is continuous: a rolling robot turns it many times
        bad = np.nonzero(np.abs(values[:, j]) > 2 * math.pi)[0]
        if bad.size:
            r = bad[0]
            raise recording_error(
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

    kind = _check_kind(meta, file, where)
    _check_pressure(meta, kind, file, where, allow_unknown_pressure)
    _check_ramp_angle(meta, kind, file, where, sources)
    _check_ramp_exit(meta, file, where, time_range)
    return meta


def _check_kind(meta: dict, file: Any, where: Callable[[str], str]) -> str:
    """The recording's kind, which must be one of the recorded kinds."""
    kind = meta.get("kind")
    if kind is None:
        raise recording_error(file, where("kind"), "missing", f"give one of {', '.join(RECORDED)} in the sidecar or with --kind")
    if kind not in RECORDED:
        guess = difflib.get_close_matches(str(kind), RECORDED, n=1, cutoff=0.6)
        todo = f"did you mean {guess[0]!r}?" if guess else f"valid kinds: {', '.join(RECORDED)}"
        raise recording_error(file, where("kind"), f"unknown kind {kind!r}", todo)
    return kind


def _check_pressure(meta: dict, kind: str, file: Any, where: Callable[[str], str], allow_unknown_pressure: bool) -> None:
    """pressure_kpa: a gauge pressure in (0, MAX_PRESSURE_KPA] kPa, or None where it may be unknown."""
    p = meta.get("pressure_kpa")
    if p is None:
        # An imported native log whose pressure was never logged says so explicitly.
        unknown_ok = allow_unknown_pressure or meta.get("pressure_source") == "unknown"
        if kind in PRESSURE_REQUIRED and not unknown_ok:
            raise recording_error(
                file, where("pressure_kpa"), f"missing: kind {kind} needs the shell gauge pressure",
                "add pressure_kpa to the sidecar or pass --pressure-kpa",
            )
        meta["pressure_kpa"] = None
    else:
        if not _is_number(p) or not math.isfinite(float(p)):
            raise recording_error(file, where("pressure_kpa"), f"{p!r} is not a number", "give the gauge pressure in kPa")
        if not (0.0 < float(p) <= MAX_PRESSURE_KPA):
            raise recording_error(
                file, where("pressure_kpa"),
                f"{p} kPa is outside (0, {MAX_PRESSURE_KPA:g}] kPa",
                "give the shell gauge pressure in kPa (1 psi = 6.895 kPa)",
            )
        meta["pressure_kpa"] = float(p)


def _check_ramp_angle(meta: dict, kind: str, file: Any, where: Callable[[str], str], sources: dict) -> None:
    """ramp_angle_deg: in (0, 90) deg; a ramp run without one gets the paper's angle."""
    a = meta.get("ramp_angle_deg")
    if a is None:
        meta.pop("ramp_angle_deg", None)
        if kind == "ramp":
            meta["ramp_angle_deg"] = DEFAULT_RAMP_ANGLE_DEG
            meta["ramp_angle_deg_source"] = "default"
    else:
        if not _is_number(a) or not math.isfinite(float(a)):
            raise recording_error(file, where("ramp_angle_deg"), f"{a!r} is not a number", "give the ramp angle in degrees")
        if not (0.0 < float(a) < 90.0):
            raise recording_error(file, where("ramp_angle_deg"), f"{a} deg is outside (0, 90) deg", "give the ramp angle in degrees")
        meta["ramp_angle_deg"] = float(a)
        meta.setdefault("ramp_angle_deg_source", sources.get("ramp_angle_deg", "sidecar").split(" ")[0])


def _check_ramp_exit(meta: dict, file: Any, where: Callable[[str], str],
                     time_range: tuple[float, float] | None) -> None:
    """ramp_exit_s (optional): a time not before the recording's first sample."""
    e = meta.get("ramp_exit_s")
    if e is not None:
        if not _is_number(e) or not math.isfinite(float(e)):
            raise recording_error(file, where("ramp_exit_s"), f"{e!r} is not a number", "give the time in seconds")
        if time_range is not None and float(e) < time_range[0]:
            raise recording_error(
                file, where("ramp_exit_s"),
                f"{e} s is before the first sample ({time_range[0]:g} s)",
                "give the time the robot left the ramp, in the recording's time base",
            )
        meta["ramp_exit_s"] = float(e)
