"""The shell model with the pendulum free on its steer joint (roboball.reduced.shell_steer)
agrees with Drake's coupled scenario, and with the steer joint held it is the locked model."""
import numpy as np
import pytest

from roboball.diagnose.drake import effect_term
from roboball.reduced.shell import ShellModel
from roboball.reduced.shell_steer import ShellSteerModel, integrate
from roboball.sim.coupled import coupled_spec
from roboball.sim.scenarios import simulate
from roboball.sim.spec import ShellParams

DT = 2e-3


def _reduced(model, q0, steer0, rate0, effects, duration):
    P = {f"{e}.{p}": np.array([v]) for e, ps in effects.items() for p, v in ps.items()}
    P.update(steer_angle=np.array([steer0]), steer_rate=np.array([rate0]))
    Y, _ = model.simulate(np.array([q0]), P, int(round(duration / DT)), DT)
    return np.arange(Y.shape[0]) * DT, Y[:, 0]


@pytest.mark.parametrize("effects, steer0, rate0", [
    ({}, 0.3, 0.0),
    # about what the real dynamic log's diagnosis finds (docs/diagnosis.md)
    ({"linear_stiffness": {"k": 55.0}, "viscous_damping": {"c": 8.0}, "com_offset": {"delta": 0.02}}, -0.4, -3.8),
], ids=["baseline", "stiffness+damping+offset"])
def test_free_steer_shell_matches_drake_coupled_point_contact(effects, steer0, rate0):
    """Same start in both (pipe 0.4 rad at rest, the steer joint swinging): the pipe angle
    within 0.5% of its swing over 6 s (measured: 0.16%, 0.09%) (Drake's compliant point contact against rolling)."""
    model = ShellSteerModel()
    t, y = _reduced(model, 0.4, steer0, rate0, effects, 6.0)
    term = effect_term(model, effects)
    spec = coupled_spec("point", ShellParams(), model.majd, extra_terms=[term] if term else [], dt=1e-3)
    df = simulate(spec, 0.4, 6.0, sample_rate_hz=500, steer0=steer0,
                  rates0={"pipe_rate": 0.0, "steer_rate": rate0})
    yd = df["pipe_angle_rad"].to_numpy()
    yr = np.interp(df.time_s.to_numpy(), t, y)
    assert np.max(np.abs(yr - yd)) < 0.005 * np.ptp(yd)


def _energy(model, ph, th, v, w):
    """Kinetic plus potential energy (J) of the two bodies (module docstring's positions)."""
    R, g = model.radius, model.g
    total = 0.0
    for (m, cy, cz, i), a, ad in ((model.a, ph, v), (model.b, ph + th, v + w)):
        uy, uz = -cy * np.sin(a) - cz * np.cos(a), cy * np.cos(a) - cz * np.sin(a)
        vy, vz = -R * v + uy * ad, uz * ad
        z = R + cy * np.sin(a) + cz * np.cos(a)
        total = total + 0.5 * m * (vy * vy + vz * vz) + 0.5 * i * ad * ad + m * g * z
    return total


def test_without_friction_the_free_steer_shell_conserves_energy():
    """Mass matrix, velocity terms and gravity of one Lagrangian: with no joint friction and no
    effect the energy drifts by under 5e-5 of the swing's energy over 6 s of large swings at the
    diagnosis's 2 ms step, and at least four times less at 1 ms (the midpoint method's second
    order; an inconsistent term would leave a drift that does not shrink with the step)."""
    model = ShellSteerModel(friction={"f_w": 0.0, "f_c": 0.0, "sigma": 0.0, "omega_c": 0.1, "n": 1.0})
    rest = _energy(model, model.rest, model.steer_rest, 0.0, 0.0)
    drifts = []
    for dt in (DT, DT / 2):
        Q, V, TH, W = integrate(model, None, np.array([0.4, -0.3]), np.array([-0.4, 0.8]), np.array([-3.8, 1.0]),
                                int(round(6.0 / dt)), dt)
        e = _energy(model, Q, TH, V, W)
        drifts.append(np.max(np.abs(e - e[0]), axis=0) / (e[0] - rest))
    assert np.all(drifts[0] < 5e-5), drifts[0]
    assert np.all(drifts[1] < drifts[0] / 4), drifts


def test_rest_is_each_bodys_centre_of_mass_below_the_sphere_centre():
    model = ShellSteerModel()
    accel = model.equations(None)
    a, b = accel(np.array([model.rest]), np.array([model.steer_rest]), np.zeros(1), np.zeros(1))
    assert abs(a[0]) < 1e-12 and abs(b[0]) < 1e-12
    # the pendulum's centre of mass sits 3.37 mm off the steer axis (robot facts): rest -0.0355 rad
    assert model.steer_rest == pytest.approx(-0.0355, abs=2e-4)
    assert model.rest == 0.0


def test_with_the_steer_joint_held_it_is_the_locked_shell_model():
    """A rotor inertia of 1e9 kg m^2 on the steer joint (no friction) holds it at 0: the pipe angle
    then follows roboball.reduced.shell.ShellModel, the locked robot's own equation, to 1e-6 rad."""
    free = ShellSteerModel(friction={"f_w": 0.0, "f_c": 0.0, "sigma": 0.0, "omega_c": 0.1, "n": 1.0, "delta_i": 1e9})
    q0 = np.array([0.4, -0.25])
    Qf, _, TH, _ = integrate(free, None, q0, np.zeros(2), np.zeros(2), 2000, DT)
    Ql, _ = ShellModel().simulate(q0, {}, 2000, DT)
    assert np.max(np.abs(TH)) < 1e-6
    np.testing.assert_allclose(Qf, Ql, atol=1e-6)
