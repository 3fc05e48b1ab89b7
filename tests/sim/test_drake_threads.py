"""Drake runs in threads (the diagnosis runs its baseline and augmented model, and its two steer
settings, side by side): a fresh process's first contexts made in two threads at once must not
deadlock on Drake's once-per-process warning (roboball.sim.scenarios.DRAKE_SETUP), and a run
in a thread gives the same bits as one alone."""
import subprocess
import sys

import numpy as np

SCRIPT = """
from concurrent.futures import ThreadPoolExecutor
from roboball.sim.scenarios import simulate
from roboball.sim.spec import SimSpec
spec = SimSpec(kind="shell_rock", contact="point", friction={"steer": "none", "drive": "none"})
with ThreadPoolExecutor(4) as pool:
    runs = list(pool.map(lambda release: simulate(spec, release, 0.2), [0.2, 0.25, 0.3, 0.35]))
print(len(runs))
"""


def test_threads_making_a_fresh_process_s_first_drake_runs_finish():
    # a child of its own each time: the warning is said once per process.  Without the lock
    # most such children hung (a race: 3 of 4 with two threads)
    for _ in range(3):
        out = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=60)
        assert out.returncode == 0, out.stderr
        assert out.stdout.strip() == "4"


def test_a_run_in_a_thread_is_the_same_as_one_alone():
    from concurrent.futures import ThreadPoolExecutor

    from roboball.sim.scenarios import simulate
    from roboball.sim.spec import SimSpec

    spec = SimSpec(kind="shell_rock", contact="point", friction={"steer": "majd", "drive": "none"})
    alone = [simulate(spec, r, 0.5) for r in (0.2, 0.35)]
    with ThreadPoolExecutor(2) as pool:
        side_by_side = list(pool.map(lambda r: simulate(spec, r, 0.5), (0.2, 0.35)))
    for a, b in zip(alone, side_by_side):
        assert np.array_equal(a.to_numpy(), b.to_numpy())
