"""Reduced planar models (roboball.reduced.planar): constants from the robot facts, the equations of
motion, energy bookkeeping, integration accuracy and the batched API."""
import math

import numpy as np
import pytest

from roboball.reduced import planar as R
from roboball.reduced.integrate import sample
from roboball.config import load_robot
from roboball.errors import RoboballError, SimulationError
from roboball.physics import friction

ROBOT = load_robot()
MAJD_STEER = ROBOT.majd_params("steer")


def _frequency(t, q, rest):
    """Angular frequency from the mean spacing of zero crossings of q - rest."""
    x = q - rest
    i = np.nonzero(np.sign(x[1:]) != np.sign(x[:-1]))[0]
    tc = t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])
    return math.pi / np.mean(np.diff(tc))


# ---- constants and equations -----------------------------------------------------------------
def test_steer_stand_equation_is_the_pendulum_about_the_steer_axis():
    m = R.planar_model("steer_stand", ROBOT)
    p = ROBOT.links["pendulum"]
    y_c, d_z = p.com_m[1], -p.com_m[2]
    assert (y_c, d_z) == pytest.approx((0.0033714, 0.095))
    assert m.inertia(0.3) == pytest.approx(ROBOT.steer_stand_terms["inertia"], rel=1e-12)
    th = np.linspace(-1.5, 1.0, 11)
    assert m.gravity_torque(th) == pytest.approx(-p.mass_kg * ROBOT.g * (y_c * np.cos(th) + d_z * np.sin(th)),
                                                 rel=1e-12, abs=1e-12)
    assert m.rest_angle == pytest.approx(-0.0355, abs=5e-5)
    assert m.rest_angle == pytest.approx(ROBOT.steer_stand_terms["rest_angle"], abs=1e-12)


def test_drive_stand_constants():
    m = R.planar_model("drive_stand", ROBOT)
    assert m.inertia0_kg_m2 == pytest.approx(ROBOT.drive_stand_terms["inertia"], rel=1e-12)
    assert m.g * m.mass_moment_kg_m == pytest.approx(ROBOT.drive_stand_terms["mgd"], rel=1e-12)
    assert m.rest_angle == pytest.approx(0.0, abs=1e-12)
    q = np.array([0.2, -0.7])
    assert m.gravity_torque(q) == pytest.approx(-ROBOT.drive_stand_terms["mgd"] * np.sin(q), rel=1e-12)


def test_shell_rock_linearises_to_eq5_and_rests_at_the_offset_angle():
    m = R.planar_model("shell_rock", ROBOT)
    assert m.rest_angle == pytest.approx(ROBOT.shell_rest_angle, abs=1e-12)
    assert m.rest_angle == pytest.approx(-0.0333, abs=5e-5)
    assert float(m.inertia(0.0)) == pytest.approx(ROBOT.M_eq, rel=1e-9)      # M(0) is eq. 4's M_eq
    assert m.omega_at_rest() == pytest.approx(ROBOT.omega_n_eq5, rel=5e-3)
    assert m.omega_at_rest() == pytest.approx(2.2855, rel=5e-3)
    # and the nonlinear simulation oscillates at that frequency for small swings about rest
    t = np.arange(0.0, 20.0, 0.002)
    q = R.simulate_stand("shell_rock", t, m.rest_angle + 0.01, 0.0, "none", None)[0]
    assert _frequency(t, q, m.rest_angle) == pytest.approx(ROBOT.omega_n_eq5, rel=5e-3)


def test_shell_mass_matrix_and_velocity_term_are_consistent_with_energy():
    """M'(phi) phi'^2 / 2 is what keeps energy constant with a position-dependent M(phi)."""
    m = R.planar_model("shell_rock", ROBOT)
    q = np.linspace(-1.0, 1.0, 7)
    h = 1e-6
    assert m.dinertia(q) == pytest.approx((m.inertia(q + h) - m.inertia(q - h)) / (2 * h), rel=1e-6)
    assert m.gravity_torque(q) == pytest.approx(-(m.potential(q + h) - m.potential(q - h)) / (2 * h), rel=1e-6)


def test_small_swing_frequency_of_the_steer_stand():
    m = R.planar_model("steer_stand", ROBOT)
    t = np.arange(0.0, 10.0, 0.002)
    q = R.simulate_stand("steer_stand", t, m.rest_angle + 0.005, 0.0, "none", None)[0]
    assert _frequency(t, q, m.rest_angle) == pytest.approx(ROBOT.steer_stand_terms["omega_n"], rel=2e-3)


