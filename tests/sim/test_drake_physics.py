"""The Drake robot reproduces the derived numbers of robot-facts.md."""
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from conftest import fit_damped
from roboball.physics import friction
from roboball.sim.plant import build
from roboball.sim.scenarios import energy, set_release, signals_from_states, simulate
from roboball.sim.spec import ShellParams, SimSpec


def test_shell_rock_point_contact_matches_eq5(robot):
    df = simulate(SimSpec(kind="shell_rock", contact="point"), 0.05, 20.0, sample_rate_hz=200)
    fit = fit_damped(df.time_s, df.pipe_angle_rad)
    assert robot.omega_n_eq5 == pytest.approx(2.286, abs=1e-3)   # 2.2855 from the URDF values
    assert fit["omega_n"] == pytest.approx(2.286, rel=0.01)
    assert abs(fit["zeta"]) < 0.005
    assert fit["rest"] == pytest.approx(-0.0333, abs=5e-4)


def test_steer_stand_frequency_rest_and_energy(robot):
    spec = SimSpec(kind="steer_stand")
    built = build(spec, sample_period=1.0 / 200)
    from pydrake.systems.analysis import Simulator

    sim = Simulator(built.diagram)
    set_release(built, sim.get_mutable_context(), 0.05)
    sim.AdvanceTo(10.0)
    log = built.logger.FindLog(sim.get_context())
    sig = signals_from_states(built, log.data())
    fit = fit_damped(log.sample_times(), sig["steer_angle_rad"])
    assert fit["omega_n"] == pytest.approx(5.659, rel=0.01)
    assert fit["rest"] == pytest.approx(-0.0355, abs=0.001)
    e = energy(built, log.data())
    # Drift of the swing's energy over 10 s: mean over the first vs the last period, relative
    # to the swing's own energy (the potential-energy datum is arbitrary).
    e_swing = 0.5 * robot.steer_stand_terms["mgd"] * (0.05 - robot.steer_stand_terms["rest_angle"]) ** 2
    n_period = int(round(2 * math.pi / 5.659 * 200))
    drift = abs(e[-n_period:].mean() - e[:n_period].mean()) / e_swing
    assert drift < 0.005, drift


@pytest.mark.parametrize("p_kpa,zeta,omega_n", [(6.9, 0.18, 2.45), (13.8, 0.10, 2.75), (20.7, 0.06, 3.05)])
def test_injected_shell_reproduces_zeta_omega(p_kpa, zeta, omega_n):
    spec = SimSpec(kind="shell_rock", contact="injected", pressure_kpa=p_kpa,
                   shell=ShellParams(zeta=zeta, omega_n=omega_n))
    df = simulate(spec, 0.08, 12.0, sample_rate_hz=200)
    fit = fit_damped(df.time_s, df.pipe_angle_rad)
    assert fit["zeta"] == pytest.approx(zeta, rel=0.03)
    assert fit["omega_n"] == pytest.approx(omega_n, rel=0.03)


# ---- friction laws at hand-computed points --------------------------------------------------
def test_viscous_and_coulomb_hand_values():
    assert friction.viscous(2.0, c=0.104) == pytest.approx(-0.208)
    # eq. 2 outside the stiction band: -mu_d sign(v) - c v
    assert friction.coulomb_viscous(0.5, 0.7, 0.65, 0.104) == pytest.approx(-0.65 - 0.052)
    assert friction.coulomb_viscous(-0.5, 0.7, 0.65, 0.104) == pytest.approx(0.65 + 0.052)
    # inside |v| < v_tol: regularised stiction, reaching mu_s at the band's edge
    assert friction.coulomb_viscous(0.005, 0.7, 0.65, 0.104, v_tol=0.01) == pytest.approx(-0.35)
    assert friction.coulomb_viscous(0.0, 0.7, 0.65, 0.104) == 0.0


def test_coulomb_band_edge_belongs_to_the_outside_branch():
    # the stiction band is |v| < v_tol: exactly at its edge the outside branch applies, -mu_d - c v_tol
    # (not the regularised stiction value -mu_s)
    assert friction.coulomb_viscous(0.01, 0.7, 0.65, 0.104, v_tol=0.01) == pytest.approx(-0.65 - 0.00104)
    assert friction.coulomb_viscous(-0.01, 0.7, 0.65, 0.104, v_tol=0.01) == pytest.approx(0.65 + 0.00104)


