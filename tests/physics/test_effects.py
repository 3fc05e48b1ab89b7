"""The effect library (issue 6): one law per vocabulary entry, evaluated identically on NumPy and
on Drake symbolic expressions."""
import math

import numpy as np
import pydrake.symbolic as sym
import pytest

from roboball.physics import effects as fx
from roboball.sim.forces import SYM

VOCABULARY = ("viscous_damping", "coulomb_friction", "stiction", "quadratic_drag", "linear_stiffness",
              "cubic_stiffness", "com_offset", "backlash", "rolling_resistance", "added_inertia")
PARAMS = {"viscous_damping": {"c": 0.3}, "coulomb_friction": {"tau_c": 0.45}, "stiction": {"tau_s": 0.2},
          "quadratic_drag": {"c2": 0.1}, "linear_stiffness": {"k": -2.0}, "cubic_stiffness": {"k3": 5.0},
          "com_offset": {"delta": 0.03}, "backlash": {"k_b": 6.0, "b": 0.2}, "rolling_resistance": {"tau_rr": 1.2},
          "added_inertia": {"delta_i": 0.06}}
CONTEXT = {"k_g": 20.54}


def test_library_holds_exactly_the_vocabulary_with_units_and_bounds():
    assert fx.VOCABULARY == VOCABULARY
    for name, eff in fx.LIBRARY.items():
        assert eff.params, name
        for p in eff.params:
            assert p.unit and p.lo < p.hi and p.lo <= p.typical <= p.hi, (name, p)
    assert fx.LIBRARY["com_offset"].kind == "geometric" and fx.LIBRARY["com_offset"].context == ("k_g",)


def test_an_effect_at_a_reducing_parameter_of_zero_is_exactly_its_simpler_entry():
    """Backlash with no free play IS linear stiffness: the selection must then report the
    simpler entry (roboball.diagnose.keep.KeepRule.not_itself), which it can only do if the
    library says so and the two laws agree."""
    q = np.linspace(-0.8, 0.8, 33)
    qd = np.linspace(1.0, -1.0, 33)
    nested = {name: eff for name, eff in fx.LIBRARY.items() if eff.reduces_to}
    assert set(nested) == {"backlash"}
    for name, eff in nested.items():
        assert eff.defining_params()[0] == eff.params[0].name
        for param, simpler in eff.reduces_to:
            assert simpler in fx.LIBRARY and param in eff.defining_params()
            mag = {p.name: p.typical for p in eff.params} | {param: 0.0}
            other = fx.LIBRARY[simpler]
            same = {other.params[0].name: mag[eff.params[0].name]}
            assert np.allclose(eff.law(q, qd, **mag), other.law(q, qd, **same), atol=1e-12)
    assert fx.LIBRARY["coulomb_friction"].defining_params() == ("tau_c",)


@pytest.mark.parametrize("name,q,qd,expected", [
    ("viscous_damping", 0.2, -1.5, 0.45),
    ("coulomb_friction", 0.0, 2.0, -0.45),
    ("coulomb_friction", 0.0, -2.0, 0.45),
    ("coulomb_friction", 0.3, 0.0, 0.0),
    ("stiction", 0.0, fx.V_STRIBECK, -0.2 / 0.5936154838 * math.exp(-1.0) * math.tanh(fx.V_STRIBECK / fx.V_EPS)),
    ("stiction", 0.0, 1.0, -0.2 / 0.5936154838 * math.exp(-(1.0 / fx.V_STRIBECK) ** 2)),
    ("quadratic_drag", 0.0, -2.0, 0.4),
    ("linear_stiffness", 0.1, 5.0, 0.2),
    ("cubic_stiffness", -0.2, 0.0, 0.04),
    ("com_offset", 0.0, 0.0, 20.54 * math.sin(0.03)),
    ("backlash", 0.15, 1.0, 0.0),
    ("backlash", 0.5, 1.0, -6.0 * 0.3),
    ("backlash", -0.5, 1.0, 6.0 * 0.3),
    ("rolling_resistance", 0.0, 3.0, -1.2),
    # the regularisation width is 1 mrad/s (module docstring): tanh(1) and tanh(0.5) typed by hand
    ("coulomb_friction", 0.0, 1e-3, -0.45 * 0.7615941559557649),
    ("rolling_resistance", 0.0, -0.5e-3, 1.2 * 0.46211715726000974),
])
def test_laws_at_hand_values(name, q, qd, expected):
    got = fx.torque(name, np.array([q]), np.array([qd]), PARAMS[name], CONTEXT)[0]
    assert got == pytest.approx(expected, rel=1e-9, abs=1e-12)


