"""A sensor's own lag is fitted inside the baseline, never reported as physics (issue 24).

Recordings made by the diagnosis's own reduced model (so that the lag is the only thing the
baseline misses), seen through the test bed's estimator (its own first-order lag, noise 3e-5
rad like the real dynamic log), with hand-held phases before each release."""
import numpy as np
import pandas as pd
import pytest
from scipy.interpolate import CubicHermiteSpline
from scipy.signal import lfilter

from roboball.diagnose import diagnose
from roboball.diagnose import sensor_fit
from roboball.diagnose.data import prepare, read
from roboball.diagnose.sensor import lag_grid, sensed
from roboball.diagnose.sensor_fit import fresh, sample_noise, smooth
from roboball.reduced.models import model_for

DT = 2e-3


def _reduced_recording(path, lag_s, kind="steer_stand", releases=(-0.8, 0.6), free_s=6.0, params=None, seed=1,
                       raw=False):
    """The reduced model's free responses after hand-held phases, through the test bed's lag and
    sensors (`raw`: its raw sensors instead of the estimator's)."""
    from roboball.ingest.recording import write_recording
    from roboball.testbed.physics import load_truth
    from roboball.testbed.sensors import estimator_lag, estimator_sensors, hand_phase, measure

    truth, rng, m = load_truth(), np.random.default_rng(seed), model_for(kind)
    pieces, angle = [np.full(1000, m.rest)], m.rest
    P = {k: np.array([v]) for k, v in (params or {}).items()}
    for a in releases:
        hand, held = hand_phase(angle, m.rest + a, truth["hand"], rng, 1000.0)
        n = int(free_s / DT)
        Y, Yd = m.simulate(np.array([held]), P, n, DT)
        y = CubicHermiteSpline(np.arange(n + 1) * DT, Y[:, 0], Yd[:, 0])(np.arange(1, int(free_s * 1000) + 1) / 1000)
        pieces += [hand, y]
        angle = float(y[-1])
    y = np.concatenate(pieces)
    dense = estimator_lag(pd.DataFrame({"time_s": np.arange(len(y)) / 1000.0, m.signal: y}), lag_s)
    cfg = truth["sensors"] if raw else estimator_sensors(truth["sensors"])
    write_recording(path, measure(dense, cfg, rng, stamp_digits=4 if raw else 9),
                    {"kind": kind, "pressure_kpa": 13.8 if kind == "shell_rock" else None})
    return path


# ---- the operator ------------------------------------------------------------------------------
def _damped(t):
    a, s, w = 0.4, 0.3, 5.4
    return (a * np.exp(-s * t) * np.cos(w * t),
            a * np.exp(-s * t) * (-s * np.cos(w * t) - w * np.sin(w * t)))


@pytest.mark.parametrize("tau", [0.02, 0.04])
def test_the_lag_of_a_swing_matches_a_fine_step_filter_run_through_its_past(tau):
    """Started at a turning point (the mirror image of the swing before it) the lagged swing is
    the steady filter's to 1e-5 rad from the first step; started settled (x = u) it is off by
    about A (omega tau)^2 / 2 (a transient the fit would take for physics)."""
    h = 1e-5
    td = np.arange(-6.0, 7.0, h)
    a = np.exp(-h / tau)
    ref = lfilter([1 - a], [1, -a], _damped(td)[0], zi=[a * _damped(td)[0][0]])[0]
    tg = np.arange(0.0, 6.5, DT)
    u, ud = _damped(tg)
    ref = np.interp(tg - h / 2, td, ref)         # the fine filter's half-step delay
    x, xd = lag_grid(u[:, None], ud[:, None], DT, np.array([tau]), np.array([True]))
    assert np.max(np.abs(x[:, 0] - ref)) < 1.5e-5
    assert np.allclose(xd[:, 0], (u - x[:, 0]) / tau)
    held = lag_grid(u[:, None], ud[:, None], DT, np.array([tau]), np.array([False]))[0][:, 0]
    assert held[0] == u[0] and abs(held[0] - ref[0]) > 0.3 * 0.4 * (5.4 * tau) ** 2


def test_no_lag_leaves_every_prediction_as_simulated():
    tg = np.arange(0.0, 3.0, DT)
    u, ud = _damped(tg)
    Y, Yd = np.stack([u, u]).T, np.stack([ud, ud]).T
    X, Xd = lag_grid(Y, Yd, DT, np.array([0.0, 0.03]), np.array([True, True]))
    assert np.array_equal(X[:, 0], u) and np.array_equal(Xd[:, 0], ud) and not np.allclose(X[:, 1], u)

    class W:
        start = "turning point"
    ts = np.array([-0.01, 0.0, 0.013, 1.7])
    assert np.array_equal(sensed(W, ts, tg, u, {}), np.interp(ts, tg, u, left=u[0]))


