"""Ground runs start with the shell resting in its contact (roboball.sim.scenarios.settle_on_ground):
no fall into the ground and no bounce after the release, for the soft hydroelastic shell (which
sinks by millimetres) and rigid point contact alike."""
import numpy as np
import pytest

from roboball.sim.plant import build
from roboball.sim.scenarios import set_release, settle_on_ground, simulate
from roboball.sim.spec import ShellParams, SimSpec

HYDRO = dict(contact="hydroelastic", pressure_kpa=13.8, shell=ShellParams(zeta=0.10, omega_n=2.75, dissipation_scale=0.5))


def _spec(kind, contact="point", **kw):
    return SimSpec(kind=kind, friction={"steer": "majd", "drive": "majd"}, **({"contact": contact} | kw))


def _height(built, x):
    lay = built.layout
    return x[lay.base_q + 4: lay.base_q + 7].T @ built.ground_normal


@pytest.mark.parametrize("kw, lo_mm, hi_mm", [({}, 0.05, 2.0), (HYDRO, 5.0, 15.0)])
def test_the_shell_starts_pressed_in_by_the_penetration_that_holds_its_weight(kw, lo_mm, hi_mm):
    spec = _spec("ramp", **kw)
    built = build(spec, sample_period=1e-3)
    ctx = built.diagram.CreateDefaultContext()
    set_release(built, ctx, 0.0)       # settles
    fresh = built.diagram.CreateDefaultContext()
    set_release(built, fresh, 0.0)
    sink = settle_on_ground(built, fresh)   # a second settle from the settled state finds ~0 more
    assert abs(sink) < 1e-4
    r = built.robot.radius
    h0 = float(built.plant.GetPositionsAndVelocities(built.plant.GetMyContextFromRoot(ctx))[built.layout.base_q + 4:
                                                                                          built.layout.base_q + 7]
               @ built.ground_normal)
    assert lo_mm < 1e3 * (r - h0) < hi_mm


def test_a_settled_hydroelastic_descent_starts_at_once_and_does_not_fall_into_the_ramp():
    spec = _spec("ramp", **HYDRO)
    built = build(spec, sample_period=1e-3)
    df, x = simulate(spec, 0.0, 0.1, sample_rate_hz=1000.0, built=built, return_states=True)
    h = _height(built, x)
    assert np.ptp(h[:60]) < 5e-4                        # unsettled it falls by about 10 mm
    w = df.drive_rate_rad_s.to_numpy()
    assert w[20] > 0.1 and np.all(np.diff(w[:80]) > -0.02)   # rising from the start, no bounce


def test_the_stands_are_not_touched():
    spec = _spec("steer_stand")
    built = build(spec)
    ctx = built.diagram.CreateDefaultContext()
    set_release(built, ctx, 0.5)
    q = built.plant.GetPositions(built.plant.GetMyContextFromRoot(ctx))
    assert q[built.layout.joint_q["steer"]] == 0.5


@pytest.mark.parametrize("kw", [{}, HYDRO])
def test_runs_that_differ_only_in_joint_friction_share_one_settling_bit_for_bit(kw):
    """A ramp run's posterior draws settle once (simulate's `settled`): each draw's run is the
    run it would be settled on its own, and another scenario or start settles anew."""
    draws = [{"steer": {"f_w": 0.2 * s, "f_c": 0.45 * s, "sigma": 10.0, "omega_c": 0.1, "n": 1.0},
              "drive": {"f_w": 1.78 * s, "f_c": 1.24 * s, "sigma": 8.33, "omega_c": 1.36, "n": 1.6}}
             for s in (1.0, 0.6, 1.5)]
    settled = {}
    for fp in draws:
        spec = _spec("ramp", friction_params=fp, **kw)
        alone = simulate(spec, 0.05, 0.3, sample_rate_hz=200.0)
        shared = simulate(spec, 0.05, 0.3, sample_rate_hz=200.0, settled=settled)
        assert alone.equals(shared)
    assert len(settled) == 1
    simulate(_spec("ramp", **kw), -0.05, 0.05, settled=settled)               # another start
    simulate(_spec("ramp", **(kw | {"pressure_kpa": 6.9})), 0.05, 0.05, settled=settled)   # another shell
    assert len(settled) == 3


def test_a_calibrated_soft_shell_starts_settled_however_deep_it_sinks():
    """The hydroelastic calibration's moduli (about 1e4 Pa) hold the robot some 140 mm deep; a
    settling capped at 50 mm dropped such a shell from where it touched, 0.14 m, and bounced it."""
    spec = SimSpec(kind="shell_rock", contact="hydroelastic", pressure_kpa=6.9,
                   shell=ShellParams(hydro_modulus=1.0e4, hydro_dissipation=0.76))
    built = build(spec, sample_period=1e-3)
    df, x = simulate(spec, -0.4, 0.2, sample_rate_hz=1000.0, built=built, return_states=True)
    h = _height(built, x)
    r = built.robot.radius
    assert 0.10 < r - h[0] < 0.5 * r
    assert np.ptp(h[:100]) < 5e-3                         # unsettled it falls by about 140 mm
