"""Configs are validated against a schema (and the robot facts against physics) before
anything runs, through the real entry points.

* `roboball simulate` (robot.yaml from $ROBOBALL_CONFIG_DIR): negative mass, negative friction
  coefficients, unknown keys, wrong types, an impossible inertia, a centre of mass above the
  shell centre; each a one-line error naming file and field, exit code 2, nothing written.
* `roboball check-config`: config.yaml with a time step above 10 ms, an unknown key, a wrong type.
* `roboball check-config` on friction priors: bounds below zero, unknown laws and keys, wrong
  types, a law's parameter missing or foreign, swapped bounds, a start outside them.
* `snakemake -n`: the same mistakes in config.yaml, robot.yaml or priors.yaml stop the workflow
  while it is parsed, before the DAG is built.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from conftest import REPO, one_error_line
BIN = Path(sys.executable).parent
ROBOBALL = str(BIN / "roboball")
SNAKEMAKE = str(BIN / "snakemake")


def roboball(*args, env=None) -> subprocess.CompletedProcess:
    return subprocess.run([ROBOBALL, *map(str, args)], capture_output=True, text=True, env=env, timeout=300)


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
    # NaN passes every JSON-Schema bound (each comparison with it is false)
    "nan_mass": (("links", "pendulum", "mass_kg"), float("nan"), "links.pendulum.mass_kg", "not a finite number"),
    "infinite_radius": (("shell", "radius_m"), float("inf"), "shell.radius_m", "not a finite number"),
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
    # NaN passes every JSON-Schema bound
    "nan_ramp_dt": (lambda c: c["ramp"].update(dt_s=float("nan")), ["ramp.dt_s", "not a finite number"]),
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


@pytest.mark.parametrize("case", ["dt_above_10ms", "nan_ramp_dt", "robot:negative_friction"])
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


# --------------------------------------------------------------------------------------------
# friction priors (configs/priors.yaml)
# --------------------------------------------------------------------------------------------
GOOD_PRIORS = {
    "steer": {"stand": {"delta_i": {"type": "uniform", "low": -0.05, "high": 0.25, "start": 0.02},
                        "rest_offset": {"type": "uniform", "low": -0.1, "high": 0.1, "start": 0.0}},
              "viscous": {"c": {"type": "loguniform", "low": 0.001, "high": 10.0, "start": 0.104}},
              "majd": {p: {"type": "loguniform", "low": 0.001, "high": 50.0, "start": 1.0}
                       for p in ("f_w", "f_c", "h_peak", "v_peak", "n")}},
    "drive": {"coulomb_viscous": {"mu_s": {"type": "uniform", "low": 0.0, "high": 5.0, "start": 0.7},
                                  "mu_d": {"type": "lognormal", "median": 0.6, "sigma_log": 0.5, "start": 0.65},
                                  "c": {"type": "loguniform", "low": 0.001, "high": 10.0, "start": 0.1}}},
}
BAD_PRIORS = {  # case -> (edit, field named, words)
    "negative_low": (lambda d: d["drive"]["coulomb_viscous"]["mu_s"].update(low=-1.0),
                     "drive.coulomb_viscous.mu_s.low", "less than the minimum of 0"),
    "loguniform_from_zero": (lambda d: d["steer"]["viscous"]["c"].update(low=0.0),
                             "steer.viscous.c.low", "less than or equal to the minimum of 0"),
    "unknown_law": (lambda d: d["steer"].update(lugre={"c": {"type": "uniform", "low": 0, "high": 1, "start": 0.5}}),
                    "steer", "'lugre' was unexpected"),
    "unknown_key": (lambda d: d["steer"]["viscous"]["c"].update(hgih=3.0), "steer.viscous.c", "'hgih' was unexpected"),
    "wrong_type": (lambda d: d["steer"]["viscous"]["c"].update(start="0.1"), "steer.viscous.c.start",
                   "is not of type 'number'"),
    "missing_parameter": (lambda d: d["steer"]["majd"].pop("v_peak"), "steer.majd", "no prior for v_peak"),
    "foreign_parameter": (lambda d: d["steer"]["viscous"].update(mu_d=dict(d["steer"]["viscous"]["c"])),
                          "steer.viscous", "mu_d is not a parameter of the viscous law"),
    "bounds_swapped": (lambda d: d["steer"]["viscous"]["c"].update(low=20.0), "steer.viscous.c", "is not below high"),
    "start_outside": (lambda d: d["steer"]["viscous"]["c"].update(start=30.0), "steer.viscous.c",
                      "start 30 is outside the bounds"),
    # Majd's law is sampled by its stiction peak (roboball.physics.friction.FIT_PARAMS), not sigma
    "majd_sigma": (lambda d: d["steer"]["majd"].update(sigma=d["steer"]["majd"].pop("h_peak")), "steer.majd",
                   "'sigma' is not one of"),
    # the stand's calibration: both parameters, uniform, start inside (bounds may be negative)
    "stand_missing_offset": (lambda d: d["steer"]["stand"].pop("rest_offset"), "steer.stand",
                             "'rest_offset' is a required property"),
    "stand_not_uniform": (lambda d: d["steer"]["stand"]["delta_i"].update(type="loguniform"), "steer.stand.delta_i.type",
                          "'uniform' was expected"),
    "stand_start_outside": (lambda d: d["steer"]["stand"]["rest_offset"].update(start=0.2), "steer.stand.rest_offset",
                            "start 0.2 is outside the bounds"),
}


def priors_dir(tmp_path: Path, case: str | None) -> Path:
    cfg = tmp_path / "configs"
    shutil.copytree(REPO / "configs", cfg)
    data = json.loads(json.dumps(GOOD_PRIORS))
    if case is not None:
        BAD_PRIORS[case][0](data)
    (cfg / "priors.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    return cfg


def test_good_priors_pass(tmp_path):
    r = roboball("check-config", "--config-dir", priors_dir(tmp_path, None))
    assert r.returncode == 0, r.stderr
    assert "priors.yaml" in r.stdout


@pytest.mark.parametrize("case", sorted(BAD_PRIORS))
def test_check_config_refuses_bad_priors(tmp_path, case):
    cfg = priors_dir(tmp_path, case)
    r = roboball("check-config", "--config-dir", cfg)
    assert r.returncode == 2, r.stdout + r.stderr
    msg = one_error_line(r)
    _, field, words = BAD_PRIORS[case]
    assert msg.startswith(f"{cfg / 'priors.yaml'}: field '{field}'"), msg
    assert words in msg, msg


def test_snakemake_refuses_bad_priors_before_any_job(tmp_path):
    work = _workflow_copy(tmp_path)
    bad = priors_dir(tmp_path / "bad", "start_outside")
    shutil.copy2(bad / "priors.yaml", work / "configs" / "priors.yaml")
    env = {k: v for k, v in os.environ.items() if k != "ROBOBALL_CONFIG_DIR"}
    r = subprocess.run([SNAKEMAKE, "-n", "--cores", "1", "results/identify/shell_regression.csv"], cwd=work,
                       capture_output=True, text=True, env=env, timeout=120)
    assert r.returncode != 0
    text = r.stdout + r.stderr
    assert "priors.yaml: field 'steer.viscous.c': start 30 is outside the bounds" in text, text[-2000:]
    assert not (work / "results").exists()


# --------------------------------------------------------------------------------------------
# the campaign manifest (raw_data/MANIFEST.csv)
# --------------------------------------------------------------------------------------------
def manifest_dir(tmp_path: Path, lines: list[str]) -> Path:
    raw = tmp_path / "raw"
    (raw / "steer_stand").mkdir(parents=True)
    (raw / "steer_stand" / "a.csv").write_text("time_s,steer_angle_rad\n0.0,0.0\n0.01,0.0\n")
    (raw / "other").mkdir()
    (raw / "other" / "a.csv").write_text("time_s,steer_angle_rad\n0.0,0.0\n0.01,0.0\n")
    # an authors' shell log (no pressure in it) and a log whose header no importer knows
    (raw / "other" / "dynamic.csv").write_text("timestamp,ball_roll.position,ball_roll.velocity\n0,0.1,0.0\n"
                                               "10000000,0.1,0.0\n")
    (raw / "other" / "odd.csv").write_text("stamp,angle\n0,0.1\n0.01,0.1\n")
    (raw / "MANIFEST.csv").write_text("\n".join(lines) + "\n")
    return raw


BAD_MANIFESTS = {  # case -> (lines, words of the error)
    "missing_file": (["file,kind,pressure_kpa", "steer_stand/b.csv,steer_stand,"], "line 2: steer_stand/b.csv: file not found"),
    "unknown_kind": (["file,kind,pressure_kpa", "steer_stand/a.csv,steer,"], "line 2: column kind: unknown kind 'steer'"),
    "bad_pressure": (["file,kind,pressure_kpa", "steer_stand/a.csv,shell_rock,2 psi"], "'2 psi' is not a number"),
    "absurd_pressure": (["file,kind,pressure_kpa", "steer_stand/a.csv,shell_rock,13800"], "13800 kPa is outside"),
    "same_stem": (["file,kind,pressure_kpa", "steer_stand/a.csv,steer_stand,", "other/a.csv,steer_stand,"],
                  "line 3: other/a.csv: same name as line 2"),
    "missing_column": (["path,kind", "steer_stand/a.csv,steer_stand"], "line 1 (header): missing column file"),
    "shell_without_pressure": (["file,kind,pressure_kpa", "other/dynamic.csv,shell_rock,"],
                               "line 2: other/dynamic.csv: a shell_rock recording needs its shell pressure: give column "
                               "pressure_kpa (or 'unknown' if it was not logged)"),
    "ramp_pressure_unknown": (["file,kind,pressure_kpa", "steer_stand/a.csv,ramp,unknown"],
                              "line 2: steer_stand/a.csv: a ramp run's pressure cannot be unknown"),
    "header_not_recognised": (["file,kind,pressure_kpa", "other/odd.csv,steer_stand,"],
                              "line 2: other/odd.csv: line 1 (header): not a recording (first column time_s) nor a "
                              "known native log (columns: stamp, angle)"),
    "bad_steer_joint": (["file,kind,pressure_kpa,steer_joint", "other/dynamic.csv,shell_rock,6.9,clamped"],
                        "line 2: column steer_joint: 'clamped'"),
    "empty": (["file,kind,pressure_kpa"], "no recordings listed"),
}


@pytest.mark.parametrize("case", sorted(BAD_MANIFESTS))
def test_bad_manifest_refused_in_one_line(tmp_path, case):
    from roboball.ingest.manifest import read_manifest
    from roboball.errors import ConfigError

    lines, words = BAD_MANIFESTS[case]
    raw = manifest_dir(tmp_path, lines)
    with pytest.raises(ConfigError) as info:
        read_manifest(raw)
    msg = str(info.value)
    assert msg.startswith(f"{raw / 'MANIFEST.csv'}: ") and words in msg and "\n" not in msg, msg


def test_manifest_reads_the_campaign():
    from roboball.ingest.manifest import read_manifest

    m = read_manifest(REPO / "raw_data")
    assert len(m) == 32 and m["shell_rock_13.8kpa_r1"]["kind"] == "shell_rock"
    assert m["shell_rock_13.8kpa_r1"]["pressure_kpa"] == "13.8"
    assert m["steer_coupled_6.9kpa_r2"]["kind"] == "steer_coupled" and m["steer_coupled_6.9kpa_r2"]["pressure_kpa"] == "6.9"


def test_snakemake_refuses_a_bad_manifest_before_any_job(tmp_path):
    work = _workflow_copy(tmp_path)
    raw = manifest_dir(tmp_path, BAD_MANIFESTS["same_stem"][0])
    os.unlink(work / "raw_data")
    os.symlink(raw, work / "raw_data")
    r = subprocess.run([SNAKEMAKE, "-n", "--cores", "1", "results/identify/shell_regression.csv"], cwd=work,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode != 0
    assert "raw_data/MANIFEST.csv: line 3: other/a.csv: same name as line 2" in r.stdout + r.stderr
    assert not (work / "results").exists()
