"""`roboball-testbed replay`: the calibrated twin runs a real log's experiment and writes the
log's own columns at the log's own stamps; a bad input is refused in one line, nothing written."""
import pandas as pd
import pytest

from conftest import REAL_DATA
from roboball.testbed.cli import main

STAND = "steering_static_stand_response.csv"
SHELL = "dynamic_data.csv"
COUPLED = ("steer_coupled_20250429_165825.csv", "steer_coupled_20250429_165853.csv", "steer_coupled_20250429_165914.csv")


def _real(name):
    path = REAL_DATA / name
    if not path.is_file():
        pytest.skip(f"{path} not found")
    return path


@pytest.mark.parametrize("name", [STAND, SHELL, COUPLED[0],
                                  *(pytest.param(n, marks=pytest.mark.slow) for n in COUPLED[1:])])
def test_replay_writes_the_logs_columns_at_its_stamps(tmp_path, capsys, name):
    log = _real(name)
    out = tmp_path / "twin.csv"
    assert main(["replay", str(log), "--out", str(out)]) == 0
    real, twin = pd.read_csv(log), pd.read_csv(out)
    assert list(twin.columns) == list(real.columns)
    assert set(twin.iloc[:, 0]) <= set(real.iloc[:, 0])            # the log's own stamps
    assert len(twin) >= 100 and twin.notna().all().all()            # a free response, not a stub
    merged = twin.merge(real.drop_duplicates(real.columns[0]), on=real.columns[0], suffixes=("", "_real"))
    for c in real.columns[1:]:
        if c.endswith(".velocity"):
            continue
        rms = ((merged[c] - merged[c + "_real"]) ** 2).mean() ** 0.5
        assert rms < 0.5, (c, rms)                                   # it is the same experiment, not noise
        assert abs(twin[c].iloc[0] - merged[c + "_real"].iloc[0]) < 0.05   # from the log's own release
    assert "RMS against the log" in capsys.readouterr().out


def _refused(capsys, argv, out):
    rc = main(argv)
    err = capsys.readouterr().err.strip()
    assert rc != 0
    assert len(err.splitlines()) == 1 and err.startswith("roboball-testbed: error: ")
    assert not out.exists() and not list(out.parent.glob(f".{out.name}*"))
    return err


def test_a_missing_log_is_refused_in_one_line_naming_it(tmp_path, capsys):
    out = tmp_path / "twin.csv"
    err = _refused(capsys, ["replay", str(tmp_path / "nope.csv"), "--out", str(out)], out)
    assert "nope.csv" in err and "no such file" in err


def test_a_log_of_unknown_columns_is_refused(tmp_path, capsys):
    bad = tmp_path / "odd.csv"
    bad.write_text("t_s,angle_deg\n0,1\n0.1,2\n")
    out = tmp_path / "twin.csv"
    err = _refused(capsys, ["replay", str(bad), "--out", str(out)], out)
    assert "odd.csv" in err


def test_a_log_with_a_bad_cell_is_refused_naming_the_file(tmp_path, capsys):
    bad = tmp_path / "steer.csv"
    bad.write_text("steer_timestamp,pend_angle\n1.0,0.1\n1.01,abc\n1.02,0.1\n")
    out = tmp_path / "twin.csv"
    err = _refused(capsys, ["replay", str(bad), "--out", str(out)], out)
    assert "steer.csv" in err


def test_a_log_without_a_release_is_refused_and_nothing_is_written(tmp_path, capsys):
    flat = tmp_path / "still.csv"
    flat.write_text("steer_timestamp,pend_angle\n" + "".join(f"{1 + 0.0125 * k:.4f},-0.040\n" for k in range(400)))
    out = tmp_path / "twin.csv"
    err = _refused(capsys, ["replay", str(flat), "--out", str(out)], out)
    assert "still.csv" in err and "release" in err


def test_a_pressure_for_a_stand_log_is_refused(tmp_path, capsys):
    out = tmp_path / "twin.csv"
    err = _refused(capsys, ["replay", str(_real(STAND)), "--pressure-kpa", "13.8", "--out", str(out)], out)
    assert "no shell pressure" in err


def test_an_impossible_pressure_is_refused(tmp_path, capsys):
    out = tmp_path / "twin.csv"
    err = _refused(capsys, ["replay", str(_real(COUPLED[0])), "--pressure-kpa", "-5", "--out", str(out)], out)
    assert "-5" in err and "kPa" in err


def _calibration():
    from conftest import REPO
    import json
    path = REPO / "benchmarks" / "testbed_calibration.json"
    if not path.is_file():
        pytest.skip("benchmarks/testbed_calibration.json not written yet (benchmarks/testbed_calibrate.py --report)")
    return json.loads(path.read_text())