def test_table1_params_pick_each_joints_majd_row(robot):
    """Table I (configs/robot.yaml): the drive joint's Majd values are not the steer joint's."""
    drive = friction.table1_params(robot, "majd", "drive")
    steer = friction.table1_params(robot, "majd", "steer")
    assert drive == pytest.approx({"f_w": 1.78, "f_c": 1.24, "sigma": 8.33, "omega_c": 1.36, "n": 1.60})
    assert steer == pytest.approx({"f_w": 0.20, "f_c": 0.45, "sigma": 10.0, "omega_c": 0.1, "n": 1.0})
    assert friction.table1_params(robot, "viscous", "drive") == {"c": 0.104}
    assert friction.table1_params(robot, "none", "drive") == {}


def test_majd_hand_values():
    # Table I drive: f_w 1.78, f_c 1.24, sigma 8.33, omega_c 1.36, n 1.60 at v = 0.5 rad/s:
    # x = 0.5/1.36 = 0.367647; e^-x = 0.692362; e^-1.6x = 0.555306
    # hump = 1.24 + 8.33*0.692362 - 9.57*0.555306 = 1.693089; tau = -(0.89 + 1.693089)
    tau = friction.majd(0.5, 1.78, 1.24, 8.33, 1.36, 1.60)
    assert tau == pytest.approx(-(0.89 + 1.24 + 8.33 * math.exp(-0.5 / 1.36) - 9.57 * math.exp(-0.8 / 1.36)))
    assert tau == pytest.approx(-2.583089, abs=1e-5)
    # Table I steer (n = 1): tau = -(f_w v + f_c (1 - e^{-|v|/omega_c}) sign v); at v = -0.2:
    assert friction.majd(-0.2, 0.20, 0.45, 10, 0.1, 1) == pytest.approx(0.04 + 0.45 * (1 - math.exp(-2)))
    assert friction.majd(0.0, 1.78, 1.24, 8.33, 1.36, 1.60) == 0.0
    v = np.linspace(-3, 3, 601)
    for law, p in [("viscous", {"c": 0.1}), ("coulomb_viscous", {"mu_s": 0.7, "mu_d": 0.65, "c": 0.1}),
                   ("majd", {"f_w": 1.78, "f_c": 1.24, "sigma": 8.33, "omega_c": 1.36, "n": 1.6})]:
        assert np.all(friction.torque(law, v, p) * v <= 0.0), law   # always dissipative


@pytest.mark.parametrize("law", ["viscous", "coulomb_viscous", "majd"])
def test_drake_stand_energy_loss_equals_friction_work(law, robot):
    """Energy lost by the swing equals the work of the friction torque (within 2%)."""
    from pydrake.systems.analysis import Simulator

    dt = 1e-3
    spec = SimSpec(kind="steer_stand", friction={"steer": law, "drive": "none"}, dt=dt)
    built = build(spec, sample_period=dt)
    sim = Simulator(built.diagram)
    set_release(built, sim.get_mutable_context(), 0.3)
    sim.AdvanceTo(3.0)
    x = built.logger.FindLog(sim.get_context()).data()
    e = energy(built, x)
    v = x[built.layout.nq + built.layout.joint_v["steer"]]
    params = friction.table1_params(robot, law, "steer")
    # Discrete plant: the torque applied over step k is evaluated at the state at the step's
    # start and acts on the step's end velocity (semi-implicit); its work over the step is
    # tau(v_k) * v_{k+1} * dt.
    work = np.sum(friction.torque(law, v[:-1], params) * v[1:] * dt)
    lost = e[-1] - e[0]
    assert lost < -0.2                                   # the swing really lost energy
    assert lost == pytest.approx(work, rel=0.02)


