"""The workflow's jobs run with mimalloc preloaded (roboball.pipeline.allocator), which must not
change a result: a hydroelastic shell release, the most allocation-heavy Drake run, gives the
same bytes under both allocators."""
import os
import subprocess
import sys

import pytest

from roboball.pipeline.allocator import ENV, job_preload, mimalloc_library

LIB = mimalloc_library()
needs_lib = pytest.mark.skipif(LIB is None, reason="cmeel-mimalloc is not installed here")

RUN = """
import sys
from roboball.sim.scenarios import simulate
from roboball.sim.spec import ShellParams, SimSpec
spec = SimSpec(kind="shell_rock", contact="hydroelastic", pressure_kpa=6.9,
               shell=ShellParams(zeta=0.25, omega_n=3.3, dissipation_scale=0.5))
simulate(spec, 0.3, 1.0, sample_rate_hz=200.0).to_csv(sys.stdout, float_format="%.17g")
print("mimalloc mapped:", "libmimalloc" in open("/proc/self/maps").read())
"""


@needs_lib
def test_the_preload_adds_mimalloc_after_the_users_own_and_only_once():
    assert job_preload({}) == LIB
    assert job_preload({"LD_PRELOAD": "/opt/x.so"}) == f"/opt/x.so {LIB}"
    assert job_preload({"LD_PRELOAD": f"/opt/x.so:{LIB}"}) is None
    assert job_preload({ENV: "system"}) is None
    assert os.path.basename(LIB) == "libmimalloc.so"


@needs_lib
def test_a_hydroelastic_release_is_byte_identical_under_mimalloc():
    def run(preload):
        env = {k: v for k, v in os.environ.items() if k != "LD_PRELOAD"}
        if preload:
            env["LD_PRELOAD"] = preload
        return subprocess.run([sys.executable, "-c", RUN], env=env, capture_output=True, text=True,
                              check=True).stdout.splitlines()

    plain, fast = run(None), run(job_preload({}))
    assert plain[-1] == "mimalloc mapped: False" and fast[-1] == "mimalloc mapped: True"
    assert len(plain) > 150 and plain[:-1] == fast[:-1]
