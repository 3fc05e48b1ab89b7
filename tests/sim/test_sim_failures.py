"""A simulation given a diverging parameter set fails with a clear one-line
message naming the scenario and its parameters, and writes nothing.

Detected faults (roboball.sim.scenarios.simulate): NaN (Drake refuses a NaN force, or the state
turns non-finite), blow-up (|velocity| > 1e3), deep penetration of the ground, and a stuck run
(wall-clock budget).  Checked through `roboball simulate`, through the pipeline's shell-sim stage
and through the Python API.
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from roboball.errors import RoboballError, SimulationError
from roboball.sim.scenarios import simulate
from roboball.sim.spec import SimSpec
from conftest import one_error_line

ROBOBALL = str(Path(sys.executable).parent / "roboball")


def roboball(*args, env=None) -> subprocess.CompletedProcess:
    return subprocess.run([ROBOBALL, *map(str, args)], capture_output=True, text=True, env=env, timeout=300)


@pytest.mark.parametrize("args, what", [
    # injected shell with omega_n = 10^4 rad/s: K_inject far beyond what a 1 ms step can integrate
    (["shell_rock", "--contact", "injected", "--pressure-kpa", "13.8", "--zeta", "0.1", "--omega-n", "10000"],
     "NaN"),
    # a hydroelastic shell 10^5 times softer than eq. 10: it sinks into the ground
    (["shell_rock", "--contact", "hydroelastic", "--pressure-kpa", "13.8", "--zeta", "0.1", "--omega-n", "2.8",
      "--hydro-modulus", "10"], "penetrated the ground"),
])
def test_simulate_diverging_parameters_fail_clearly(tmp_path, args, what):
    out = tmp_path / "div.csv"
    r = roboball("simulate", *args, "--duration", "2", "--out", out)
    assert r.returncode == 3, r.stderr
    msg = one_error_line(r)
    assert what in msg
    for named in ("scenario shell_rock", "pressure 13.8 kPa", "dt 0.001 s", "omega_n"):
        assert named in msg, msg
    assert not out.exists() and not out.with_suffix(".json").exists()


def test_simulate_stuck_run_hits_the_wall_clock_budget(tmp_path):
    out = tmp_path / "slow.csv"
    r = roboball("simulate", "steer_stand", "--duration", "3", "--max-wall-s", "1e-6", "--out", out)
    assert r.returncode == 3
    msg = one_error_line(r)
    assert "simulation stuck" in msg and "scenario steer_stand" in msg and "budget of 1e-06 s" in msg
    assert not out.exists()


def test_shell_sim_stage_fails_instead_of_writing_garbage(tmp_path):
    """The pipeline stage with a regression that puts omega_n at 10^4 rad/s: exit code 3, one
    line naming the scenario and its parameters, no output table."""
    reg = tmp_path / "regression.csv"
    pd.DataFrame({"name": ["zeta_a", "zeta_b", "omega_n_c", "omega_n_d"], "value": [0.2, -0.04, 1e4, 0.0]}).to_csv(reg)
    rel = tmp_path / "run.releases.json"
    rel.write_text(json.dumps({"pressure_kpa": 13.8, "releases": [{"y_release": -0.3}]}))
    out = tmp_path / "sim.csv"
    r = roboball("stage", "shell-sim", "--releases", rel, "--regression", reg, "--contact", "injected",
                 "--duration", "2", "--out-csv", out)
    assert r.returncode == 3, r.stderr
    msg = one_error_line(r)
    assert "scenario shell_rock" in msg and "contact injected" in msg and "omega_n 10000" in msg, msg
    assert set(tmp_path.iterdir()) == {reg, rel}, "no output, no temporary file"


def test_negative_viscous_friction_blows_up_and_says_so():
    """Viscous friction of -500 N m s/rad pumps energy into the drive stand: detected as a blow-up
    within the first chunk, with the friction parameters in the message."""
    spec = SimSpec(kind="drive_stand", friction={"steer": "none", "drive": "viscous"},
                   friction_params={"drive": {"c": -500.0}})
    with pytest.raises(SimulationError) as info:
        simulate(spec, 0.3, 5.0)
    msg = str(info.value)
    assert "\n" not in msg and isinstance(info.value, RoboballError) and info.value.exit_code == 3
    assert "blew up" in msg and "scenario drive_stand" in msg and "'c': -500.0" in msg and "t = 0.500 s" in msg


def test_the_same_run_with_physical_friction_is_fine():
    """Control for the test above: the drive stand with +0.1 N m s/rad swings and decays."""
    spec = SimSpec(kind="drive_stand", friction={"steer": "none", "drive": "viscous"},
                   friction_params={"drive": {"c": 0.1}})
    df = simulate(spec, 0.3, 2.0)
    y = df.drive_angle_rad.to_numpy()
    assert abs(y).max() <= 0.3 + 1e-9 and y.min() < -0.1


def test_wall_clock_budget_from_the_environment(monkeypatch):
    monkeypatch.setenv("ROBOBALL_SIM_MAX_WALL_S", "1e-9")
    with pytest.raises(SimulationError, match=r"simulation stuck: .* over the budget of 1e-09 s \(scenario steer_stand"):
        simulate(SimSpec(kind="steer_stand"), 0.3, 2.0)
    monkeypatch.setenv("ROBOBALL_SIM_MAX_WALL_S", "soon")
    with pytest.raises(SimulationError, match="ROBOBALL_SIM_MAX_WALL_S='soon': not a number"):
        simulate(SimSpec(kind="steer_stand"), 0.3, 2.0)
    monkeypatch.setenv("ROBOBALL_SIM_MAX_WALL_S", "600")
    assert len(simulate(SimSpec(kind="steer_stand"), 0.3, 1.0)) == 101


@pytest.mark.parametrize("args, words", [
    (["--release", "45"], "--release 45: beyond pi rad, looks like degrees"),
    (["--sample-rate-hz", "5000"], "faster than the time step (1000 Hz"),
    (["--dt", "0.05"], "time step above 10 ms"),
    (["--duration", "-1"], "--duration must be positive"),
    (["--max-wall-s", "soon"], "--max-wall-s must be a number"),
])
def test_simulate_bad_flags_refused_before_running(tmp_path, args, words):
    out = tmp_path / "x.csv"
    r = roboball("simulate", "steer_stand", *args, "--out", out)
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr and r.stderr.count("\n") == 1 and words in r.stderr, r.stderr
    assert not out.exists()