def test_ramp_locked_joints_matches_rolling_ode(robot):
    alpha = math.radians(robot.ramp_angle_deg)
    spec = SimSpec(kind="ramp", contact="point", lock_joints=("steer", "drive"))
    df = simulate(spec, 0.0, 1.5, sample_rate_hz=200)

    # Independent planar model: rigid sphere (radius R) with its CoM a depth d below the centre
    # rolling without slip; beta = rotation about +y (downhill positive), body upright at start.
    m = robot.total_mass
    zs = {n: l.com_m[2] for n, l in robot.links.items()}
    xs = {n: l.com_m[0] for n, l in robot.links.items()}
    z_g = sum(l.mass_kg * zs[n] for n, l in robot.links.items()) / m
    x_g = sum(l.mass_kg * xs[n] for n, l in robot.links.items()) / m
    d = -z_g
    i_g = sum(l.inertia_kg_m2[1] + l.mass_kg * ((xs[n] - x_g) ** 2 + (zs[n] - z_g) ** 2)
              for n, l in robot.links.items())
    R, g = robot.radius, robot.g

    def rhs(t, s):
        b, bd = s
        M = m * (R * R - 2 * R * d * math.cos(b) + d * d) + i_g
        num = m * g * (math.sin(alpha) * (R - d * math.cos(b)) - math.cos(alpha) * d * math.sin(b)) \
            - m * R * d * math.sin(b) * bd * bd
        return [bd, num / M]

    sol = solve_ivp(rhs, (0, 1.5), [-alpha, 0.0], t_eval=df.time_s.values, rtol=1e-10, atol=1e-12)
    w_ode = sol.y[1]
    w_sim = df.drive_rate_rad_s.values
    assert w_ode[-1] > 2.0                                 # it really rolled downhill
    mask = df.time_s.values > 0.2
    rel = np.abs(w_sim[mask] - w_ode[mask]) / np.abs(w_ode[mask])
    assert rel.max() < 0.02, rel.max()


def test_a_steer_release_past_the_joint_stop_is_refused():
    """Drake's limit stop would throw the pendulum across its range in a few ms (Fig. 7 once
    showed it): a release outside [-1.57, 1.0] rad is a clear error, not a simulation."""
    from roboball.errors import SimulationError
    from roboball.sim.scenarios import simulate
    from roboball.sim.spec import SimSpec

    spec = SimSpec(kind="steer_stand", friction={"steer": "viscous", "drive": "none"}, friction_params={"steer": {"c": 0.3}})
    with pytest.raises(SimulationError, match=r"release angle 1.158 rad is outside the steer joint's limits \[-1.57, 1\]"):
        simulate(spec, 1.158, 0.1)
    df = simulate(spec, 0.99, 0.1)                     # just inside: an ordinary swing
    assert np.all(np.diff(df.steer_angle_rad.to_numpy()) <= 1e-9) and df.steer_angle_rad.iloc[-1] > 0.8


@pytest.mark.parametrize("contact", ["point", "hydroelastic"])
def test_unsampled_output_ports_give_bit_identical_descents(contact):
    """build() turns off Drake's sampled output ports (a 2.4x cheaper step); with the models'
    stateless force systems the trajectory of a ramp descent with Majd friction on both joints
    must not change by a single bit.  (The test bed, whose LuGre friction has a discrete state,
    keeps Drake's sampled ports: tests/testbed/test_testbed.py regenerates its files bit-for-bit.)"""
    from dataclasses import replace

    from roboball.sim.convergence import ramp_spec

    spec = ramp_spec(contact, 2e-3)
    runs = {}
    for sampled in (True, False):
        s = replace(spec, sampled_output_ports=sampled)
        built = build(s, sample_period=0.01)
        assert built.plant.has_sampled_output_ports() is sampled
        _, x = simulate(s, 0.0, 0.6, built=built, return_states=True)
        runs[sampled] = x
    assert np.array_equal(runs[True], runs[False])


# ---- the force system at a given state: the laws, mapped onto the plant's velocities -----------
def _ramp_state(built):
    """A general ramp state (rolled, pitched and yawed base, both joints moving) and the plant
    context holding it."""
    from pydrake.math import RollPitchYaw, RotationMatrix

    lay, plant = built.layout, built.plant
    q, v = np.zeros(lay.nq), np.zeros(lay.nv)
    q[lay.base_q:lay.base_q + 4] = RotationMatrix(RollPitchYaw([0.3, -0.2, 0.9])).ToQuaternion().wxyz()
    q[lay.base_q + 4:lay.base_q + 7] = [0.1, -0.3, 0.4]
    q[lay.joint_q["steer"]], q[lay.joint_q["drive"]] = 0.1, 0.4
    v[lay.base_v:lay.base_v + 6] = [0.4, -1.3, 0.25, 0.1, 0.2, -0.05]
    v[lay.joint_v["steer"]], v[lay.joint_v["drive"]] = 0.7, -2.1
    ctx = plant.CreateDefaultContext()
    plant.SetPositionsAndVelocities(ctx, np.concatenate([q, v]))
    return q, v, plant, ctx


def _tau(system, q, v):
    ctx = system.CreateDefaultContext()
    system.get_input_port(0).FixValue(ctx, np.concatenate([q, v]))
    return np.array(system.get_output_port(0).Eval(ctx))


