"""Atomic, deterministic file output.

Every file the pipeline writes goes through here so that a crash, a full disk or an
exception half-way through never leaves a half-written output behind: the content is
written to a temporary file in the *same* directory (so the final rename stays on one
file system), flushed and fsync'ed, and only then moved over the target with
:func:`os.replace`, which is atomic on POSIX and Windows.  On any exception the temporary
file is removed and the target is left untouched.

The writers also make the bytes deterministic (identical input gives byte-identical
files): JSON with sorted keys and Python's shortest round-trip float repr, CSV with one
fixed float format and ``\\n`` line endings.  Reproducible outputs can then be compared by
hash.
"""
from __future__ import annotations

import contextlib
import csv
import errno
import io
import json
import math
import os
import tempfile
from pathlib import Path
from typing import Any, Iterator

import numpy as np

__all__ = [
    "atomic_write",
    "write_text_atomic",
    "write_texts_atomic",
    "savefig_atomic",
    "write_bytes_atomic",
    "write_json_atomic",
    "write_csv_atomic",
    "json_dumps_stable",
    "csv_text",
    "format_float",
]


def _current_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _not_a_folder(path: Path) -> None:
    """Refuse a target that is an existing folder before anything is staged (the rename would
    fail naming the temporary file, not the path the user gave)."""
    if path.is_dir():
        raise IsADirectoryError(errno.EISDIR, "is a folder; give a file name", str(path))


def output_folder(path: str | os.PathLike, create: bool = True, files: tuple = ()) -> Path:
    """`path` as an output folder: refused when it, or a folder above it, is a file, when the
    nearest existing one cannot be written, or when one of the `files` it will hold is a folder;
    else created (with `create`; a command checks first, before any work, and creates the folder
    only when it has something to write, so a refused run leaves nothing half-written)."""
    path = Path(path)
    for p in (path, *path.parents):
        if p.exists():
            if not p.is_dir():
                why = "is a file; give a folder for the output" if p == path else f"is a file, so {path} cannot be a folder"
                raise NotADirectoryError(errno.ENOTDIR, why, str(p))
            if not os.access(p, os.W_OK | os.X_OK):
                raise PermissionError(errno.EACCES, "cannot be written (read-only or no permission)", str(p))
            break
    for name in files:
        _not_a_folder(path / name)
    if create:
        path.mkdir(parents=True, exist_ok=True)
    return path


