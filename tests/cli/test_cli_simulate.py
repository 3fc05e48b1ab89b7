"""`roboball simulate` writes a recording in the shared format, read back by the same reader."""
import subprocess
import sys

import pytest

from conftest import fit_damped
from roboball.ingest.recording import read_recording

ROBOBALL = [sys.executable, "-m", "roboball.cli"]


def test_simulate_writes_a_readable_recording(tmp_path):
    out = tmp_path / "rock.csv"
    r = subprocess.run(ROBOBALL + ["simulate", "shell_rock", "--contact", "injected", "--pressure-kpa", "13.8",
                                   "--zeta", "0.1", "--omega-n", "2.8", "--release", "0.1", "--duration", "8",
                                   "--out", str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    rec = read_recording(out)
    assert rec.meta["kind"] == "shell_rock" and rec.meta["pressure_kpa"] == 13.8
    assert list(rec.data.columns[:2]) == ["time_s", "pipe_angle_rad"]
    fit = fit_damped(rec.data.time_s, rec.data.pipe_angle_rad)
    assert fit["zeta"] == pytest.approx(0.1, rel=0.03)
    assert fit["omega_n"] == pytest.approx(2.8, rel=0.03)


@pytest.mark.parametrize("args,needle", [
    (["simulate", "shell_rock", "--contact", "injected", "--pressure-kpa", "10", "--regression", "no/such.csv"], "--zeta"),
    (["simulate", "ramp"], "--pressure-kpa"),                      # whatever the contact: the recording needs it
    (["simulate", "steer_stand", "--dt", "0.02"], "10 ms"),
    (["simulate", "ramp", "--contact", "hydroelastic", "--zeta", "0.1", "--omega-n", "2.8"], "--pressure-kpa"),
    (["simulate", "ramp", "--pressure-kpa", "-3"], "pressure"),
])
def test_simulate_bad_flags_give_one_line_errors(tmp_path, args, needle):
    assert_refused_in_one_line(ROBOBALL + args, tmp_path, needle)


def assert_refused_in_one_line(cmd: list, tmp_path, needle: str) -> None:
    """`cmd` with --out in tmp_path fails with one error line (Drake's warnings aside) that
    contains `needle`, no traceback, and writes no recording."""
    r = subprocess.run(cmd + ["--out", str(tmp_path / "x.csv")], capture_output=True, text=True)
    assert r.returncode != 0
    lines = [l for l in r.stderr.strip().splitlines() if "WARNING" not in l]
    assert len(lines) == 1 and needle in lines[0], r.stderr
    assert "Traceback" not in r.stderr
    assert not (tmp_path / "x.csv").exists()


def test_shell_numbers_come_from_the_pipelines_regression_and_it_says_so(tmp_path):
    reg = tmp_path / "shell_regression.csv"
    # zeta(p) = a exp(b p), omega_n(p) = c + d p: 0.1 and 2.8 rad/s at any pressure
    reg.write_text("name,value\nzeta_a,0.1\nzeta_b,0.0\nomega_n_c,2.8\nomega_n_d,0.0\n")
    out = tmp_path / "rock.csv"
    r = subprocess.run(ROBOBALL + ["simulate", "shell_rock", "--contact", "injected", "--pressure-kpa", "13.8",
                                   "--regression", str(reg), "--release", "0.1", "--duration", "6", "--out", str(out)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert f"zeta 0.1, omega_n 2.8 rad/s (from the pipeline's regression, {reg})" in r.stdout
    rec = read_recording(out)
    assert rec.meta["simulation"]["zeta"] == 0.1 and rec.meta["simulation"]["omega_n_rad_s"] == 2.8
    bad = tmp_path / "bad.csv"
    bad.write_text("name,value\nzeta_a,0.1\n")
    r = subprocess.run(ROBOBALL + ["simulate", "shell_rock", "--contact", "injected", "--pressure-kpa", "13.8",
                                   "--regression", str(bad), "--out", str(tmp_path / "x.csv")], capture_output=True, text=True)
    assert r.returncode != 0 and "not a shell regression table" in r.stderr and "Traceback" not in r.stderr


def test_every_simulate_option_says_its_unit_and_default():
    from roboball.cli.main import _load_plugins, build_parser
    _load_plugins()
    sub = next(a for a in build_parser()._actions if a.dest == "command").choices
    for name in ("simulate", "diagnose"):
        for action in sub[name]._actions:
            if action.dest in ("help", "kind", "recording") or action.required:
                continue
            assert "default" in (action.help or ""), (name, action.option_strings)
    units = {a.dest: a.help for a in sub["simulate"]._actions}
    for dest, unit in (("pressure_kpa", "kPa"), ("omega_n", "rad/s"), ("release", "rad"), ("duration", "(s;"),
                       ("dt", "(s,"), ("sample_rate_hz", "Hz"), ("hydro_modulus", "Pa"), ("hydro_dissipation", "s/m")):
        assert unit in units[dest], dest


def test_hydro_tuned_takes_the_calibrated_modulus_and_dissipation_and_says_so(tmp_path):
    """`--contact hydro_tuned` is Drake's hydroelastic contact with the calibration's numbers at the
    pressure (log-interpolated), the same law as the pipeline's hydro_tuned runs."""
    fit = tmp_path / "hydro_tuned.csv"
    fit.write_text("pressure_kpa,hydro_modulus_pa,hydro_dissipation_s_m\n10.0,1.0e5,0.5\n20.0,4.0e5,2.0\n")
    out = tmp_path / "rock.csv"
    r = subprocess.run(ROBOBALL + ["simulate", "shell_rock", "--contact", "hydro_tuned", "--pressure-kpa", "15",
                                   "--hydro-fit", str(fit), "--release", "0.1", "--duration", "0.2", "--out", str(out)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert f"modulus 2e+05 Pa, dissipation 1 s/m (from the pipeline's calibration, {fit})" in r.stdout
    sim = read_recording(out).meta["simulation"]
    assert sim["contact"] == "hydro_tuned"
    assert sim["hydro_modulus_pa"] == pytest.approx(2e5) and sim["hydro_dissipation_s_m"] == pytest.approx(1.0)
    for extra, needle in ((["--hydro-fit", str(tmp_path / "none.csv")], "--hydro-modulus"),
                          (["--hydro-fit", str(fit), "--pressure-kpa", "25"], "outside the calibrated 10-20 kPa")):
        assert_refused_in_one_line(ROBOBALL + ["simulate", "shell_rock", "--contact", "hydro_tuned",
                                               "--pressure-kpa", "15", *extra], tmp_path, needle)