# ---- the criterion ----------------------------------------------------------------------------
def test_the_noise_of_recorded_samples_is_read_about_their_neighbours_not_a_resampled_grid():
    rng = np.random.default_rng(0)
    t = np.cumsum(1.0 / rng.uniform(80, 100, 800))
    y = 0.8 * np.cos(5.4 * t)                       # the stand's fastest swing
    assert sample_noise(t, y) < 2e-6
    assert sample_noise(t, y + rng.normal(0, 3e-5, t.size)) == pytest.approx(3e-5, rel=0.15)
    quantised = np.round((y + rng.normal(0, 4e-4, t.size)) / 1e-3) * 1e-3
    assert sample_noise(t, quantised) > 4e-4 > sensor_fit.SMOOTH_NOISE
    stale = y.copy()
    stale[5::5] = stale[4::5][: len(stale[5::5])]    # every fifth sample repeats the one before
    assert fresh(stale).sum() == t.size - len(stale[5::5])
    assert sample_noise(t[fresh(stale)], stale[fresh(stale)]) < 1e-5 < 1e-3 < sample_noise(t, stale)


def test_a_raw_recording_never_meets_the_sensor_lag(tmp_path, monkeypatch):
    """The test bed's raw sensors (1 mrad steps): not smooth, so neither the lag nor the stale
    samples are looked at, and the diagnosis is the one made before (the campaign's and the real
    steer log's diagnosis.json were compared, identical)."""
    path = _reduced_recording(tmp_path / "raw.csv", 0.0, releases=(-0.8,), raw=True, params={"viscous_c": 0.12})
    assert not smooth(prepare(read(path)))

    def must_not_run(*a, **k):
        raise AssertionError("the sensor lag was tried on a raw recording")
    monkeypatch.setattr(sensor_fit, "_with_lag", must_not_run)
    d, js = diagnose(path)
    assert "sensor_lag_s" not in js["baseline"]["fitted"] and not any("lag" in n for n in d.prep.notes)


# ---- the diagnosis ----------------------------------------------------------------------------
def test_a_40ms_lag_is_fitted_inside_the_baseline_not_taken_for_a_cubic_stiffness(tmp_path):
    path = _reduced_recording(tmp_path / "lagged.csv", 0.04, params={"viscous_c": 0.12})
    d, js = diagnose(path)
    assert js["verdict"] == "adequate" and js["missing_physics"] == []
    assert js["baseline"]["fitted"]["sensor_lag_s"] == pytest.approx(0.04, rel=0.1)
    assert js["baseline"]["fitted"]["viscous_c"] == pytest.approx(0.12, rel=0.05)
    assert js["fit"]["rmse_before"] < 2e-4          # the lagged baseline follows the recording
    assert any("kept as sensor_lag_s" in n for n in d.prep.notes)


def test_the_same_recording_without_the_lag_gets_no_lag_entry(tmp_path):
    path = _reduced_recording(tmp_path / "plain.csv", 0.0, params={"viscous_c": 0.12})
    d, js = diagnose(path)
    assert smooth(d.prep)                           # it was tried, and not supported
    assert js["verdict"] == "adequate" and js["missing_physics"] == []
    assert "sensor_lag_s" not in js["baseline"]["fitted"]
    assert any("not supported, no lag fitted" in n for n in d.prep.notes)


def test_a_lag_hidden_behind_missing_physics_is_found_with_the_first_effect(tmp_path):
    """A lightly damped shell through a 40 ms lag: the baseline (no dissipation) misses by 66
    mrad and a lag cannot show there; with the viscous damping found the lag shows, and the
    selection is run again with it inside the baseline, so no cubic stiffness stands in for it:
    held in the baseline (which would pull it off), fitted in every model with effects (held
    there too at the first run's value, a wrong value leaves a residual for an effect to take)."""
    path = _reduced_recording(tmp_path / "shell.csv", 0.04, kind="shell_rock", releases=(-0.6,), free_s=8.0,
                              params={"viscous_damping.c": 1.0}, seed=4)
    d, js = diagnose(path)
    assert [m["effect"] for m in js["missing_physics"]] == ["viscous_damping"]
    assert js["missing_physics"][0]["parameters"]["c"] == pytest.approx(1.0, rel=0.05)
    assert js["baseline"]["fitted"]["sensor_lag_s"] == pytest.approx(0.04, rel=0.1)
    assert js["verdict"] == "augmented"
    assert "sensor_lag_s" not in d.baseline.full.free and "sensor_lag_s" in d.final.full.free
    assert js["baseline"]["refitted_with_effects"]["sensor_lag_s"] == pytest.approx(0.04, rel=0.1)