# ---- energy ------------------------------------------------------------------------------------
@pytest.mark.parametrize("kind,q0", [("steer_stand", 1.2), ("drive_stand", 0.8), ("shell_rock", -0.5)])
def test_energy_is_conserved_without_friction(kind, q0):
    m = R.planar_model(kind, ROBOT)
    tr = R.integrate(m, "none", {}, [q0], [0.0], 10.0)
    e = m.energy(tr.q[:, 0], tr.qd[:, 0])
    swing = e[0] - float(m.potential(m.rest_angle))
    assert np.max(np.abs(e - e[0])) / swing < 1e-3


@pytest.mark.parametrize("law,params", [("majd", MAJD_STEER), ("coulomb_viscous", ROBOT.friction_table1["coulomb_viscous"]),
                                        ("viscous", {"c": 0.104})])
def test_energy_lost_equals_friction_work(law, params):
    m = R.planar_model("steer_stand", ROBOT)
    tr = R.integrate(m, law, {k: np.array([v]) for k, v in params.items()}, [1.2], [0.0], 10.0, record_work=True)
    e = m.energy(tr.q[:, 0], tr.qd[:, 0])
    lost = e[0] - e[-1]
    assert lost > 0.5 * (e[0] - float(m.potential(m.rest_angle)))        # friction did take most of it
    assert -tr.work[-1, 0] == pytest.approx(lost, rel=1e-2)
    # and at every instant, not only at the end
    assert np.max(np.abs((e[0] - e) + tr.work[:, 0])) < 1e-2 * lost


# ---- accuracy ---------------------------------------------------------------------------------
T_EVAL = np.arange(0.0, 4.0, 0.01)


def _reduced(law, params, q0, dt=R.DEFAULT_DT, kappa=R.STIFF_KAPPA):
    m = R.planar_model("steer_stand", ROBOT)
    tr = R.integrate(m, law, {k: np.array([v]) for k, v in params.items()}, [q0], [0.0], T_EVAL[-1] + 0.02, dt,
                     stiff_kappa=kappa)
    return sample(tr, T_EVAL)[0]


def _radau(law, params, q0):
    """Independent reference: SciPy's implicit Radau IIA with tight tolerances."""
    from scipy.integrate import solve_ivp

    m = R.planar_model("steer_stand", ROBOT)

    def f(t, y):
        return [y[1], (float(m.gravity_torque(y[0])) + float(friction.torque(law, y[1], params))) / m.inertia0_kg_m2]

    sol = solve_ivp(f, (0.0, T_EVAL[-1]), [q0, 0.0], method="Radau", t_eval=T_EVAL, rtol=1e-10, atol=1e-12)
    assert sol.status == 0
    return sol.y[0]


def test_default_step_is_accurate_for_table1_friction():
    ref = _radau("majd", MAJD_STEER, 1.2)
    assert np.max(np.abs(_reduced("majd", MAJD_STEER, 1.2) - ref)) < 1e-5
    cv = ROBOT.friction_table1["coulomb_viscous"]
    ref = _radau("coulomb_viscous", cv, 1.2)
    # the torque's jump at the stiction band's edges: located, 7.1e-6 rad (stepped across as any
    # fixed-step method would, 2.3e-4 rad)
    assert np.max(np.abs(_reduced("coulomb_viscous", cv, 1.2) - ref)) < 2e-5


@pytest.mark.parametrize("kind, joint, q0", [("steer_stand", "steer", 0.8), ("drive_stand", "drive", 0.7)])
@pytest.mark.parametrize("law", ["viscous", "coulomb_viscous", "majd"])
def test_the_mcmc_forward_model_agrees_with_drake(kind, joint, q0, law):
    """The friction posteriors run this model, not Drake; Fig. 7/8 and the ramp runs use Drake.
    With Table I friction, 4 s of swing: within 1.5 mrad of Drake's stand scenario at a
    0.25 ms step (measured 0.43-0.57 mrad, 1.7-2.3 mrad at Drake's default 1 ms; the sensors'
    quantum is 1 mrad), while 10% more of the law's main term (c, mu_d or f_c) moves the
    reduced model 8-38 mrad away from Drake."""
    from roboball.sim.scenarios import simulate
    from roboball.sim.spec import SimSpec

    params = friction.table1_params(ROBOT, law, joint)
    spec = SimSpec(kind=kind, friction={joint: law}, friction_params={joint: params}, dt=2.5e-4)
    df = simulate(spec, q0, 4.0, sample_rate_hz=100)
    t, y_drake = df.time_s.to_numpy(), df[f"{joint}_angle_rad"].to_numpy()

    def reduced(p):
        return R.simulate_stand(kind, t, q0, 0.0, law, {k: np.array([v]) for k, v in p.items()}, t0=0.0)[0]

    assert np.max(np.abs(reduced(params) - y_drake)) < 1.5e-3
    main = {"viscous": "c", "coulomb_viscous": "mu_d", "majd": "f_c"}[law]
    assert np.max(np.abs(reduced({**params, main: 1.1 * params[main]}) - y_drake)) > 4.5e-3