def test_stiction_adds_at_most_tau_s_to_kinetic_friction():
    """tau_s is the breakaway excess the law can hold (comparable with a real contact's
    F_s - F_c): the most the hump adds, reached in the creep band, not an amplitude it never
    reaches (0.59 tau_s with the former parametrisation)."""
    qd = np.linspace(-0.02, 0.02, 400001)
    extra = np.abs(fx.stiction(0.0 * qd, qd, 0.37))
    assert np.max(extra) == pytest.approx(0.37, rel=1e-8)
    assert fx.V_EPS / 4 < abs(qd[np.argmax(extra)]) < fx.V_STRIBECK
    assert np.max(extra[np.abs(qd) > 5 * fx.V_STRIBECK]) < 1e-9


def test_com_offset_shifts_the_rest_angle_by_delta():
    """Gravity -k_g sin(q) plus the com_offset law vanishes at q = delta: a shifted rest."""
    q = np.linspace(-0.2, 0.2, 40001)
    total = -CONTEXT["k_g"] * np.sin(q) + fx.com_offset(q, 0.0 * q, 0.03, CONTEXT["k_g"])
    assert q[np.argmin(np.abs(total))] == pytest.approx(0.03, abs=2e-5)


@pytest.mark.parametrize("name", ["viscous_damping", "coulomb_friction", "stiction", "quadratic_drag",
                                  "rolling_resistance"])
def test_dissipative_laws_oppose_motion(name):
    qd = np.linspace(-5, 5, 2001)
    tau = fx.torque(name, 0.0 * qd, qd, PARAMS[name], CONTEXT)
    assert np.all(tau * qd <= 1e-15)
    assert np.any(tau * qd < 0)


@pytest.mark.parametrize("name", VOCABULARY)
def test_numpy_and_drake_symbolic_give_the_same_torque(name):
    """The same function body on Drake symbolic variables (as in the augmented Drake model)."""
    q, qd = sym.Variable("q"), sym.Variable("qd")
    expr = fx.torque(name, q, qd, PARAMS[name], CONTEXT, m=SYM)
    rng = np.random.default_rng(3)
    for qv, qdv in zip(rng.uniform(-1, 1, 25), rng.uniform(-3, 3, 25)):
        want = float(fx.torque(name, np.array([qv]), np.array([qdv]), PARAMS[name], CONTEXT)[0])
        got = expr.Evaluate({q: qv, qd: qdv}) if hasattr(expr, "Evaluate") else float(expr)
        assert got == pytest.approx(want, rel=1e-12, abs=1e-12), (name, qv, qdv)


def test_added_inertia_adds_to_the_inertia_and_no_torque():
    """added_inertia is M -> M + delta_i: total_inertia sums it, total_torque leaves it out, and
    it stands for a geared joint's reflected rotor inertia in the report."""
    eff = fx.LIBRARY["added_inertia"]
    assert eff.kind == "inertia" and eff.param_names == ("delta_i",) and eff.units() == {"delta_i": "kg m^2"}
    assert eff.params[0].lo == 0.0          # harder to accelerate, never easier
    q, qd = np.array([0.3, -0.2]), np.array([1.0, -2.0])
    both = {"added_inertia": {"delta_i": 0.06}, "linear_stiffness": {"k": 2.0}}
    assert np.allclose(fx.total_torque(both, q, qd), -2.0 * q)
    assert np.allclose(fx.total_inertia(both, q, qd), 0.06)
    assert fx.total_inertia({"linear_stiffness": {"k": 2.0}}) == 0.0
    assert "rotor inertia" in eff.mechanism_for({"delta_i": 0.06}) and "N^2" in eff.mechanism_for({"delta_i": 0.06})


def test_every_effect_names_its_physical_mechanism_by_sign():
    for name, eff in fx.LIBRARY.items():
        assert eff.mechanism_for({eff.params[0].name: 1.0}), name
        assert eff.mechanism_for({eff.params[0].name: -1.0}) or not eff.params[0].signed, name
    stiff = fx.LIBRARY["linear_stiffness"]
    assert "softer" in stiff.mechanism_for({"k": -1.7}) and "softer" not in stiff.mechanism_for({"k": 1.7})


