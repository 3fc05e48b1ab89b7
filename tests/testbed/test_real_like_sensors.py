"""The test bed records like the real robot too (issue 24): an estimator's lagging, smooth output,
a stand slower than its URDF, and the let-go instants that a log trimmed at the let-go needs."""
import math

import numpy as np
import pandas as pd
import pytest

from roboball.testbed.campaign import _rest_angle, release_recording
from roboball.testbed.effects import conceal
from roboball.testbed.physics import load_truth, true_robot
from roboball.testbed.sensors import estimator_lag, estimator_sensors, measure


@pytest.mark.parametrize("lag", [0.02, 0.06])
def test_the_estimator_lags_a_ramp_by_tau_exactly(lag):
    """tau x' = u - x from rest on u = s t: x = s (t - tau (1 - exp(-t / tau)))."""
    t = np.arange(0.0, 1.0, 1e-3)
    dense = pd.DataFrame({"time_s": t, "steer_angle_rad": np.where(t > 0.1, 0.5 * (t - 0.1), 0.0)})
    x = estimator_lag(dense, lag).steer_angle_rad.to_numpy()
    tt = np.clip(t - 0.1, 0.0, None)
    assert np.max(np.abs(x - 0.5 * (tt - lag * (1 - np.exp(-tt / lag))))) < 1e-12
    assert estimator_lag(dense, 0.0).equals(dense)


def test_an_estimator_is_smooth_and_not_quantised_and_its_stamps_keep_nanoseconds():
    cfg = load_truth()["sensors"]
    est = estimator_sensors(cfg)
    assert est["angle_noise_rad"] == 3e-5 and est["angle_quantum_rad"] < 1e-6
    assert est["rate_hz"] == cfg["rate_hz"] and est["gap_probability"] == cfg["gap_probability"]
    t = np.arange(0.0, 2.0, 1e-3)
    dense = pd.DataFrame({"time_s": t, "pipe_angle_rad": 0.3 * np.cos(3.3 * t)})
    rec = measure(dense, est, np.random.default_rng(0), stamp_digits=9)
    assert np.any(np.abs(rec.time_s * 1e4 - np.round(rec.time_s * 1e4)) > 1e-3)   # finer than 0.1 ms
    resid = rec.pipe_angle_rad - 0.3 * np.cos(3.3 * rec.time_s)
    assert np.std(resid) == pytest.approx(3e-5, rel=0.25)


def test_added_inertia_slows_the_stand_in_the_robot_description():
    truth = load_truth()
    robot = true_robot(truth, perturbed=False)
    _, _, slow = conceal("steer_stand", {"added_inertia": {"delta_i": 0.1}}, robot)
    before, after = robot.steer_stand_terms, slow.steer_stand_terms
    assert after["inertia"] == pytest.approx(before["inertia"] + 0.1)
    assert after["mgd"] == before["mgd"] and after["rest_angle"] == before["rest_angle"]
    assert 2 * math.pi / after["omega_n"] > 1.07 * 2 * math.pi / before["omega_n"]
    with pytest.raises(ValueError):
        conceal("shell_rock", {"added_inertia": {"delta_i": 0.1}}, robot)


def test_a_recording_carries_its_let_go_instants():
    truth = load_truth()
    robot = true_robot(truth, perturbed=False)
    rest = _rest_angle("steer_stand", robot)
    dense = release_recording("steer_stand", None, [rest + 0.6], 1.0, truth, np.random.default_rng(3), extras=(),
                              base_friction={"steer": ("viscous", {"c": 0.1})}, robot=robot)
    (t_go,) = dense.attrs["let_go_s"]
    t, y = dense.time_s.to_numpy(), dense.steer_angle_rad.to_numpy()
    k = int(round(t_go * 1000))
    assert t[k] == pytest.approx(t_go)
    assert abs(y[k] - y[k - 1]) < 1e-4 < abs(y[k + 50] - y[k])     # held up to the let-go, swinging after