@pytest.mark.parametrize("kind, joint, q0, delta_i, offset", [("steer_stand", "steer", 0.8, 0.1, -0.02),
                                                             ("drive_stand", "drive", 0.7, -0.05, 0.03)])
def test_the_calibrated_stand_agrees_with_drake(kind, joint, q0, delta_i, offset):
    """The friction fits' calibrated stand (added inertia, rest offset) against Drake's, which
    carries the added inertia on the joint actuator's rotor (inertia delta_i / N^2 behind the gear
    ratio N; negative: a correction of the URDF's inertia) and the offset on the measured angle
    (roboball.sim.scenarios.simulate_calibrated_stand): with Table I Majd friction, 4 s of swing,
    within 1.5 mrad at a 0.25 ms step (measured 0.4-0.6 mrad).  The calibration matters: without
    the added inertia, or without the offset, the reduced model is 20-400 mrad away."""
    from roboball.sim.scenarios import simulate_calibrated_stand
    from roboball.sim.spec import SimSpec

    params = friction.table1_params(ROBOT, "majd", joint)
    spec = SimSpec(kind=kind, friction={joint: "majd"}, friction_params={joint: params}, dt=2.5e-4,
                   added_inertia={joint: delta_i})
    df = simulate_calibrated_stand(spec, q0, 4.0, rest_offset=offset, sample_rate_hz=100)
    t, y_drake = df.time_s.to_numpy(), df[f"{joint}_angle_rad"].to_numpy()

    def reduced(d, o):
        return R.simulate_stand(kind, t, q0, 0.0, "majd", {k: np.array([v]) for k, v in params.items()}, t0=0.0,
                                added_inertia=d, rest_offset=o)[0]

    assert np.max(np.abs(reduced(delta_i, offset) - y_drake)) < 1.5e-3
    assert np.max(np.abs(reduced(0.0, offset) - y_drake)) > 0.02
    assert np.max(np.abs(reduced(delta_i, 0.0) - y_drake)) > 0.02
    assert y_drake[0] == pytest.approx(q0, abs=1e-12)                 # released at the measured angle


def test_stiff_stiction_sticks_without_spurious_creep():
    """Majd with omega_c = 1e-4 rad/s: slope 8e3 N m s/rad at rest, dt * slope / I = 31 at 2.5 ms.
    Plain RK4 chatters across zero speed and creeps ten times too fast; the implicit stiction
    step follows the reference's slow creep."""
    stiff = {"f_w": 0.2, "f_c": 0.8, "sigma": 10.0, "omega_c": 1e-4, "n": 1.0}
    ref = _radau("majd", stiff, 0.3)
    y = _reduced("majd", stiff, 0.3)
    plain = _reduced("majd", stiff, 0.3, kappa=np.inf)
    assert abs(ref[-1] - R.planar_model("steer_stand").rest_angle) > 0.02      # stuck well off rest
    assert np.max(np.abs(y - ref)) < 4e-4
    creep_ref, creep, creep_plain = (a[-1] - a[-150] for a in (ref, y, plain))   # the last 1.5 s
    assert creep == pytest.approx(creep_ref, abs=2e-5)
    assert abs(creep_plain - creep_ref) > 5e-4                                   # what the step fixes


def test_step_error_helper_reports_the_dt_effect():
    e = R.step_error("steer_stand", "majd", MAJD_STEER, 1.0, 4.0, dt=0.01)
    e2 = R.step_error("steer_stand", "majd", MAJD_STEER, 1.0, 4.0, dt=0.005)
    assert e2 < e / 4                                      # RK4: error falls fast with the step


# ---- API -----------------------------------------------------------------------------------------
def test_batch_rows_are_independent_and_match_single_runs():
    t = np.sort(np.random.default_rng(1).uniform(3.0, 9.0, 300))
    stiffish = {k: np.array([v, 0.3, 0.15]) for k, v in MAJD_STEER.items()}
    stiffish["omega_c"] = np.array([0.1, 1e-3, 0.05])
    q0 = np.array([1.0, -0.8, 0.5])
    yb = R.simulate_stand("steer_stand", t, q0, 0.0, "majd", stiffish, t0=3.0)
    for i in range(3):
        yi = R.simulate_stand("steer_stand", t, q0[i], 0.0, "majd", {k: v[i] for k, v in stiffish.items()}, t0=3.0)
        assert np.array_equal(yb[i], yi[0])


def test_release_is_from_rest_at_the_release_time_and_held_before():
    t = np.array([0.0, 0.5, 1.0, 1.0 + 1e-4, 1.3])
    y = R.simulate_stand("steer_stand", t, 0.6, 0.0, "none", None, t0=1.0)[0]
    assert y[0] == y[1] == y[2] == pytest.approx(0.6)
    m = R.planar_model("steer_stand")
    a0 = float(m.gravity_torque(0.6)) / m.inertia0_kg_m2
    assert y[3] - 0.6 == pytest.approx(0.5 * a0 * 1e-8, rel=1e-3)          # starts at rest


