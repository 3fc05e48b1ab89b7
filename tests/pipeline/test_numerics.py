"""Every job runs on pinned numeric code paths (roboball.pipeline.numerics), so a result does not
depend on which CPU computed it: the pins are recognised by the installed libraries, and (slow) a
sub-DAG with an emcee fit gives the same bytes under two NumPy dispatch settings of the user's."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from roboball.pipeline.numerics import ENV, PINNED, job_environment

from conftest import REPO

HASH = """
import hashlib, numpy as np
x = np.linspace(-30, 30, 100003)
h = hashlib.sha1()
with np.errstate(all="ignore"):
    for fn in (np.exp, np.sin, np.cos, np.tanh, np.log1p):
        h.update(fn(x).tobytes())
print(h.hexdigest())
"""


def _hash(env_update: dict) -> str:
    env = {k: v for k, v in os.environ.items() if k not in PINNED}
    env.update(env_update)
    return subprocess.run([sys.executable, "-c", HASH], env=env, capture_output=True, text=True, check=True).stdout


def test_jobs_get_the_pins_over_the_users_settings_unless_told_native():
    assert job_environment({"NPY_DISABLE_CPU_FEATURES": "X86_V4"}) == PINNED
    assert job_environment({ENV: "native"}) == {}


def test_a_benchmark_restarts_itself_under_the_pins_once(tmp_path):
    script = tmp_path / "bench.py"
    script.write_text("import os, sys\n"
                      "print('start', flush=True)\n"
                      "from roboball.pipeline.numerics import run_pinned\n"
                      "run_pinned()\n"
                      "print(os.environ.get('OPENBLAS_CORETYPE'), os.environ.get('GLIBC_TUNABLES'), sys.argv[1:])\n")
    env = {k: v for k, v in os.environ.items() if k not in PINNED and k != ENV}
    out = subprocess.run([sys.executable, str(script), "--seed", "3"], env=env, capture_output=True, text=True,
                         check=True).stdout.split("\n")
    assert out[:2] == ["start", "start"]    # one restart, not a loop
    assert out[2] == f"{PINNED['OPENBLAS_CORETYPE']} {PINNED['GLIBC_TUNABLES']} ['--seed', '3']"
    native = subprocess.run([sys.executable, str(script)], env={**env, ENV: "native"}, capture_output=True,
                            text=True, check=True).stdout.split("\n")
    assert native[:2] == ["start", "None None []"]


def test_numpys_pin_is_recognised_by_the_installed_numpy():
    from numpy._core._multiarray_umath import __cpu_features__
    if not __cpu_features__.get("AVX2"):
        pytest.skip("this CPU has no AVX2: NumPy runs its baseline already")
    pinned = {"NPY_DISABLE_CPU_FEATURES": PINNED["NPY_DISABLE_CPU_FEATURES"]}
    # the pin moves the results on a wide CPU: its names are this NumPy's (unknown ones are ignored)
    assert _hash(pinned) != _hash({})


def _content(path: Path):
    """A result's bytes; a fit file's without its own wall times (`timing`, kept out of every
    table for that reason), which differ from run to run."""
    if path.suffix == ".json" and "friction" in path.parts:
        import json
        d = json.loads(path.read_text())
        d.pop("timing", None)
        return json.dumps(d, sort_keys=True)
    return path.read_bytes()


@pytest.mark.slow
def test_an_emcee_fit_and_the_shell_regression_give_the_same_bytes_under_two_dispatch_settings(tmp_path):
    from test_partial_campaigns import partial
    raw = partial(tmp_path / "c", drop=("ramp", "steer_stand"), pressures=(6.9, 20.7))
    venv = Path(sys.executable).parent.parent
    targets = "results/friction/c/drive_majd.json results/identify/shell_regression.csv results/decay/shell_rock_6.9kpa_r1.csv"
    outs = {}
    for name, setting in (("native", None), ("no_avx512_avx2", "X86_V3 X86_V4 AVX512_ICL AVX512_SPR")):
        env = {k: v for k, v in os.environ.items() if k not in PINNED}
        if setting:
            env["NPY_DISABLE_CPU_FEATURES"] = setting
        out = tmp_path / name
        r = subprocess.run(["make", "-s", "-C", str(REPO), "figures", f"VENV={venv}", "STAMP=", f"RAW={raw}",
                            f"OUT={out}", f"SNAKEMAKE_TARGETS={targets} --configfile {REPO / 'configs/config.yaml'} "
                            f"{REPO / 'tests/data/config_partial.yaml'}"], env=env, capture_output=True, text=True,
                           timeout=1800)
        assert r.returncode == 0, r.stderr[-3000:]
        outs[name] = {p.relative_to(out): _content(p) for p in sorted((out / "results").rglob("*"))
                      if p.is_file() and "logs" not in p.parts and "benchmarks" not in p.parts and p.suffix != ".h5"}
    assert outs["native"].keys() == outs["no_avx512_avx2"].keys() and len(outs["native"]) > 5
    differ = [str(k) for k in outs["native"] if outs["native"][k] != outs["no_avx512_avx2"][k]]
    assert not differ, differ
