"""Issue 8: configs are validated against a schema (and the robot facts against physics) before
anything runs, through the real entry points.

* `roboball simulate` (robot.yaml from $ROBOBALL_CONFIG_DIR): negative mass, negative friction
  coefficients, unknown keys, wrong types, an impossible inertia, a centre of mass above the
  shell centre; each a one-line error naming file and field, exit code 2, nothing written.
* `roboball check-config`: config.yaml with a time step above 10 ms, an unknown key, a wrong type.
* `snakemake -n`: the same mistakes in config.yaml or robot.yaml stop the workflow while it is
  parsed, before the DAG is built.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
ROBOBALL = str(BIN / "roboball")
SNAKEMAKE = str(BIN / "snakemake")


def roboball(*args, env=None) -> subprocess.CompletedProcess:
    return subprocess.run([ROBOBALL, *map(str, args)], capture_output=True, text=True, env=env, timeout=300)


def one_error_line(r: subprocess.CompletedProcess) -> str:
    """The single line a user error must produce on stderr."""
    assert "Traceback" not in r.stderr, r.stderr
    lines = [l for l in r.stderr.splitlines() if l.strip() and "Warning" not in l and "WARNING" not in l]
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("roboball: error: "), lines[0]
    return lines[0][len("roboball: error: "):]


# --------------------------------------------------------------------------------------------
# robot facts, through roboball simulate
# --------------------------------------------------------------------------------------------
def _robot_edit(data, path, value):
    node = data
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value


BAD_ROBOT = {  # case -> (path in robot.yaml, new value, field named, words in the message)
    "negative_mass": (("links", "pendulum", "mass_kg"), -1.2, "links.pendulum.mass_kg", "less than or equal to"),
    "negative_friction": (("friction_table1", "viscous", "c"), -0.1, "friction_table1.viscous.c", "less than the minimum"),
    "negative_majd": (("friction_table1", "majd_drive", "f_c"), -1.0, "friction_table1.majd_drive.f_c", "minimum"),
    "unknown_key": (("shell", "colour"), "red", "shell", "'colour' was unexpected"),
    "wrong_type": (("shell", "radius_m"), "0.3 m", "shell.radius_m", "is not of type 'number'"),
    "impossible_inertia": (("links", "pendulum", "inertia_kg_m2"), [0.5, 0.01, 0.01], "links.pendulum.inertia_kg_m2",
                           "impossible for a rigid body"),
    "com_above_centre": (("links", "pendulum", "com_m"), [0.0, 0.0, 0.4], "links", "no rest"),
}


def bad_config_dir(tmp_path: Path, case: str) -> Path:
    cfg = tmp_path / "configs"
    shutil.copytree(REPO / "configs", cfg)
    data = yaml.safe_load((cfg / "robot.yaml").read_text())
    path, value, _, _ = BAD_ROBOT[case]
    _robot_edit(data, path, value)
    (cfg / "robot.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    return cfg


@pytest.mark.parametrize("case", sorted(BAD_ROBOT))
def test_simulate_refuses_bad_robot_facts(tmp_path, case):
    cfg = bad_config_dir(tmp_path, case)
    out = tmp_path / "run.csv"
    r = roboball("simulate", "steer_stand", "--duration", "0.2", "--out", out,
                 env={**os.environ, "ROBOBALL_CONFIG_DIR": str(cfg)})
    assert r.returncode == 2, r.stderr
    msg = one_error_line(r)
    _, _, field, words = BAD_ROBOT[case]
    assert msg.startswith(f"{cfg / 'robot.yaml'}: field"), msg
    assert field in msg and words in msg, msg
    assert not out.exists()


def test_simulate_with_good_facts_from_a_config_dir(tmp_path):
    """The same route with an unmodified copy works (the failures above are the edits)."""
    cfg = tmp_path / "configs"
    shutil.copytree(REPO / "configs", cfg)
    r = roboball("simulate", "steer_stand", "--duration", "0.2", "--out", tmp_path / "ok.csv",
                 env={**os.environ, "ROBOBALL_CONFIG_DIR": str(cfg)})
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "ok.csv").exists() and (tmp_path / "ok.json").exists()


# --------------------------------------------------------------------------------------------
# pipeline configs: checked before any job runs
# --------------------------------------------------------------------------------------------
def _workflow_copy(tmp_path: Path) -> Path:
    work = tmp_path / "wf"
    work.mkdir()
    shutil.copy2(REPO / "Snakefile", work / "Snakefile")
    shutil.copytree(REPO / "workflow", work / "workflow")
    shutil.copytree(REPO / "configs", work / "configs")
    os.symlink(REPO / "raw_data", work / "raw_data")
    return work


BAD_PIPELINE_CONFIG = {  # case -> (edit of config.yaml, words of the error)
    "dt_above_10ms": (lambda c: c["shell"].update(dt_s=0.02), ["0.02 is greater than the maximum of 0.01"]),
    "ramp_dt_above_10ms": (lambda c: c["ramp"].update(dt_s=0.05), ["0.05 is greater than the maximum of 0.01"]),
    "unknown_key": (lambda c: c.update(sead=1), ["'sead' was unexpected"]),
    "wrong_type": (lambda c: c.update(seed="12345"), ["'12345' is not of type 'integer'"]),
}


@pytest.mark.parametrize("case", sorted(BAD_PIPELINE_CONFIG))
def test_check_config_refuses_bad_pipeline_config(tmp_path, case):
    cfg = tmp_path / "configs"
    shutil.copytree(REPO / "configs", cfg)
    data = yaml.safe_load((cfg / "config.yaml").read_text())
    edit, words = BAD_PIPELINE_CONFIG[case]
    edit(data)
    (cfg / "config.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    r = roboball("check-config", "--config-dir", cfg)
    assert r.returncode == 2
    msg = one_error_line(r)
    assert msg.startswith(f"{cfg / 'config.yaml'}: field")
    assert all(w in msg for w in words), msg


def test_check_config_accepts_the_repository_configs():
    r = roboball("check-config")
    assert r.returncode == 0, r.stderr
    assert "robot.yaml" in r.stdout and "config.yaml" in r.stdout


@pytest.mark.parametrize("case", ["dt_above_10ms", "unknown_key", "robot:negative_friction", "robot:negative_mass"])
def test_snakemake_refuses_bad_configs_before_any_job(tmp_path, case):
    work = _workflow_copy(tmp_path)
    if case.startswith("robot:"):
        bad = bad_config_dir(tmp_path / "bad", case.split(":")[1])
        shutil.copy2(bad / "robot.yaml", work / "configs" / "robot.yaml")
        _, _, field, words = BAD_ROBOT[case.split(":")[1]]
        expected = [str(work / "configs" / "robot.yaml"), field, words]
    else:
        data = yaml.safe_load((work / "configs" / "config.yaml").read_text())
        edit, expected = BAD_PIPELINE_CONFIG[case]
        edit(data)
        (work / "configs" / "config.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    env = {k: v for k, v in os.environ.items() if k != "ROBOBALL_CONFIG_DIR"}
    r = subprocess.run([SNAKEMAKE, "-n", "--cores", "1", "results/identify/shell_regression.csv"], cwd=work,
                       capture_output=True, text=True, env=env, timeout=120)
    assert r.returncode != 0
    text = r.stdout + r.stderr
    assert all(w in text for w in expected), text[-2000:]
    assert "Building DAG of jobs" not in text, "the DAG was built before the configs were checked"
    assert not (work / "results").exists()
