"""The compiled time loop (roboball.reduced.kernel) against the NumPy loop (roboball.reduced.integrate).

The friction posterior runs on the compiled loop; these tests are what lets it stand in for the
NumPy loop (which the accuracy tests of test_reduced.py check against a Radau reference).
Tolerance: 1e-9 rad.  The loops run the same operations in the same order; what differs is the
last bits of exp/sin (libm against NumPy's vector routines), seen here at <= 2e-15 rad over 10 s
swings.  Parameter sets come from the fit's own priors (configs/priors.yaml)."""
import numpy as np
import pytest

from roboball.reduced import planar as R
from roboball.reduced import kernel as K
from roboball.config import load_robot
from roboball.identify.friction.priors import law_fixed, law_priors
from roboball.physics import friction

ROBOT = load_robot()
TOL = 1e-9


def _both(kind, law, params, q0, duration=10.0, dt=2.5e-3):
    model = R.planar_model(kind, ROBOT)
    v0 = np.zeros_like(q0)
    a = R.integrate(model, law, params, q0, v0, duration, dt)
    b = R.integrate(model, law, params, q0, v0, duration, dt, compiled=False)
    return a, b


@pytest.mark.parametrize("joint", ["steer", "drive"])
@pytest.mark.parametrize("law", ["viscous", "coulomb_viscous", "majd"])
def test_compiled_loop_matches_numpy_loop_over_prior_draws(joint, law):
    kind = f"{joint}_stand"
    rng = np.random.default_rng(3)
    B = 96
    params = friction.natural_params(law, {**{name: p.theta(p.sample_u(rng, B)) for name, p in law_priors(joint, law).items()},
                                           **law_fixed(joint, law)})
    q0 = R.planar_model(kind, ROBOT).rest_angle + rng.uniform(-1.0, 1.0, B)
    a, b = _both(kind, law, params, q0)
    assert a.q.shape == b.q.shape and a.qd.shape == b.qd.shape
    assert np.max(np.abs(a.q - b.q)) < TOL
    assert np.max(np.abs(a.qd - b.qd)) < 1e3 * TOL


def test_compiled_loop_takes_the_implicit_stiction_step_like_the_numpy_loop():
    """omega_c = 1e-4 rad/s (far below the prior's 0.02): the stiff band is active; plain RK4
    would creep (test_reduced.py).  Tolerance 2e-5 rad here: in the slow creep at the edge of
    the stiff band both loops alternate between RK4 and implicit steps, and that switching
    amplifies last-bit differences (measured: 1e-15 rad at 4.74 s grows to 7e-6 rad by 6 s, for
    either loop against itself with perturbed start angles as well).  2e-5 rad is 1/50 of the
    logs' 1 mrad quantisation."""
    stiff = {"f_w": 0.2, "f_c": 0.8, "sigma": 10.0, "omega_c": 1e-4, "n": 1.0}
    a, b = _both("steer_stand", "majd", stiff, np.array([0.3, -0.5, 0.9]), duration=6.0)
    assert a.implicit_steps > 0
    assert np.max(np.abs(a.q[:, :2] - b.q[:, :2])) < TOL
    assert np.max(np.abs(a.q - b.q)) < 2e-5
    assert abs(a.q[-1, 0] - R.planar_model("steer_stand").rest_angle) > 0.02      # stuck off rest


def test_compiled_loop_on_the_shell_with_its_position_dependent_inertia():
    params = {"f_w": np.array([0.05, 0.2]), "f_c": 0.3, "sigma": 2.0, "omega_c": 0.1, "n": 1.5}
    a, b = _both("shell_rock", "majd", params, np.array([0.2, -0.15]))
    assert np.max(np.abs(a.q - b.q)) < TOL


def test_compiled_runs_do_not_depend_on_the_number_of_threads():
    import numba

    rng = np.random.default_rng(5)
    params = friction.natural_params("majd", {**{name: p.theta(p.sample_u(rng, 40))
                                                 for name, p in law_priors("steer", "majd").items()},
                                              "n": rng.uniform(1.05, 4.0, 40)})
    q0 = rng.uniform(-1.0, 1.0, 40)
    model = R.planar_model("steer_stand", ROBOT)
    n0 = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = R.integrate(model, "majd", params, q0, np.zeros(40), 5.0)
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        many = R.integrate(model, "majd", params, q0, np.zeros(40), 5.0)
    finally:
        numba.set_num_threads(n0)
    assert np.array_equal(one.q, many.q)


