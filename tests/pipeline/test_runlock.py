"""roboball.pipeline.runlock: `make figures` clears a stale Snakemake lock only when no other run is alive.

The proof of "no other run" is a kernel flock, held by the exec'd Snakemake for its lifetime and
released by the kernel however the process dies (here: SIGKILL)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from roboball.pipeline import runlock

RUNLOCK = [sys.executable, "-m", "roboball.pipeline.runlock"]


def stale_locks(workdir: Path) -> list[Path]:
    locks = workdir / ".snakemake" / "locks"
    locks.mkdir(parents=True, exist_ok=True)
    paths = [locks / "0.input.lock", locks / "0.output.lock"]
    for p in paths:
        p.write_text("results/x.csv\n")
    return paths


def test_stale_snakemake_locks_are_removed_then_the_command_runs(tmp_path):
    locks = stale_locks(tmp_path)
    r = subprocess.run(RUNLOCK + [sys.executable, "-c", "import os; print(sorted(os.listdir('.snakemake/locks')))"],
                       cwd=tmp_path, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[]"          # the command ran after the locks were cleared
    assert "removed 2 stale Snakemake lock(s)" in r.stderr
    assert not any(p.exists() for p in locks)


def test_a_live_run_keeps_its_locks_and_blocks_a_second_run(tmp_path):
    live = subprocess.Popen(RUNLOCK + ["sleep", "30"], cwd=tmp_path, start_new_session=True)
    try:
        deadline = time.monotonic() + 20
        while not (tmp_path / ".snakemake" / runlock.LOCK_NAME).exists():
            assert time.monotonic() < deadline
            time.sleep(0.02)
        time.sleep(0.3)                       # `sleep` has replaced the wrapper and holds the lock
        locks = stale_locks(tmp_path)         # as a live Snakemake's own locks
        r = subprocess.run(RUNLOCK + ["true"], cwd=tmp_path, capture_output=True, text=True)
        assert r.returncode == 2
        assert "another pipeline run is active" in r.stderr and r.stderr.count("\n") == 1
        assert all(p.exists() for p in locks), "a live run's locks must not be touched"
    finally:
        os.killpg(live.pid, signal.SIGKILL)
        live.wait()
    # Killed: the kernel dropped the flock, so the next run recovers by itself.
    r = subprocess.run(RUNLOCK + ["true"], cwd=tmp_path, capture_output=True, text=True)
    assert r.returncode == 0 and "removed 2 stale" in r.stderr
    assert not any(p.exists() for p in locks)


def test_acquire_is_exclusive_and_released_on_close(tmp_path):
    fd = runlock.acquire(tmp_path)
    assert fd is not None
    assert runlock.acquire(tmp_path) is None
    os.close(fd)
    fd2 = runlock.acquire(tmp_path)
    assert fd2 is not None
    os.close(fd2)


def test_unknown_command_is_a_one_line_error(tmp_path):
    r = subprocess.run(RUNLOCK + ["no-such-program-roboball"], cwd=tmp_path, capture_output=True, text=True)
    assert r.returncode == 2 and "no-such-program-roboball: cannot run" in r.stderr
