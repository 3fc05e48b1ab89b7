"""Low-level parsing of a numeric CSV table with precise diagnostics: every problem is a one-line
:class:`~roboball.ingest.errors.RecordingError` naming the line (1-based, the header is line 1)
and the column.  Accepts CRLF line endings, a UTF-8 byte-order mark and blank lines."""
from __future__ import annotations

import csv
import re
from pathlib import Path

import numpy as np

from roboball.ingest.errors import recording_error

__all__ = ["read_text", "split_lines", "fields", "parse_numeric_csv"]

_NUMBER = re.compile(r"^[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?$")
_NONFINITE = re.compile(r"^[+-]?(?:nan|inf|infinity)$", re.IGNORECASE)


def read_text(path: Path) -> str:
    """The file's text (UTF-8, byte-order mark dropped); one-line errors for a missing,
    unreadable, non-UTF-8 or empty file."""
    if not path.exists():
        raise recording_error(path, "file", "not found", "check the path")
    if path.is_dir():
        raise recording_error(path, "file", "is a folder, not a CSV file")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise recording_error(path, "file", f"cannot be read ({exc.strerror})")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise recording_error(path, f"line {line}", "not UTF-8 text", "save the file as UTF-8 CSV")
    if not text.strip():
        raise recording_error(path, "file", "empty file (no header, no data)", "re-export the recording")
    return text


def split_lines(text: str) -> list[str]:
    """Split on LF, CRLF or lone CR without treating other Unicode separators as breaks."""
    return re.split(r"\r\n|\n|\r", text)


def fields(line: str) -> list[str]:
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
        text = read_text(path)
    lines = split_lines(text)
    numbered = [(i + 1, ln) for i, ln in enumerate(lines) if ln.strip()]
    if not numbered:
        raise recording_error(path, "file", "empty file (no header, no data)", "re-export the recording")
    header_no, header_line = numbered[0]
    header = _header(path, header_no, header_line)
    rows = numbered[1:]
    if not rows:
        raise recording_error(path, "file", "header only, no data rows", "the recording is empty; re-export it")
    ncol = len(header)
    values = np.empty((len(rows), ncol), dtype=float)
    line_numbers = np.empty(len(rows), dtype=np.int64)
    last = len(rows) - 1
    for r, (line_no, line) in enumerate(rows):
        _read_row(path, header, line_no, line, r == last, values[r])
        line_numbers[r] = line_no
    return header, values, line_numbers


def _header(path: Path, header_no: int, header_line: str) -> list[str]:
    """The column names; no name may be empty or appear twice."""
    header = [h.strip() for h in next(csv.reader([header_line]))]
    for j, name in enumerate(header):
        if not name:
            raise recording_error(path, f"line {header_no} (header), column {j + 1}", "empty column name")
    seen: dict[str, int] = {}
    for j, name in enumerate(header):
        if name in seen:
            raise recording_error(
                path, f"line {header_no} (header)",
                f"column {name} appears twice (columns {seen[name] + 1} and {j + 1})",
                "keep one of them",
            )
        seen[name] = j
    return header


def _read_row(path: Path, header: list[str], line_no: int, line: str, is_last: bool, out: np.ndarray) -> None:
    """Parse one data line into `out` (one value per column)."""
    ncol = len(header)
    cells = fields(line)
    if len(cells) != ncol or (is_last and cells[-1].strip() == "" and ncol > 1):
        if is_last and len(cells) <= ncol:
            raise recording_error(
                path, f"line {line_no}",
                f"truncated last line ({len(cells)} of {ncol} fields"
                + (", last one empty" if len(cells) == ncol else "") + ")",
                "delete the partial line or re-export the recording",
            )
        raise recording_error(
            path, f"line {line_no}",
            f"has {len(cells)} field{'s' if len(cells) != 1 else ''} but the header has {ncol}",
            "every row needs one value per column",
        )
    for j, cell in enumerate(cells):
        s = cell.strip()
        if _NUMBER.match(s):
            out[j] = float(s)
            continue
        col = header[j]
        if s == "":
            raise recording_error(path, f"line {line_no}, column {col}", "empty cell", "fill in a number")
        if _NONFINITE.match(s):
            raise recording_error(
                path, f"line {line_no}, column {col}",
                f"non-finite value {s!r} (NaN or infinity)",
                "remove or interpolate the sample",
            )
        raise recording_error(
            path, f"line {line_no}, column {col}",
            f"{s[:40]!r} is not a number",
            "fix the cell or delete the row",
        )
