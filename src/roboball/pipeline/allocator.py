"""The memory allocator the workflow's jobs run with.

Drake's discrete contact solvers allocate and free small buffers every time step; under glibc's
malloc that is about 30% of a hydroelastic step (docs/performance.md).  mimalloc (PyPI's
`cmeel-mimalloc`, a dependency), preloaded into every job, makes the Drake jobs 8-17% cheaper and
changes no output byte: allocation order is not arithmetic (tests/pipeline/test_allocator.py runs
a hydroelastic shell release both ways).  `ROBOBALL_MALLOC=system` keeps glibc's malloc.
"""
from __future__ import annotations

import importlib.metadata
import os

ENV = "ROBOBALL_MALLOC"
_LIB = "cmeel.prefix/lib/libmimalloc.so"


def mimalloc_library() -> str | None:
    """The installed mimalloc shared library, or None (not installed, or not a Linux build)."""
    try:
        path = importlib.metadata.distribution("cmeel-mimalloc").locate_file(_LIB)
    except importlib.metadata.PackageNotFoundError:
        return None
    return str(path) if os.path.isfile(path) else None


def job_preload(environ) -> str | None:
    """The LD_PRELOAD value jobs should run with given the environment `environ`, or None to leave
    it as it is: mimalloc added after whatever the user preloads, unless ROBOBALL_MALLOC=system."""
    if environ.get(ENV, "").strip().lower() == "system":
        return None
    lib = mimalloc_library()
    if lib is None:
        return None
    current = [p for p in environ.get("LD_PRELOAD", "").replace(":", " ").split() if p]
    if lib in current:
        return None
    return " ".join(current + [lib])
