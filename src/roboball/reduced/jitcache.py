"""Numba's on-disk cache for the compiled loops of roboball.reduced (`cached_jit`).

Numba checks a cached kernel against the stamp of the file that defines it only, while the
kernels hold the laws of roboball.physics compiled into them: after an edit of a law they would
load the old machine code and disagree with NumPy.  So the cache lives in a folder named by a
hash of every source the kernels are built from (:func:`kernel_cache_dir`); an edit anywhere
there compiles afresh.
"""
from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numba
from numba import njit

__all__ = ["CACHE_DIR", "cached_jit", "kernel_cache_dir"]


def kernel_cache_dir() -> str:
    """The folder of the cached kernels: under the user's NUMBA_CACHE_DIR if set, else beside
    this file, named by a hash of the bytes of roboball/physics/*.py and roboball/reduced/*.py
    (everything compiled into a kernel lives there)."""
    here = Path(__file__).resolve().parent
    digest = hashlib.sha256()
    for folder in (here.parent / "physics", here):
        for source in sorted(folder.glob("*.py")):
            digest.update(source.name.encode())
            digest.update(source.read_bytes())
    base = numba.config.CACHE_DIR or str(here / "__pycache__")
    return os.path.join(base, f"roboball-kernels-{digest.hexdigest()[:16]}")


CACHE_DIR = kernel_cache_dir()


def cached_jit(**options):
    """njit with cache=True, cached in CACHE_DIR.  Numba fixes a function's cache folder when it
    is decorated, from numba.config.CACHE_DIR; it is set for that moment only, so other Numba
    users in the process keep their own."""
    def decorate(fn):
        saved = numba.config.CACHE_DIR
        numba.config.CACHE_DIR = CACHE_DIR
        try:
            return njit(cache=True, **options)(fn)
        finally:
            numba.config.CACHE_DIR = saved
    return decorate