def test_the_twin_in_truth_yaml_is_the_calibrated_one():
    """truth.yaml's real_robot section holds the calibration's values (not hand-edited ones)."""
    import sys
    from conftest import REPO
    from roboball.testbed.physics import load_truth
    sys.path.insert(0, str(REPO / "benchmarks"))
    import testbed_calibrate as tc
    cal = _calibration()
    real = load_truth(real=True)
    want = tc.with_params(tc.base_truth(), cal["calibrated"])
    for name, spec in tc.PARAMS.items():
        a, b = real, want
        for k in spec[0]:
            a, b = a[k], b[k]
        assert a == pytest.approx(b, rel=1e-3), name
    assert real["shell"]["set_at_kpa"] == cal["set_at_kpa"]


@pytest.mark.parametrize("name", [STAND, SHELL, COUPLED[0]])
def test_replay_reproduces_the_calibrations_in_sample_numbers(tmp_path, name):
    from roboball.testbed.replay import replay
    cal = _calibration()
    want = cal["logs"][name.removesuffix(".csv")]["in_sample"]
    got = replay(_real(name), tmp_path / "twin.csv")
    for c, v in want.items():
        assert got[c] == pytest.approx(v, rel=2e-3, abs=1e-4), c


def test_the_docs_table_is_the_calibrations():
    """docs/testbed.md's held-out table states benchmarks/testbed_calibration.json's numbers."""
    import re
    from conftest import REPO
    cal = _calibration()
    text = (REPO / "docs" / "testbed.md").read_text()
    rows = {"steer stand": STAND, "shell log (pendulum free)": SHELL, "coupled repeat 1": COUPLED[0],
            "coupled repeat 2": COUPLED[1], "coupled repeat 3": COUPLED[2]}
    for label, name in rows.items():
        m = re.search(r"^\| " + re.escape(label) + r" \| [^|]+ \| ([^|]+) \| ([^|]+) \|", text, re.M)
        assert m, label
        entry = cal["logs"][name.removesuffix(".csv")]
        for cell, key in zip(m.groups(), ("in_sample", "held_out")):
            stated = [float(x) for x in re.findall(r"\d+\.\d+", cell)]
            want = [entry[key][c] for c in ("pend_angle", "ball_roll.position", "roll_joint.position") if c in entry[key]]
            assert stated == pytest.approx(want, abs=5e-4), (label, key, stated, want)


def test_the_shell_logs_pendulum_rate_at_the_let_go_is_a_nuisance_value_the_replay_takes():
    """A rate in the log's nuisance values starts the pendulum moving at the let-go (the joint
    moves at that rate at first); without one it hangs still, as the calibrated twin has it."""
    import numpy as np
    from roboball.testbed.physics import load_truth
    from roboball.testbed.replay import Segment, free_pendulum_run
    truth = load_truth(real=True)
    assert "steer_rate_rad_s" not in truth["logs"]["dynamic_data"]
    t = np.linspace(0.0, 0.02, 11)
    seg = Segment(np.arange(t.size), -0.4)
    still = free_pendulum_run(truth, 8.0, t, seg, 0.2)
    moving = free_pendulum_run(truth, 8.0, t, seg, 0.2, steer_rate=-2.5)
    assert still["steer_angle_rad"][0] == moving["steer_angle_rad"][0] == pytest.approx(0.4 + 0.2)
    # the rate at t = 0: the linear term of a quadratic (gravity accelerates both alike)
    assert np.polyfit(t, still["steer_angle_rad"], 2)[1] == pytest.approx(0.0, abs=0.02)
    assert np.polyfit(t, moving["steer_angle_rad"], 2)[1] == pytest.approx(-2.5, abs=0.1)


def test_a_pendulum_held_and_let_go_before_the_shell_reaches_it_swinging_toward_plumb():
    """The hold form of the shell log's let-go (`held_joint_rad`, `lead_s`): let go at once it is
    where the joint held it, still; a quarter second later it swings through toward plumb no
    faster than its fall from the hold allows without friction."""
    import numpy as np
    from roboball.config import load_robot
    from roboball.testbed.physics import load_truth
    from roboball.testbed.replay import Segment, pendulum_at_let_go
    truth = load_truth(real=True)
    seg = Segment(np.arange(3), -0.4)
    angle, rate = pendulum_at_let_go(truth, seg, {"held_joint_rad": 1.0, "lead_s": 0.005})
    assert angle == pytest.approx(0.6, abs=2e-3) and abs(rate) < 0.1
    angle, rate = pendulum_at_let_go(truth, seg, {"held_joint_rad": 1.0, "lead_s": 0.25})
    stand = load_robot().steer_stand_terms
    plumb = stand["rest_angle"]
    bound = np.sqrt(2 * stand["mgd"] * (np.cos(angle - plumb) - np.cos(0.6 - plumb)) / stand["inertia"])
    assert angle < 0.3 and -bound - 1e-9 <= rate < -2.0
    assert pendulum_at_let_go(truth, seg, {"steer_offset_rad": 0.2, "steer_rate_rad_s": -1.0}) == (0.2, -1.0)
    assert pendulum_at_let_go(truth, seg, {}) == (0.0, 0.0)
