"""The PME sign convention (a model faster than the robot is positive)."""
from pathlib import Path

import numpy as np
import pytest

from roboball.metrics import pme, speed_errors
from roboball.sim.forces import InjectedShell
from roboball.sim.scenarios import simulate
from roboball.sim.spec import SimSpec


def test_pme_by_hand():
    w_e = np.array([0.0, 0.2, 2.0, 4.0])        # first two below the 0.5 rad/s floor: left out
    w_s = np.array([0.3, 0.9, 2.2, 4.4])        # 10% too fast where defined
    assert pme(w_e, w_s) == pytest.approx(10.0)
    assert pme(w_s[2:], w_e[2:]) == pytest.approx(100 * np.mean([(2.0 - 2.2) / 2.2, (4.0 - 4.4) / 4.4]))


def test_unsigned_errors_do_not_cancel_where_eq12_does():
    """A model 2% fast early and 2% slow late scores 0 by eq. 12, 2% by the mean absolute
    point error; the RMS error covers every sample, the ones below the floor too."""
    w_e = np.array([0.1, 1.0, 2.0, 3.0, 4.0])
    w_s = np.array([0.2, 1.02, 2.04, 2.94, 3.92])
    e = speed_errors(w_e, w_s)
    assert e["pme_percent"] == pytest.approx(0.0, abs=1e-12)
    assert e["mape_percent"] == pytest.approx(2.0)
    assert e["rmse_rad_s"] == pytest.approx(np.sqrt(np.mean((w_s - w_e) ** 2)))
    assert speed_errors(w_e, w_e) == {"pme_percent": 0.0, "mape_percent": 0.0, "rmse_rad_s": 0.0}


def test_pme_sign_on_a_run_where_the_answer_is_known():
    """'Recording' = the point-contact robot with extra rolling damping; the undamped point model
    rolls faster, so its PME must be positive, and the recording scored against itself is zero."""
    friction = {"steer": "majd", "drive": "majd"}
    damped = SimSpec(kind="ramp", contact="point", friction=friction,
                     extra_terms=[InjectedShell(k_inject=0.0, c_inject=2.0, steer=False, drive=True)])
    rec = simulate(damped, 0.0, 1.5, sample_rate_hz=100)
    fast = simulate(SimSpec(kind="ramp", contact="point", friction=friction), 0.0, 1.5, sample_rate_hz=100)
    assert pme(rec.drive_rate_rad_s, fast.drive_rate_rad_s) > 2.0
    assert pme(fast.drive_rate_rad_s, rec.drive_rate_rad_s) < -2.0
    assert pme(rec.drive_rate_rad_s, rec.drive_rate_rad_s) == 0.0


def test_pme_sign_on_a_run_rolling_the_other_way():
    """Eq. 12's sign convention holds for negative drive rates too: a model that rolls faster
    than the robot (|w_s| > |w_e|) is positive whichever way the robot rolls, and the floor
    is on the speed |w_e|, so negative samples are scored, not dropped."""
    w_e = np.array([-0.1, -0.3, -2.0, -4.0])    # first two below the 0.5 rad/s floor
    w_s = np.array([-0.5, -0.1, -2.2, -4.4])    # 10% too fast where defined
    assert pme([-2.0], [-2.2]) == pytest.approx(10.0)
    assert pme(w_e, w_s) == pytest.approx(10.0)
    assert pme(w_e, 0.9 * w_e) == pytest.approx(-10.0)
    assert pme(w_e, w_s) == pytest.approx(pme(-w_e, -w_s))
    e = speed_errors(w_e, w_s)
    assert e["pme_percent"] == pytest.approx(10.0)
    assert e["mape_percent"] == pytest.approx(10.0)


def _regression_csv(path, a=0.05, b=-0.02, c=3.0, d=0.1):
    """A shell regression table in the pipeline's format (regress.regression_table)."""
    import pandas as pd

    pd.DataFrame({"name": ["zeta_a", "zeta_b", "omega_n_c", "omega_n_d"], "value": [a, b, c, d],
                  "se": [0.001] * 4, "ci95_low": [0.0] * 4, "ci95_high": [1.0] * 4,
                  "unit": ["1", "1/kPa", "rad/s", "rad/s/kPa"], "n_points": [6] * 4, "dof": [4] * 4}
                 ).to_csv(path, index=False)
    return str(path)


def test_shell_at_reads_the_regression_table(tmp_path):
    from roboball.pipeline.simulation import shell_at

    csv = _regression_csv(tmp_path / "shell_regression.csv", a=0.05, b=-0.02, c=3.0, d=0.1)
    zeta, omega = shell_at(csv, 13.8)
    assert zeta == pytest.approx(0.05 * np.exp(-0.02 * 13.8))
    assert omega == pytest.approx(3.0 + 0.1 * 13.8)
    zeta, omega = shell_at(_regression_csv(tmp_path / "up.csv", a=0.01, b=0.03, c=2.0, d=-0.05), 20.0)
    assert zeta == pytest.approx(0.01 * np.exp(0.03 * 20.0))
    assert omega == pytest.approx(2.0 - 0.05 * 20.0)


