"""The test bed's membrane shell law (roboball.testbed.membrane, docs/testbed.md)."""
import math

import numpy as np
import pytest

from roboball.testbed import membrane as mb

W, R = 412.1181, 0.305


@pytest.mark.parametrize("p_kpa", [6.9, 13.8, 20.7])
def test_the_patch_carries_the_weight_and_the_flat_is_bounded_by_it(p_kpa):
    pt = mb.patch(W, R, p_kpa, set_tension_n_m=1200.0)
    assert math.pi * pt["a"] ** 2 * p_kpa * 1e3 == pytest.approx(W)          # A = W / p
    assert pt["stiffness"] == pytest.approx(R * W / 2) and pt["lift_off"] == pytest.approx(pt["a"] / (2 * R))
    d = np.linspace(1e-6, 0.7, 70001)
    tau = mb.flat_torque(d, pt, mb.NP_NS)
    assert np.all(tau <= 0)                                                   # restoring
    np.testing.assert_allclose(mb.flat_torque(-d, pt, mb.NP_NS), -tau)       # odd
    small = d < 0.2 * pt["lift_off"]
    np.testing.assert_allclose(tau[small], -pt["share"] * pt["stiffness"] * d[small], rtol=1e-9)
    assert np.all(-tau <= pt["share"] * W * R * np.sin(np.maximum(pt["beta"] - d, 0)) + 1e-12)
    assert np.all(tau[d >= pt["beta"]] == 0)                                  # the flat has rolled off
    assert np.max(np.abs(np.diff(tau))) < 1e-3                                # no jump (continuous)
    # not a linear spring: the torque per radian at 0.8 beta is half the small-tilt stiffness or
    # less, and beyond beta the flat holds nothing (a hardening cubic would grow, a linear stay)
    secant = -mb.flat_torque(0.8 * pt["beta"], pt, mb.NP_NS) / (0.8 * pt["beta"])
    assert secant < 0.6 * pt["share"] * pt["stiffness"]


def test_the_stiffness_falls_with_pressure_through_the_patch():
    pts = [mb.patch(W, R, p, 1200.0) for p in (6.9, 10.3, 13.8, 17.2, 20.7)]
    assert np.all(np.diff([pt["share"] * pt["stiffness"] for pt in pts]) < 0)
    assert np.all(np.diff([pt["beta"] for pt in pts]) < 0)
    with pytest.raises(ValueError, match="too low"):
        mb.patch(W, R, 1.0, 1200.0)


def test_the_hysteresis_loss_has_a_debye_peak():
    pt = mb.patch(W, R, 13.8, 1200.0)
    w = np.linspace(-20, 20, 40001)
    tau = mb.hysteresis_torque(w, pt, alpha_peak=0.4, loss_time_s=1.0)
    np.testing.assert_allclose(tau, -tau[::-1], atol=1e-12)                  # odd, smooth through 0
    peak = w[np.argmin(tau)]
    assert peak == pytest.approx(2 * pt["a"] / R, rel=1e-3)                   # x = 1
    assert tau.min() == pytest.approx(-(3 / 16) * 0.4 * W * pt["a"], rel=1e-6)
    # falls beyond the peak: neither viscous (growing) nor a constant rolling resistance
    assert abs(mb.hysteresis_torque(10.0, pt, 0.4, 1.0)) < 0.5 * abs(tau.min())
