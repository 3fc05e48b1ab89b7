"""`roboball diagnose` refuses bad calibration inputs, short coupled logs and unusable output
folders before any work: one line naming the file and the field or row, exit code 2, and no
output folder left behind (found by feeding corrupted copies of the real logs to the command)."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import REAL_DATA, REPO, one_error_line

ROBOBALL = str(Path(sys.executable).parent / "roboball")
STEER = REPO / "raw_data" / "steer_stand" / "steer_stand_r1.csv"
SHELL = REPO / "raw_data" / "shell_rock" / "shell_rock_10.3kpa_r1.csv"
COUPLED = REAL_DATA / "steer_coupled_20250429_165825.csv"
MAJD = {"f_w": 0.2, "f_c": 0.45, "sigma": 10.0, "omega_c": 0.1, "n": 1.6}
REGRESSION = {"zeta_a": 0.28, "zeta_b": 0.0033, "omega_n_c": 4.06, "omega_n_d": -0.056}


def roboball(*args) -> subprocess.CompletedProcess:
    return subprocess.run([ROBOBALL, *map(str, args)], capture_output=True, text=True, timeout=300)


def refused(r: subprocess.CompletedProcess, out: Path, *words: str) -> None:
    assert r.returncode == 2, r.stderr
    line = one_error_line(r)
    for w in words:
        assert w in line, line
    assert not out.exists(), sorted(p.name for p in out.iterdir())


def regression_csv(path: Path, **values) -> Path:
    rows = {**REGRESSION, **values}
    path.write_text("name,value\n" + "".join(f"{k},{v}\n" for k, v in rows.items()))
    return path


@pytest.mark.parametrize("bad, words", [
    ({"omega_c": 0.0}, ("'omega_c'", "must be > 0")),
    ({"n": -2.0}, ("'n'", "must be > 0")),
    ({"f_c": -0.3}, ("'f_c'", "must be >= 0")),
])
def test_a_friction_fit_with_impossible_values_is_refused(tmp_path, bad, words):
    fit = tmp_path / "steer_fit.json"
    fit.write_text(json.dumps({**MAJD, **bad}))
    out = tmp_path / "out"
    r = roboball("diagnose", STEER, "--friction-steer", fit, "--no-drake", "--out", out)
    refused(r, out, "steer_fit.json", *words)


def test_an_output_file_that_is_a_folder_is_refused_before_any_file_is_written(tmp_path):
    out = tmp_path / "out"
    (out / "report.md").mkdir(parents=True)
    r = roboball("diagnose", STEER, "--no-drake", "--out", out)
    assert r.returncode == 2, r.stderr
    assert "report.md: is a folder" in one_error_line(r)
    assert sorted(p.name for p in out.iterdir()) == ["report.md"]


def test_a_pressure_flag_stands_in_for_a_sidecar_without_one(tmp_path):
    """The flag is read when the command decides which diagnosis the file needs: a bad value is
    named as the flag's, not as a missing sidecar field."""
    rec = tmp_path / "shell.csv"
    shutil.copy(SHELL, rec)
    side = json.loads(SHELL.with_suffix(".json").read_text())
    del side["pressure_kpa"]
    rec.with_suffix(".json").write_text(json.dumps(side))
    out = tmp_path / "out"
    r = roboball("diagnose", rec, "--pressure-kpa", "-5", "--no-drake", "--out", out)
    refused(r, out, "shell.csv", "--pressure-kpa", "outside")


@pytest.mark.skipif(not COUPLED.is_file(), reason=f"real coupled log not found in {REAL_DATA}")
@pytest.mark.parametrize("rows, zeta_a, words", [
    (10, 0.28, ("short.csv", "10 samples", "at least 2 s")),
    (None, -0.28, ("regression.csv", "row zeta_a", "must be > 0")),
])
def test_coupled_inputs_are_checked_before_the_drake_runs(tmp_path, rows, zeta_a, words):
    lines = COUPLED.read_text().splitlines(keepends=True)
    rec = tmp_path / "short.csv"
    rec.write_text("".join(lines[:1 + rows] if rows else lines))
    fit = tmp_path / "steer_fit.json"
    fit.write_text(json.dumps(MAJD))
    out = tmp_path / "out"
    r = roboball("diagnose", rec, "--regression", regression_csv(tmp_path / "regression.csv", zeta_a=zeta_a),
                 "--friction-steer", fit, "--out", out)
    refused(r, out, *words)
    assert "diagnosing" not in r.stderr      # refused before the progress of any work


def test_a_bad_steer_setting_in_the_sidecar_gets_its_error_alone(tmp_path):
    rec = tmp_path / "shell.csv"
    shutil.copy(SHELL, rec)
    side = json.loads(SHELL.with_suffix(".json").read_text())
    rec.with_suffix(".json").write_text(json.dumps({**side, "steer_joint": "maybe"}))
    out = tmp_path / "out"
    r = roboball("diagnose", rec, "--no-drake", "--out", out)
    refused(r, out, "shell.json: field steer_joint", "'maybe'")
    assert r.stderr.strip().count("\n") == 0, r.stderr