def test_total_torque_sums_effects_and_unknown_names_are_refused():
    q, qd = np.array([0.3]), np.array([-0.7])
    both = {"viscous_damping": PARAMS["viscous_damping"], "cubic_stiffness": PARAMS["cubic_stiffness"]}
    assert fx.total_torque(both, q, qd)[0] == pytest.approx(0.21 - 5.0 * 0.027)
    with pytest.raises(ValueError, match="vocabulary"):
        fx.torque("magic", q, qd, {})
    with pytest.raises(ValueError, match="k_g"):
        fx.torque("com_offset", q, qd, {"delta": 0.1})


def test_com_offset_takes_k_g_from_the_experiment_context():
    """k_g = m g d is the experiment's, not a constant: -k_g [sin(q - delta) - sin(q)] with
    k_g = 10, q = 0.1, delta = 0.05 is -10 (0.0499792 - 0.0998334) = 0.4985425 N m."""
    got = fx.torque("com_offset", np.array([0.1]), np.array([0.0]), {"delta": 0.05}, {"k_g": 10.0})[0]
    assert got == pytest.approx(0.49854247376, rel=1e-9)


def test_stiction_parameters_magnitude_from_the_former_grid_and_a_width_held_at_the_creep_band():
    """tau_s starts from the former amplitude grid (typical 0.3 N m times STICTION_PEAK: 0.178
    N m) and may reach 20 N m, rolling resistance's bound (a soft shell's breakaway from its
    flat at low pressure is several N m).  v_s, the width, defaults to the creep band, so a law
    given no width and a model that holds it are the joints' law as before."""
    tau_s, v_s = fx.LIBRARY["stiction"].params
    assert (tau_s.name, tau_s.unit, tau_s.lo, tau_s.hi, tau_s.default) == ("tau_s", "N m", 0.0, 20.0, 0.0)
    assert tau_s.typical == pytest.approx(0.17808464514, rel=1e-8)
    assert (v_s.name, v_s.unit, v_s.lo, v_s.default) == ("v_s", "rad/s", fx.V_STRIBECK, fx.V_STRIBECK)
    assert min(v_s.grid_values()) > 10 * fx.V_STRIBECK      # fitted starts are wide humps


@pytest.mark.parametrize("v_s", [fx.V_STRIBECK, 0.0025, 0.01, 0.3, 2.7, 10.0])
def test_stiction_adds_at_most_tau_s_at_any_width(v_s):
    """tau_s is the most the hump adds at every width: the law divides by its width's own peak
    (stiction_peak), found on a fine grid here."""
    qd = np.concatenate([np.geomspace(1e-7, 60.0, 2000001), -np.geomspace(1e-7, 60.0, 11)])
    tau = fx.stiction(0.0 * qd, qd, 0.37, v_s)
    assert np.max(np.abs(tau)) == pytest.approx(0.37, rel=1e-6)
    acting = tau != 0.0                     # far past the width the hump underflows to zero
    assert acting.sum() > qd.size // 4 and np.all(np.sign(tau[acting]) == -np.sign(qd[acting]))


def test_stiction_at_the_creep_band_is_the_joints_law_to_the_last_bit():
    """A model that holds the width passes V_STRIBECK: the law must be the former one exactly
    (the stand diagnoses and the blind benchmark are unchanged)."""
    qd = np.linspace(-0.02, 0.02, 4001)
    former = -(0.3 / fx.STICTION_PEAK) * np.exp(-(qd / fx.V_STRIBECK) ** 2) * np.tanh(qd / fx.V_EPS)
    assert np.array_equal(fx.stiction(0.0 * qd, qd, 0.3), former)
    assert np.array_equal(fx.stiction(0.0 * qd, qd, 0.3, np.full_like(qd, fx.V_STRIBECK)), former)


def test_a_wide_stiction_hump_fades_over_its_width():
    """At v_s = 2.7 rad/s (a soft shell rolling off its flat) the torque at rest is tau_s and at
    v_s it is tau_s / e, to the peak's normalisation (1 - 5e-6 at this width)."""
    got = fx.torque("stiction", np.zeros(3), np.array([0.05, 2.7, 8.0]), {"tau_s": 4.0, "v_s": 2.7})
    assert got == pytest.approx([-4.0 * math.exp(-(0.05 / 2.7) ** 2), -4.0 * math.exp(-1.0), -4.0 * math.exp(-(8.0 / 2.7) ** 2)],
                                rel=1e-5)
    with pytest.raises(ValueError, match="tau_s"):
        fx.torque("stiction", np.zeros(1), np.zeros(1), {"v_s": 2.7})