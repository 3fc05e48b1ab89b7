"""The one error a bad recording raises, and the one-line form of its message
(``"<file>: <where>: <what is wrong>[; <what to do>]"``, see roboball.ingest.recording)."""
from __future__ import annotations

from typing import Any

from roboball.errors import RoboballError

__all__ = ["RecordingError", "recording_error"]


class RecordingError(RoboballError):
    """A recording (CSV or sidecar) is missing, malformed or physically implausible."""


def recording_error(file: Any, where: str, what: str, todo: str | None = None) -> RecordingError:
    """The error for `file`: what is wrong `where` (a line, a column, a field), and what to do."""
    msg = f"{file}: {where}: {what}"
    if todo:
        msg += f"; {todo}"
    return RecordingError(msg)
