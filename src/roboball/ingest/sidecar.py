"""The JSON sidecar of a recording CSV: same folder, same stem, ``.json``; it says what experiment
the recording is (``kind``) and at which shell pressure (``pressure_kpa``)."""
from __future__ import annotations

import json
from pathlib import Path

from roboball.ingest.errors import recording_error

__all__ = ["sidecar_path", "read_sidecar"]


def sidecar_path(path: str | Path) -> Path:
    """The JSON sidecar belonging to a recording CSV: same folder, same stem, ``.json``."""
    path = Path(path)
    return path.with_suffix(".json") if path.suffix else path.with_name(path.name + ".json")


def read_sidecar(csv_path: Path) -> tuple[dict | None, Path]:
    """The sidecar's JSON object (None if there is no sidecar) and its path; one-line errors for
    a sidecar that is unreadable, empty, not JSON or not an object."""
    side = sidecar_path(csv_path)
    if not side.exists():
        return None, side
    try:
        text = side.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError:
        raise recording_error(side, "file", "sidecar is not UTF-8 text")
    except OSError as exc:
        raise recording_error(side, "file", f"sidecar cannot be read ({exc.strerror})")
    if not text.strip():
        raise recording_error(side, "file", "sidecar is empty", 'write e.g. {"kind": "steer_stand", "pressure_kpa": null}')
    try:
        meta = json.loads(text)
    except json.JSONDecodeError as exc:
        raise recording_error(side, f"line {exc.lineno}, column {exc.colno}", f"malformed JSON ({exc.msg})",
                              'fix the sidecar, e.g. {"kind": "shell_rock", "pressure_kpa": 13.8}')
    if not isinstance(meta, dict):
        raise recording_error(side, "file", f"sidecar must hold a JSON object, found {type(meta).__name__}",
                              'write e.g. {"kind": "steer_stand", "pressure_kpa": null}')
    return meta, side
