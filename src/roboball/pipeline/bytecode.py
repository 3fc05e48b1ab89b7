"""Compile the package's own modules once per workflow run, for every job to load.

Where PYTHONDONTWRITEBYTECODE is set (as on the machines we measured), Python never caches the
code it compiles, so every job recompiled the roboball modules it imports: 0.4-0.6 s a job for
the diagnosis and simulation stages, on a DAG of some hundred jobs.  The environment's installed
packages are compiled when `.venv` is made (the Makefile's --compile-bytecode); the package's
source is edited, so it is compiled here instead, while Snakemake builds the DAG.  Only files whose
source is newer than their cache are compiled; an edited file a job imports before the next run is
compiled in memory as usual (Python checks the source's time and size against the cache).
"""
from __future__ import annotations

import compileall
from pathlib import Path

PACKAGE_ROOT = Path(__file__).resolve().parents[1]        # .../src/roboball


def compile_package(root: Path = PACKAGE_ROOT) -> bool:
    """Write the __pycache__ of every module under `root` that lacks a current one; False when the
    folder cannot be written (a read-only install: jobs then compile in memory, as before)."""
    try:
        return bool(compileall.compile_dir(str(root), quiet=2, workers=1))
    except OSError:
        return False