@pytest.mark.parametrize("law", ["viscous", "majd"])
def test_the_friction_law_is_the_shared_physics_function(law):
    """The law argument and the same law given as an extra torque produce the same swing.
    (Coulomb + viscous friction given as its law has its band's edges located, which an opaque
    extra torque cannot: test_coulomb_viscous_edges_are_located.)"""
    t = np.arange(0.0, 5.0, 0.01)
    p = friction.table1_params(ROBOT, law, "steer")
    a = R.simulate_stand("steer_stand", t, 1.0, 0.0, law, p)
    b = R.simulate_stand("steer_stand", t, 1.0, 0.0, "none", None,
                         extra_torque=lambda q, v, _: friction.torque(law, v, p))
    assert np.max(np.abs(a - b)) < 1e-12


def test_extra_torque_stiffness_and_injected_shell():
    m = R.planar_model("steer_stand")
    k = 30.0
    t = np.arange(0.0, 8.0, 0.002)
    q = R.simulate_stand("steer_stand", t, m.rest_angle + 0.004, 0.0, "none", None,
                         extra_torque=lambda q, v, p: -k * (q - m.rest_angle))[0]
    assert _frequency(t, q, m.rest_angle) == pytest.approx(math.sqrt((m.g * m.mass_moment_kg_m + k) / m.inertia0_kg_m2),
                                                           rel=3e-3)
    # eq. 9 on the shell: omega = sqrt((K_eq + k_inject) / M_eq) for small swings about 0
    sh = R.planar_model("shell_rock")
    k_inj = 20.0
    tau = R.injected_shell(k_inj, 0.0)
    rest = -sh.g * sh.mass_moment_kg_m * math.sin(sh.offset_rad) / (sh.stiffness_at_rest() + k_inj)  # near-rest shift
    t = np.arange(0.0, 15.0, 0.002)
    q = R.simulate_stand("shell_rock", t, rest + 0.005, 0.0, "none", None, extra_torque=tau)[0]
    assert _frequency(t, q, np.mean(q)) == pytest.approx(math.sqrt((ROBOT.K_eq + k_inj) / ROBOT.M_eq), rel=5e-3)
    # per-walker injected parameters by name
    y2 = R.simulate_stand("shell_rock", t[:50], -0.3, 0.0, "none", {"k": np.array([0.0, 50.0]), "c": 0.0},
                          extra_torque=R.injected_shell("k", "c"))
    assert y2.shape == (2, 50) and not np.allclose(y2[0], y2[1])


def test_bad_input_is_a_one_line_error():
    with pytest.raises(RoboballError, match="unknown kind"):
        R.planar_model("ramp")
    with pytest.raises(RoboballError, match="different lengths"):
        R.simulate_stand("steer_stand", [0.0, 1.0], np.zeros(3), 0.0, "viscous", {"c": np.ones(2)})
    with pytest.raises(RoboballError, match="unknown friction law"):
        R.simulate_stand("steer_stand", [0.0, 1.0], 0.1, 0.0, "stribeck", {})
    with pytest.raises(RoboballError, match="missing parameter"):
        R.simulate_stand("steer_stand", [0.0, 1.0], 0.1, 0.0, "majd", {"f_w": 0.1})
    with pytest.raises(SimulationError, match="diverged"):
        R.simulate_stand("steer_stand", np.arange(0, 2, 0.01), 0.1, 0.0, "none", None,
                         extra_torque=lambda q, v, p: 1e7 * q)


@pytest.mark.parametrize("compiled", [True, False], ids=["compiled loop", "NumPy loop"])
def test_coulomb_viscous_edges_are_located(compiled):
    """The torque of eq. 2 jumps at the stiction band's edges; a step cut at the crossing keeps
    the swing a smooth function of the parameters, which a posterior sampler needs.  Over a sweep
    of mu_d by +-2%, the second differences of the late mean angle measured 2.7e-4 of the first
    (a step taken across the jump: 0.073, jitter a chain cannot mix through)."""
    cv = dict(ROBOT.friction_table1["coulomb_viscous"])
    mu = cv["mu_d"] * (1.0 + np.linspace(-0.02, 0.02, 81))
    m = R.planar_model("steer_stand", ROBOT)
    tr = R.integrate(m, "coulomb_viscous", {**cv, "mu_d": mu}, np.full(81, 1.0), np.zeros(81), 6.0, 1.25e-3,
                     compiled=compiled)
    late = sample(tr, np.arange(3.0, 6.0, 0.01)).mean(axis=1)
    assert np.max(np.abs(np.diff(late, 2))) < 0.01 * np.mean(np.abs(np.diff(late)))
