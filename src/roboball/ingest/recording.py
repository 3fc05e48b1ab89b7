"""Recordings: the one format every measured or simulated log is read from and written to.

A recording is a CSV file (first column ``time_s``, then signal columns named
``<signal>_<unit>``) plus a JSON sidecar with the same stem that says what experiment it is
(``kind``) and at which shell pressure (``pressure_kpa``); see
``../shared/specs/recordings.md``.  Simulations write the same format, so measured and
simulated runs go through the same code.

The reader is deliberately strict and explains itself: anything wrong with a file raises
:class:`~roboball.ingest.errors.RecordingError` with ONE line ``"<file>: <where>: <what is wrong>[; <what to do>]"``,
naming the line (1-based, the header is line 1) and column where that makes sense.  It
accepts the harmless quirks of real logs: CRLF line endings, a UTF-8 byte-order mark, blank
lines, and exact duplicate time stamps.  :func:`normalise` then drops the duplicates and
reports gaps so downstream code never divides by a zero time step.

The parts: ``csvtable`` (the CSV table), ``sidecar`` (the JSON sidecar), ``validate`` (the
checks of columns, values and metadata), ``errors`` (RecordingError and its one-line form).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import pandas as pd

from roboball.atomic import csv_text, json_dumps_stable, write_texts_atomic
from roboball.ingest.csvtable import parse_numeric_csv, read_text
from roboball.ingest.errors import RecordingError, recording_error
from roboball.ingest.sidecar import read_sidecar, sidecar_path
from roboball.ingest.validate import check_columns, check_meta, check_values
from roboball.kinds import KNOWN_SIGNALS, MAIN_SIGNAL

__all__ = [
    "Recording",
    "read_recording",
    "write_recording",
    "normalise",
    "recording_from_columns",
]


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
        (steer_stand), drive_angle_rad (drive_stand), pipe_angle_rad (shell_rock,
        steer_coupled), drive_rate_rad_s (ramp)."""
        try:
            return MAIN_SIGNAL[self.kind]
        except KeyError:
            raise RecordingError(f"{self.label}: kind: unknown kind {self.kind!r}")

    def main_values(self) -> np.ndarray:
        """Values of :meth:`main_signal`."""
        return self.signal(self.main_signal())


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
    text = read_text(path)
    header, values, line_numbers = parse_numeric_csv(path, text)
    # Column problems are reported before sidecar problems: they are the more basic mistake.
    check_columns(path, header, None)
    sidecar, side = read_sidecar(path)
    if sidecar is None and kind is None:
        raise recording_error(
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
        raise recording_error(path, "data", "no columns")
    try:
        values = data.to_numpy(dtype=float)
    except (TypeError, ValueError) as exc:
        raise recording_error(path, "data", f"non-numeric column ({exc})")
    if values.shape[0] == 0:
        raise recording_error(path, "data", "no rows to write")
    rec = recording_from_columns(path, header, values, dict(meta))
    out = pd.DataFrame({h: values[:, j] for j, h in enumerate(header)})
    csv_body = csv_text(out, float_format=float_format)
    json_body = json_dumps_stable(rec.meta)
    # One step for the pair: a crash can leave a CSV without sidecar (refused by the reader),
    # never new data next to an old sidecar.
    write_texts_atomic([(path, csv_body), (sidecar_path(path), json_body)])
    return path
