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
    (["simulate", "shell_rock", "--contact", "injected", "--pressure-kpa", "10"], "--zeta"),
    (["simulate", "steer_stand", "--dt", "0.02"], "10 ms"),
    (["simulate", "ramp", "--contact", "hydroelastic", "--zeta", "0.1", "--omega-n", "2.8"], "--pressure-kpa"),
    (["simulate", "ramp", "--pressure-kpa", "-3"], "pressure"),
])
def test_simulate_bad_flags_give_one_line_errors(tmp_path, args, needle):
    r = subprocess.run(ROBOBALL + args + ["--out", str(tmp_path / "x.csv")], capture_output=True, text=True)
    assert r.returncode != 0
    lines = [l for l in r.stderr.strip().splitlines() if "WARNING" not in l]
    assert len(lines) == 1 and needle in lines[0], r.stderr
    assert "Traceback" not in r.stderr
    assert not (tmp_path / "x.csv").exists()
