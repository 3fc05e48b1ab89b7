"""The numeric code paths every job of the workflow runs on, pinned, so that a result does not
depend on which x86-64 CPU computed it.

Several libraries choose their arithmetic at run time by CPU: NumPy's ufuncs (exp, sin, tanh,
arctan2, ...) run AVX-512, AVX2 or baseline SIMD code, OpenBLAS picks its kernels by CPU model
(and splits work by thread), Numba compiles for the host's instruction set, and glibc's libm picks
FMA or plain variants of exp, sin, pow.  Each differs from the others in the last bits, and an emcee
chain turns last bits into different draws (Table I in its 4th digit).  Measured on one machine
(a hash of NumPy's exp, sin, cos, tanh, log1p, arctan2 and a BLAS product and solve over the same
arrays): it changes with AVX-512 off, again with AVX2 off, and with each OpenBLAS core type; glibc's
libm hash changes with its FMA variants off.  So every job runs on the paths every x86-64-v2 machine
has: NumPy at its compiled baseline, OpenBLAS's Nehalem (SSE4.2) kernels on one thread, Numba for a
generic CPU, libm's plain variants.  Drake's own arithmetic is compiled in (no run-time choice).

`ROBOBALL_NUMERICS=native` leaves the environment as it is (faster on a wide CPU; results then
depend on it).  docs/performance.md, "The same bytes on every machine", has the measurements.
"""
from __future__ import annotations

ENV = "ROBOBALL_NUMERICS"
PINNED = {
    # NumPy 2.x dispatch groups above its x86-64-v2 baseline (AVX2/FMA, AVX-512 and its extensions)
    "NPY_DISABLE_CPU_FEATURES": "X86_V3 X86_V4 AVX512_ICL AVX512_SPR",
    "OPENBLAS_CORETYPE": "Nehalem",
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "NUMBA_CPU_NAME": "generic",
    "GLIBC_TUNABLES": "glibc.cpu.hwcaps=-AVX2,-FMA,-AVX,-AVX512F",
}


def job_environment(environ) -> dict:
    """The variables jobs should run with given the environment `environ` (empty with
    ROBOBALL_NUMERICS=native): PINNED, overriding what the user set."""
    if environ.get(ENV, "").strip().lower() == "native":
        return {}
    return dict(PINNED)


def run_pinned() -> None:
    """Restart this Python program under job_environment's variables unless it already has them:
    for a benchmark run outside the workflow (its recordings and diagnoses then get the bits a
    pipeline job would).  NumPy picks its dispatch when imported and glibc reads GLIBC_TUNABLES
    when the process starts, so setting them later would change nothing; hence a new process."""
    import os
    import sys
    wanted = job_environment(os.environ)
    if all(os.environ.get(k) == v for k, v in wanted.items()):
        return
    os.execve(sys.executable, [sys.executable, *sys.argv], {**os.environ, **wanted})