@pytest.mark.parametrize("law", ["viscous", "coulomb_viscous", "majd"])
def test_the_compiled_law_is_the_physics_function(law):
    """The loop calls friction.<law> itself, compiled with the scalar namespace."""
    code = K.LAW_CODES[law]
    p = friction.table1_params(ROBOT, law, "steer")
    if law == "coulomb_viscous":
        p.setdefault("v_tol", 0.01)
    row = np.array([p[k] for k in friction.PARAMS[law]], dtype=float)
    v = np.concatenate([np.linspace(-3.0, 3.0, 601), [0.0, 1e-9, -1e-9]])
    ref = friction.torque(law, v, p)
    got = np.array([K._friction(code, x, row, 0.0) for x in v])
    assert np.max(np.abs(got - ref)) < 1e-12
    if law == "coulomb_viscous":            # each branch continued past the band's edges
        for side in (friction.BAND, 1.0, -1.0):
            ref = friction.coulomb_viscous(v, p["mu_s"], p["mu_d"], p["c"], p["v_tol"], side=side)
            got = np.array([K._friction(code, x, row, side) for x in v])
            assert np.max(np.abs(got - ref)) < 1e-12


def test_runs_the_compiled_loop_cannot_take_stay_on_numpy():
    """Extra torques (diagnosis effects) and work records are not compiled."""
    assert K.supports("majd", None, False)
    assert not K.supports("majd", lambda q, v, p: 0.0 * q, False)
    assert not K.supports("majd", None, True)
    assert not K.supports("none", None, False)


def test_segments_stop_at_their_own_end_and_match_the_numpy_loop(monkeypatch):
    """simulate_segments lets each release's rows stop at that release's last sample."""
    segs = [(np.linspace(1.0, 3.0, 200), 1.0), (np.linspace(5.0, 12.0, 500), 5.0), (np.linspace(20.0, 21.0, 50), 20.0)]
    params = {k: np.array([v, 1.3 * v, 0.7 * v]) for k, v in ROBOT.majd_params("steer").items()}
    q0 = np.array([[0.8, -0.6, 0.3], [0.5, 0.9, -1.0], [-0.2, 0.4, 0.7]])
    a = R.simulate_segments("steer_stand", segs, q0, "majd", params)
    monkeypatch.setattr(K, "supports", lambda *args: False)
    b = R.simulate_segments("steer_stand", segs, q0, "majd", params)
    for ya, yb in zip(a, b):
        assert ya.shape == yb.shape
        assert np.max(np.abs(ya - yb)) < TOL


def test_a_calibrated_stand_runs_alike_in_both_loops(monkeypatch):
    """The calibrated stand of the friction fits: an added inertia per walker (compiled: one M0 per
    row), a rest offset per walker and a shift of each release's instant, the same in both loops;
    and the rows are those of single runs of each walker's calibrated stand."""
    segs = [(np.linspace(1.0, 4.0, 300), 1.0), (np.linspace(5.0, 9.0, 400), 5.0)]
    params = {k: np.array([v, 1.3 * v, 0.7 * v]) for k, v in ROBOT.majd_params("steer").items()}
    q0 = np.array([[0.8, -0.6], [0.5, 0.9], [-0.2, 0.4]])
    cal = dict(added_inertia=np.array([0.0, 0.08, -0.03]), rest_offset=np.array([0.0, 0.01, -0.02]),
               release_shift=np.array([[0.0, 0.05], [-0.04, 0.0], [0.1, -0.1]]))
    a = R.simulate_segments("steer_stand", segs, q0, "majd", params, **cal)
    monkeypatch.setattr(K, "supports", lambda *args: False)
    b = R.simulate_segments("steer_stand", segs, q0, "majd", params, **cal)
    for s, (ya, yb) in enumerate(zip(a, b)):
        assert np.max(np.abs(ya - yb)) < TOL
        t, t_rel = segs[s]
        for w in range(3):
            one = R.simulate_stand("steer_stand", t, q0[w, s], 0.0, "majd", {k: v[w] for k, v in params.items()},
                                   t0=t_rel + cal["release_shift"][w, s], added_inertia=cal["added_inertia"][w],
                                   rest_offset=cal["rest_offset"][w])[0]
            assert np.max(np.abs(ya[w] - one)) < 1e-6, (s, w)
    assert np.max(np.abs(a[0][1] - a[0][0])) > 0.05                 # the calibration acts