@contextlib.contextmanager
def atomic_write(path: str | os.PathLike, mode: str = "w", encoding: str = "utf-8") -> Iterator[Any]:
    """Open a temporary file next to `path`; on success move it over `path` atomically.

    `mode` is "w" (text, UTF-8, no newline translation) or "wb" (binary).  The file is
    flushed and fsync'ed before the rename.  If the body raises, the temporary file is
    deleted, `path` is not touched, and the exception propagates.
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_write: unsupported mode {mode!r} (use 'w' or 'wb')")
    path = Path(path)
    _not_a_folder(path)
    directory = path.parent if str(path.parent) else Path(".")
    directory.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
    try:
        if mode == "wb":
            fh = os.fdopen(fd, "wb")
        else:
            fh = os.fdopen(fd, "w", encoding=encoding, newline="")
        with fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        # mkstemp creates 0600 files; give the result the permissions a normal open() would.
        os.chmod(tmp_name, 0o666 & ~_current_umask())
        os.replace(tmp_name, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp_name)
        raise
    # Make the rename itself durable where the platform allows it.
    with contextlib.suppress(OSError, AttributeError):
        dir_fd = os.open(directory, os.O_RDONLY)
        try:
            os.fsync(dir_fd)
        finally:
            os.close(dir_fd)


def write_text_atomic(path: str | os.PathLike, text: str) -> Path:
    """Write `text` (UTF-8, newlines written exactly as given) atomically; returns the path."""
    with atomic_write(path, "w") as fh:
        fh.write(text)
    return Path(path)


def write_texts_atomic(files: list[tuple[str | os.PathLike, str]]) -> list[Path]:
    """Write several files that only make sense together (a recording CSV and its sidecar) so
    that an interruption never leaves a mix of old and new files that reads as a valid set.

    All contents go to temporary files first (fsync'ed).  Then the existing targets after the
    first are deleted, the first is moved into place, and the others follow.  Every state a crash
    can leave is either the old set, the new set, or a set with a file missing (which readers
    refuse), never new data with old metadata.  On an exception before the renames nothing
    changes.  Returns the paths."""
    staged: list[tuple[str, Path]] = []
    for path, _ in files:
        _not_a_folder(Path(path))
    try:
        for path, text in files:
            path = Path(path)
            directory = path.parent if str(path.parent) else Path(".")
            directory.mkdir(parents=True, exist_ok=True)
            fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
            staged.append((tmp_name, path))
            with os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
                fh.write(text)
                fh.flush()
                os.fsync(fh.fileno())
            os.chmod(tmp_name, 0o666 & ~_current_umask())
        for _, path in staged[1:]:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(path)
        for tmp_name, path in staged:
            os.replace(tmp_name, path)
    except BaseException:
        for tmp_name, _ in staged:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp_name)
        raise
    return [path for _, path in staged]


def savefig_atomic(fig, path: str | os.PathLike, **savefig_kwargs) -> Path:
    """``fig.savefig`` through a temporary file next to `path`, renamed into place when complete
    (the format comes from the suffix unless ``format=`` is given).  Returns the path."""
    path = Path(path)
    fmt = savefig_kwargs.pop("format", None) or path.suffix.lstrip(".") or None
    with atomic_write(path, "wb") as fh:
        fig.savefig(fh, format=fmt, **savefig_kwargs)
    return path


def write_bytes_atomic(path: str | os.PathLike, data: bytes) -> Path:
    """Write raw bytes atomically; returns the path."""
    with atomic_write(path, "wb") as fh:
        fh.write(data)
    return Path(path)


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating):
        return float(obj)
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (Path, os.PathLike)):
        return os.fspath(obj)
    if isinstance(obj, (set, frozenset)):
        return sorted(obj)
    raise TypeError(f"object of type {type(obj).__name__} is not JSON serialisable")


def _normalise_json(obj: Any) -> Any:
    """Turn tuples into lists and numpy scalars into Python numbers, recursively."""
    if isinstance(obj, dict):
        return {str(k): _normalise_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_normalise_json(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return [_normalise_json(v) for v in obj.tolist()]
    if isinstance(obj, (np.floating, np.integer, np.bool_)):
        return _json_default(obj)
    if isinstance(obj, float) and not math.isfinite(obj):
        raise ValueError(f"non-finite float {obj!r} cannot be written to JSON")
    return obj


def json_dumps_stable(obj: Any, indent: int | None = 2) -> str:
    """Serialise to JSON deterministically: sorted keys, shortest round-trip floats,
    no NaN/inf (they are not JSON), trailing newline."""
    text = json.dumps(
        _normalise_json(obj),
        sort_keys=True,
        indent=indent,
        ensure_ascii=False,
        allow_nan=False,
        default=_json_default,
        separators=(",", ": ") if indent is not None else (",", ":"),
    )
    return text + "\n"


def write_json_atomic(path: str | os.PathLike, obj: Any, indent: int | None = 2) -> Path:
    """Write `obj` as stable JSON (see :func:`json_dumps_stable`) atomically."""
    return write_text_atomic(path, json_dumps_stable(obj, indent=indent))


def format_float(x: float, float_format: str = "repr") -> str:
    """Format one float: "repr" gives Python's shortest string that round-trips exactly;
    any printf-style format (e.g. "%.9g") is applied as is."""
    x = float(x)
    if float_format == "repr":
        if x == 0.0:
            return "0.0" if math.copysign(1.0, x) > 0 else "-0.0"
        return repr(x)
    return float_format % x


def _format_column(values: Any, float_format: str) -> list[str]:
    arr = np.asarray(values)
    if arr.dtype.kind == "f":
        if float_format == "repr":
            return [format_float(v) for v in arr.tolist()]
        return [float_format % v for v in arr.tolist()]
    if arr.dtype.kind in "iub":
        return [str(v) for v in arr.tolist()]
    out = []
    for v in arr.tolist():
        if isinstance(v, float):
            out.append(format_float(v, float_format))
        elif v is None:
            out.append("")
        else:
            out.append(str(v))
    return out


def csv_text(df, float_format: str = "repr") -> str:
    """Render a DataFrame as CSV text (header row, no index, ``\\n`` line endings) with a
    fixed float format, so identical frames always give identical bytes."""
    columns = [str(c) for c in df.columns]
    formatted = [_format_column(df[c].to_numpy(), float_format) for c in df.columns]
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(columns)
    if formatted:
        writer.writerows(zip(*formatted))
    return buf.getvalue()


def write_csv_atomic(df, path: str | os.PathLike, float_format: str = "repr") -> Path:
    """Write a DataFrame as CSV atomically and deterministically.

    `float_format` is "repr" (default: exact, shortest round-trip) or a printf format such
    as "%.9g".  The index is not written.
    """
    return write_text_atomic(path, csv_text(df, float_format=float_format))