def _ramp_recording(t_exit=None):
    import pandas as pd

    from roboball.ingest.recording import Recording

    t = np.round(np.arange(0.0, 5.0, 0.01), 10)
    w = np.where(t > 1.0, 2.0 * (t - 1.0), 0.0)
    pipe = np.where(t < 1.0, 0.2, 0.2 + (t - 1.0))      # held at 0.2 rad until the release
    pipe = np.where(t < 0.5, -0.5, pipe)                # ...and elsewhere before the hold
    meta = {"kind": "ramp", "pressure_kpa": 13.8, "ramp_angle_deg": 16.0}
    if t_exit is not None:
        meta["ramp_exit_s"] = t_exit
    return Recording(pd.DataFrame({"time_s": t, "drive_rate_rad_s": w, "pipe_angle_rad": pipe}), meta,
                     Path("runs/ramp_a.csv"))


def _releases_json(path, t_release=1.0, t_end=4.0):
    import json

    path.write_text(json.dumps({"pressure_kpa": 13.8, "releases": [
        {"t_release_s": t_release, "t_end_s": t_end, "i_release": 100, "i_end": 400, "y_release": 0.0,
         "y_rest": 0.0, "held_from_s": 0.0, "half_period_s": None, "noise": 0.001, "kind": "ramp"}]}))
    return str(path)


@pytest.mark.parametrize("t_exit", [None, 3.5])
def test_ramp_window_starts_at_the_release(tmp_path, t_exit):
    """The scored window runs from the release (time 0) until the robot leaves the ramp (the
    recording's ramp_exit_s, else the release's end); the initial pipe angle is the one held
    just before the release."""
    from roboball.pipeline.simulation import ramp_window

    rec = _ramp_recording(t_exit)
    tt, w_e, pipe0 = ramp_window(rec, _releases_json(tmp_path / "rel.json", 1.0, 4.0))
    t_end = 4.0 if t_exit is None else t_exit
    assert tt[0] == pytest.approx(0.0, abs=1e-9)
    assert tt[-1] == pytest.approx(t_end - 1.0, abs=0.011)
    assert np.all(tt >= 0.0) and np.all(np.diff(tt) > 0)
    sel = (rec.time >= 1.0) & (rec.time <= t_end)
    np.testing.assert_array_equal(w_e, rec.signal("drive_rate_rad_s")[sel])
    assert w_e[0] == pytest.approx(0.0) and np.all(w_e[1:] > 0)
    assert pipe0 == pytest.approx(0.2)


def test_ramp_sim_posterior_band_is_the_95_percent_range_of_the_draws(tmp_path, monkeypatch):
    """The friction-posterior PME band (pme_draw_low/high) is the 2.5-97.5 percentile range of
    the draws' PMEs (the documented 95% range), pme_draw_median their median.  The simulation is
    stubbed: it rolls (1 + f_w) times as fast as the robot, so each draw's PME is 100 f_w."""
    import json

    import pandas as pd

    import roboball.ingest.recording
    import roboball.sim.scenarios
    from roboball.pipeline import simulation

    rec = _ramp_recording(3.5)
    monkeypatch.setattr(roboball.ingest.recording, "read_recording", lambda path, *a, **k: rec)
    draws = []

    memos = []

    def fake_simulate(spec, pipe0, duration, sample_rate_hz=200.0, settled=None):
        assert spec.kind == "ramp" and pipe0 == pytest.approx(0.2)
        memos.append(settled)
        f_w = spec.friction_params["drive"]["f_w"]
        assert spec.friction_params["drive"]["n"] == 2.0 and spec.friction_params["steer"]["n"] == 2.0
        draws.append(100.0 * f_w)
        t = np.arange(0.0, duration + 0.01, 1.0 / sample_rate_hz)
        return pd.DataFrame({"time_s": t, "drive_rate_rad_s": (1.0 + f_w) * 2.0 * t})

    monkeypatch.setattr(roboball.sim.scenarios, "simulate", fake_simulate)
    rng = np.random.default_rng(3)
    samples = pd.DataFrame({"f_w": rng.uniform(-0.3, 0.3, 200), "f_c": 0.1, "sigma": 0.2, "omega_c": 1.0})
    samples.to_csv(tmp_path / "samples.csv", index=False)
    fits = {}
    for joint in ("steer", "drive"):       # n held by the fit: not in its samples, in `fixed`
        fits[joint] = tmp_path / f"{joint}.json"
        fits[joint].write_text(json.dumps({"f_w": 0.05, "f_c": 0.1, "sigma": 0.2, "omega_c": 1.0, "n": 2.0,
                                           "fixed": {"n": 2.0}, "samples_csv": str(tmp_path / "samples.csv")}))
    out = tmp_path / "ramp.csv"
    simulation.ramp_sim("runs/ramp_a.csv", _releases_json(tmp_path / "rel.json"),
                        _regression_csv(tmp_path / "reg.csv"), "point", str(out),
                        friction_steer=str(fits["steer"]), friction_drive=str(fits["drive"]),
                        posterior_draws=40, seed=1)
    row = pd.read_csv(out).iloc[0]
    assert len(draws) == 41 and draws[0] == pytest.approx(5.0)   # the median fit, then the draws
    assert isinstance(memos[0], dict) and all(m is memos[0] for m in memos)   # one settling for all
    assert row.pme_percent == pytest.approx(5.0)
    d = np.array(draws[1:])
    assert np.ptp(d) > 20.0
    assert row.pme_draw_low == pytest.approx(np.percentile(d, 2.5))
    assert row.pme_draw_high == pytest.approx(np.percentile(d, 97.5))
    assert row.pme_draw_median == pytest.approx(np.median(d))