def _shell_by_hand(built, plant, ctx, v, k, c, steer, drive):
    """Eq. 9 mapped with Drake's own kinematics: -K phi - C phi_dot on the base's world-x angular
    velocity (phi = the base's roll); a couple T = -C omega_d on the pipe about the driveshaft
    (+y of the base), omega_d the pipe's angular velocity about it, as generalised forces J_w^T T."""
    from pydrake.math import RollPitchYaw
    from pydrake.multibody.tree import JacobianWrtVariable

    lay = built.layout
    tau = np.zeros(lay.nv)
    R_WB = plant.EvalBodyPoseInWorld(ctx, plant.GetBodyByName("pitch_center")).rotation()
    if steer:
        phi = RollPitchYaw(R_WB).roll_angle()
        assert phi == pytest.approx(0.3)
        tau[lay.base_v] += -c * v[lay.base_v] - k * phi
    if drive:
        pipe = plant.GetBodyByName("pipe_assembly")
        axle = R_WB.matrix()[:, 1]
        omega_d = plant.EvalBodySpatialVelocityInWorld(ctx, pipe).rotational() @ axle
        Jw = plant.CalcJacobianAngularVelocity(ctx, JacobianWrtVariable.kV, pipe.body_frame(),
                                               plant.world_frame(), plant.world_frame())
        tau += Jw.T @ (-c * omega_d * axle)
    return tau


def test_force_system_is_the_friction_laws_plus_eq9_at_a_given_state(robot):
    """The SymbolicVectorSystem the plant is driven by, evaluated at one general ramp state,
    equals the NumPy friction laws on each joint's own velocity plus the injected shell mapped
    onto the generalised velocities by Drake's Jacobian of the pipe (terms on the same velocity
    add up; the drive joint carries both its friction and the shell's reaction)."""
    from roboball.sim.forces import InjectedShell, JointFriction, build_force_system

    built = build(SimSpec(kind="ramp"))
    lay = built.layout
    q, v, plant, ctx = _ramp_state(built)
    steer_p = {"mu_s": 0.7, "mu_d": 0.65, "c": 0.104, "v_tol": 0.01}
    drive_p = friction.table1_params(robot, "majd", "drive")
    k, c = 3.1, 0.83
    system = build_force_system(lay, [JointFriction("steer", "coulomb_viscous", steer_p),
                                      JointFriction("drive", "majd", drive_p), InjectedShell(k, c)])
    expected = _shell_by_hand(built, plant, ctx, v, k, c, steer=True, drive=True)
    expected[lay.joint_v["steer"]] += friction.coulomb_viscous(0.7, **steer_p)      # -0.65 - 0.0728
    expected[lay.joint_v["drive"]] += friction.majd(-2.1, **drive_p)                # > 0: opposes v < 0
    assert expected[lay.joint_v["drive"]] != 0.0 and np.count_nonzero(expected[lay.base_v:lay.base_v + 3]) == 3
    np.testing.assert_allclose(_tau(system, q, v), expected, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("steer,drive", [(True, False), (False, True)])
def test_injected_shell_flags_drop_exactly_their_direction(steer, drive):
    """ShellParams.injected_steer / injected_drive (section IV): with one direction off, the
    force system holds the other direction's torque only."""
    from roboball.sim.forces import InjectedShell, build_force_system

    built = build(SimSpec(kind="ramp"))
    q, v, plant, ctx = _ramp_state(built)
    k, c = 3.1, 0.83
    system = build_force_system(built.layout, [InjectedShell(k, c, steer=steer, drive=drive)])
    expected = _shell_by_hand(built, plant, ctx, v, k, c, steer=steer, drive=drive)
    np.testing.assert_allclose(_tau(system, q, v), expected, rtol=1e-12, atol=1e-12)
    assert bool(expected[built.layout.joint_v["drive"]] != 0.0) == drive


def test_kin_base_rotation_is_drakes_rotation_of_the_base():
    """Kin.base_rotation (used by the shell and effect terms) is R_WB of the base, every entry."""
    from roboball.sim.forces import Kin

    built = build(SimSpec(kind="ramp"))
    q, v, plant, ctx = _ramp_state(built)
    R_WB = plant.EvalBodyPoseInWorld(ctx, plant.GetBodyByName("pitch_center")).rotation().matrix()
    np.testing.assert_allclose(np.array(Kin(built.layout, q, v, None).base_rotation(), float), R_WB, atol=1e-12)
