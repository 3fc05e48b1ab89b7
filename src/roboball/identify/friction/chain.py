"""The stored emcee chain of a friction fit: an HDF5 file that an interrupted fit resumes.

The chain is a resumable checkpoint, never a result.  Its ``roboball_meta`` attribute records
what the chain belongs to (the fit's fingerprint, sampler settings, and the identity of the
code that computes the log-probability, as the caller gives it); a stored chain whose metadata
differs is another fit's and is never continued.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from roboball.errors import RoboballError


def read_meta(path: Path) -> dict | None:
    """The metadata stored with the chain at `path`, None if it has none or is unreadable."""
    import h5py

    try:
        with h5py.File(path, "r") as f:
            s = f.attrs.get("roboball_meta")
            return json.loads(s) if s is not None else None
    except OSError:
        return None


def write_meta(path: Path, meta: dict) -> None:
    """Record what the chain at `path` belongs to."""
    import h5py

    with h5py.File(path, "a") as f:  # checkpoint: the chain file's fit fingerprint
        f.attrs["roboball_meta"] = json.dumps(meta, sort_keys=True)


def steps_to_resume(chain_path: Path, meta: dict, stale: str) -> int:
    """Steps of the chain stored at `chain_path` that the fit described by `meta` continues.

    Args:
        chain_path: the HDF5 chain file (it need not exist).
        meta: what the fit's chain must have been stored with (every key is compared).
        stale: a stored chain of another fit (or an unreadable file) is refused with an error
            (``"refuse"``, for a chain a user keeps) or deleted (``"restart"``, the pipeline's:
            there the chain is a resumable cache of its rule).

    Returns:
        The stored chain's length; 0 when there is none to continue (sample afresh).
    """
    import emcee

    if not chain_path.exists():
        return 0
    stored = read_meta(chain_path)
    try:
        it = emcee.backends.HDFBackend(str(chain_path), name="mcmc", read_only=True).iteration  # checkpoint: read only
    except Exception as exc:   # noqa: BLE001 - an unreadable file is a user-facing problem
        if stale != "restart":
            raise RoboballError(f"{chain_path}: cannot read the stored chain ({exc}); delete it to start afresh")
        it, stored = 0, None
    if it > 0 and (stored is None or {k: stored.get(k) for k in meta} != meta):
        diff = [k for k in meta if stored is None or stored.get(k) != meta[k]]
        if stale != "restart":
            raise RoboballError(f"{chain_path}: holds a chain of a different fit (differs in "
                                f"{', '.join(diff)}); delete it or give another chain path")
        print(f"{chain_path}: the stored chain is of a different fit (differs in {', '.join(diff)}); "
              "sampling afresh", file=sys.stderr)
        it = 0
    if it == 0 and stale == "restart":
        chain_path.unlink()   # the pipeline's cache starts afresh; a user's empty chain is reset by the sampler
    return int(it)
