"""Run Snakemake under an operating-system lock, so that `make figures` recovers from a killed run
by itself.

A Snakemake run that is killed (SIGKILL, a closed laptop lid, a power cut) cannot clean up: it
leaves its directory lock in ``.snakemake/locks`` and every later run stops with a
LockException until someone runs ``snakemake --unlock`` by hand.  Snakemake cannot tell a
stale lock from a live one, but the kernel can: this wrapper takes an exclusive ``flock`` on
``.snakemake/roboball-run.lock``, which the kernel releases when the process holding it dies,
however it dies.  Holding that lock proves that no other run started through this wrapper is
alive, so any Snakemake lock still present was left by an interrupted run and is removed.
The wrapper then *replaces itself* with Snakemake (``exec``), passing the lock on, so it is
held exactly as long as Snakemake and its jobs run.  (The jobs cut short are rerun thanks to
``--rerun-incomplete`` in the Makefile; every output is written atomically, so nothing
half-written is taken as finished.)

Usage (the Makefile's ``figures`` target)::

    python -m roboball.pipeline.runlock .venv/bin/snakemake --cores 2 ...

Caveat: a Snakemake started directly (not through this wrapper) in the same folder does not
take the flock, so its lock would be treated as stale; start pipeline runs with ``make figures``.
"""
from __future__ import annotations

import fcntl
import os
import sys
import time
from pathlib import Path

STATE_DIR = Path(".snakemake")
LOCK_NAME = "roboball-run.lock"


# A run killed a moment ago may still hold the lock while the kernel tears its jobs down (a Drake
# job's large address space takes a while to free, longer on a loaded machine): wait that long
# before calling the holder a live run.
GRACE_S = 10.0


def acquire(state_dir: Path = STATE_DIR, grace_s: float = 0.0) -> int | None:
    """Take the run lock, trying for up to `grace_s` seconds; the open file descriptor, or None
    if another run holds it."""
    state_dir.mkdir(parents=True, exist_ok=True)
    fd = os.open(state_dir / LOCK_NAME, os.O_RDWR | os.O_CREAT, 0o644)
    deadline = time.monotonic() + grace_s
    while True:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return fd
        except BlockingIOError:
            if time.monotonic() >= deadline:
                os.close(fd)
                return None
            time.sleep(0.1)


def remove_stale_locks(state_dir: Path = STATE_DIR) -> list[Path]:
    """Delete Snakemake's directory locks (call only while holding the run lock); returns them."""
    locks = state_dir / "locks"
    removed = []
    if locks.is_dir():
        for p in sorted(locks.iterdir()):
            if p.is_file() and p.suffix == ".lock":
                p.unlink()
                removed.append(p)
    return removed


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv:
        print("usage: python -m roboball.pipeline.runlock SNAKEMAKE [ARGS...]", file=sys.stderr)
        return 2
    fd = acquire(grace_s=GRACE_S)
    if fd is None:
        print(f"roboball: error: {STATE_DIR / LOCK_NAME}: another pipeline run is active in this folder; "
              "wait for it to finish or stop it", file=sys.stderr)
        return 2
    removed = remove_stale_locks()
    if removed:
        print(f"roboball: removed {len(removed)} stale Snakemake lock(s) left by an interrupted run",
              file=sys.stderr)
    os.set_inheritable(fd, True)
    try:
        os.execvp(argv[0], argv)
    except OSError as exc:
        print(f"roboball: error: {argv[0]}: cannot run ({exc.strerror})", file=sys.stderr)
        return 2
    return 0  # not reached


if __name__ == "__main__":
    sys.exit(main())
