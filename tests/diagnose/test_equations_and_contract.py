"""The reduced models' equations of motion and the diagnosis.json / report.md writer, checked
against hand-computed values and the contract (shared/specs/diagnosis.md) without running a
diagnosis: fast, and each assertion pins one term or one field."""
import math
from types import SimpleNamespace

import numpy as np
import pytest

from roboball.reduced.compiled import sample_outputs
from roboball.reduced.models import model_for
from roboball.reduced.stand import StandModel
from roboball.diagnose.contract import RAMP_EXPLAINS, baseline_fitted, diagnosis_json
from roboball.diagnose.markdown import _heldout_note, _param_cells
from roboball.physics import effects as fx


# ---- reduced models -------------------------------------------------------------------------
@pytest.mark.parametrize("kind, dof, signal", [("steer_stand", "steer", "steer_angle_rad"),
                                               ("drive_stand", "drive", "drive_angle_rad")])
def test_stand_models_name_their_own_joint(kind, dof, signal):
    model = model_for(kind)
    assert (model.dof, model.signal) == (dof, signal)


def test_undamped_stand_pendulum_conserves_its_energy():
    # I qdd = -k_g sin q  =>  E = I v^2 / 2 + k_g (1 - cos q) is constant (q from rest)
    model = StandModel("steer_stand")
    q0 = model.rest + 1.0
    Y, V = model.simulate(np.array([q0]), {"viscous_c": np.array([0.0])}, 2000)
    q = Y[:, 0] - model.rest
    E = 0.5 * model.inertia * V[:, 0] ** 2 + model.k_g * (1.0 - np.cos(q))
    E0 = model.k_g * (1.0 - math.cos(1.0))
    assert np.max(np.abs(E - E0)) < 1e-3 * E0


def test_damped_stand_pendulum_loses_energy_at_the_viscous_rate():
    # dE/dt = -c v^2: the energy lost up to time t is c * integral(v^2)
    model = StandModel("drive_stand")
    c = 0.05
    dt = 1e-3
    Y, V = model.simulate(np.array([model.rest + 0.5]), {"viscous_c": np.array([c])}, 3000, dt)
    q, v = Y[:, 0] - model.rest, V[:, 0]
    E = 0.5 * model.inertia * v ** 2 + model.k_g * (1.0 - np.cos(q))
    lost = c * np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] ** 2 + v[:-1] ** 2) * dt)])
    assert E[-1] < 0.9 * E[0]
    np.testing.assert_allclose(E + lost, E[0], rtol=2e-3)


def test_shell_rolling_without_slipping_conserves_lagrangian_energy():
    # M(q) qdd + m R d sin(q) qd^2 + k_g sin q = 0 with M = I_c + m (R^2 + d^2 - 2 R d cos q)
    # conserves E = M(q) qd^2 / 2 + k_g (1 - cos q); a wrong sign of the qd^2 term does not.
    model = model_for("shell_rock")
    m, R, d = model.mass, model.radius, model.d
    Y, V = model.simulate(np.array([model.rest + 1.2]), {}, 2000)
    q, v = Y[:, 0] - model.rest, V[:, 0]
    M = model.i_com + m * (R * R + d * d - 2 * R * d * np.cos(q))
    E = 0.5 * M * v ** 2 + model.k_g * (1.0 - np.cos(q))
    E0 = model.k_g * (1.0 - math.cos(1.2))
    assert np.max(np.abs(E - E0)) < 1e-3 * E0


def test_backlash_uses_each_of_its_two_parameters():
    # outside the free play b the stiffness k_b engages: -k_b (q - b) for q > b, 0 inside it
    model = StandModel("steer_stand")
    P = {"backlash.k_b": np.array([2.0, 2.0]), "backlash.b": np.array([0.1, 0.1])}
    tau = model.effect_torque(np.array([0.3, 0.05]), np.array([0.0, 0.0]), P, ["backlash"])
    np.testing.assert_allclose(tau, [-0.4, 0.0], atol=1e-12)


def test_com_offset_uses_the_experiments_gravity_term_and_only_active_rows():
    model = StandModel("steer_stand")
    delta = 0.02
    P = {"com_offset.delta": np.array([0.0, delta, 0.0])}
    q = np.array([0.3, 0.3, 0.3])
    tau = model.effect_torque(q, np.zeros(3), P, ["com_offset"])
    expected = -model.k_g * (math.sin(0.3 - delta) - math.sin(0.3))
    np.testing.assert_allclose(tau, [0.0, expected, 0.0], atol=1e-12)


def test_hermite_interpolation_is_exact_for_a_cubic():
    dt = 0.01
    t = np.arange(51) * dt
    Y = (t ** 3 - 2 * t)[:, None]
    Yd = (3 * t ** 2 - 2)[:, None]
    tau = np.array([[0.0123, 0.2057, 0.4444]])
    got, _ = sample_outputs(Y, Yd, dt, tau, np.array([0]))
    np.testing.assert_allclose(got, tau ** 3 - 2 * tau, atol=1e-12)


# ---- diagnosis.json / report.md -------------------------------------------------------------
def _diagnosis(kind="steer_stand", unit="rad", chosen=("coulomb_friction", "viscous_damping"), verdict="augmented"):
    """A finished diagnosis as the writer sees it (two effects kept in two rounds)."""
    windows = [SimpleNamespace(index=0, t0=1.5), SimpleNamespace(index=1, t0=20.0)]
    base_values = {"viscous_c": 0.2, "q0@0": 0.7, "ts@0": 0.01, "q0@1": -0.6, "ts@1": -0.02}
    final_values = {"viscous_c": 0.05, "q0@0": 0.71, "ts@0": 0.015, "q0@1": -0.61, "ts@1": -0.01,
                    "coulomb_friction.tau_c": 0.48, "viscous_damping.c": 0.03}
    steps = [[{"effect": "coulomb_friction", "delta_bic": -812.0, "kept": True},
              {"effect": "stiction", "delta_bic": -300.0, "kept": False}],
             [{"effect": "viscous_damping", "delta_bic": -40.0, "kept": True}]]
    # the BIC the final model loses without each effect, and an equivalent explanation of one
    drop_bic = {"coulomb_friction": -812.0, "viscous_damping": -40.0}
    alternatives = {"viscous_damping": [{"effect": "quadratic_drag", "parameters": {"c2": 0.02},
                                         "ci95": {"c2": (0.01, 0.03)}, "rmse_heldout": 0.0145,
                                         "rmse": 0.0125, "delta_bic": -38.0}]}
    return SimpleNamespace(
        prep=SimpleNamespace(kind=kind, unit=unit, windows=windows),
        model=SimpleNamespace(dof="steer", description="rigid pendulum",
                              base_params=(SimpleNamespace(name="viscous_c"),), hidden_release=()),
        baseline=SimpleNamespace(values=base_values, rmse=0.084, cv_rmse=0.091),
        final=SimpleNamespace(values=final_values, rmse=0.012, cv_rmse=0.014, delta_bic=-852.0),
        chosen=list(chosen), steps=steps, verdict=verdict,
        ci95={"coulomb_friction.tau_c": (0.45, 0.51), "viscous_damping.c": (0.02, 0.04)},
        drop_bic=drop_bic, alternatives=alternatives if "viscous_damping" in chosen else {})


def _located():
    return SimpleNamespace(windows=[{"start_s": 12.1, "end_s": 14.9, "signal": "steer_angle_rad",
                                     "regime": "low_speed", "share_of_residual": 0.623456}])


def test_fit_gives_fitted_and_heldout_rms_before_and_after_in_the_signals_units():
    js = diagnosis_json(_diagnosis(kind="ramp", unit="rad/s"), _located())
    assert js["fit"] == {"rmse_before": 0.084, "rmse_after": 0.012, "rmse_heldout_before": 0.091,
                         "rmse_heldout_after": 0.014, "units": "rad/s"}


def test_each_effect_has_the_delta_bic_of_leaving_it_out_and_its_95_interval():
    js = diagnosis_json(_diagnosis(), _located())
    mp = {m["effect"]: m for m in js["missing_physics"]}
    assert [m["effect"] for m in js["missing_physics"]] == ["coulomb_friction", "viscous_damping"]
    assert mp["coulomb_friction"]["delta_bic"] == -812.0 and mp["viscous_damping"]["delta_bic"] == -40.0
    assert mp["coulomb_friction"]["parameters"] == {"tau_c": 0.48}
    assert mp["coulomb_friction"]["ci95"] == {"tau_c": [0.45, 0.51]}
    assert mp["viscous_damping"]["ci95"] == {"c": [0.02, 0.04]}
    assert all(m["dof"] == "steer" for m in js["missing_physics"])
    assert js["located"][0]["share_of_residual"] == 0.6235


def test_equivalent_explanations_are_listed_with_parameters_heldout_rms_and_mechanism():
    """The contract's `alternatives`: another effect that explains the same residual about as well,
    with its parameters, 95% intervals and held-out RMS; each entry and alternative names the
    physical mechanism it stands for."""
    js = diagnosis_json(_diagnosis(), _located())
    mp = {m["effect"]: m for m in js["missing_physics"]}
    assert "alternatives" not in mp["coulomb_friction"]
    (alt,) = mp["viscous_damping"]["alternatives"]
    assert alt == {"effect": "quadratic_drag", "parameters": {"c2": 0.02}, "ci95": {"c2": [0.01, 0.03]},
                   "rmse_heldout": 0.0145, "delta_bic": -38.0,
                   "mechanism": fx.LIBRARY["quadratic_drag"].mechanism_for({"c2": 0.02})}
    assert mp["coulomb_friction"]["mechanism"].startswith("dry (Coulomb) friction")
    assert "speed" in mp["viscous_damping"]["mechanism"] and "square of speed" in alt["mechanism"]


def test_signatures_read_as_the_ramps_on_the_ramp_and_as_the_librarys_elsewhere():
    stand = diagnosis_json(_diagnosis(), _located())["missing_physics"]
    ramp = diagnosis_json(_diagnosis(kind="ramp", unit="rad/s"), _located())["missing_physics"]
    assert stand[1]["explains"] == fx.LIBRARY["viscous_damping"].explains
    assert ramp[1]["explains"] == RAMP_EXPLAINS["viscous_damping"]
    assert ramp[0]["explains"] == fx.LIBRARY["coulomb_friction"].explains     # no ramp reading of its own


def test_verdict_is_passed_through_even_when_effects_were_kept():
    # "unexplained" with effects: they help, but a structured residual remains
    js = diagnosis_json(_diagnosis(verdict="unexplained"), _located())
    assert js["verdict"] == "unexplained" and len(js["missing_physics"]) == 2
    js = diagnosis_json(_diagnosis(chosen=(), verdict="adequate"), _located())
    assert js["verdict"] == "adequate" and js["missing_physics"] == []
    assert "refitted_with_effects" not in js["baseline"]


def test_release_states_are_numbered_from_one_and_include_the_fitted_time_shift():
    d = _diagnosis()
    assert baseline_fitted(d) == {"viscous_c": 0.2, "release_1_rad": 0.7, "release_1_s": 1.51,
                                  "release_2_rad": -0.6, "release_2_s": 19.98}
    js = diagnosis_json(d, _located())
    assert js["baseline"]["fitted"] == baseline_fitted(d)
    assert js["baseline"]["refitted_with_effects"] == {"viscous_c": 0.05, "release_1_rad": 0.71,
                                                       "release_1_s": 1.515, "release_2_rad": -0.61,
                                                       "release_2_s": 19.99}
    # a rate signal (the ramp) has no release angle
    assert set(baseline_fitted(_diagnosis(kind="ramp", unit="rad/s"))) == {"viscous_c", "release_1_s", "release_2_s"}


def test_report_parameter_cells_give_value_unit_and_both_interval_bounds():
    assert _param_cells("coulomb_friction", "tau_c", 0.48, [0.45, 0.51]) == ("tau_c = 0.48 N m", "[0.45, 0.51]")
    assert _param_cells("backlash", "b", 0.0123, [0.01, None]) == ("b = 0.0123 rad", "[0.01, -]")


def test_heldout_note_says_what_was_refitted_on_the_held_out_release():
    """The report's held-out sentence follows the model: a release state refitted on the held-out
    release (stands, shell), none at all (the ramp starts at its detected release), or time blocks."""
    def d(kind, base_params=()):
        model = model_for(kind, **({"ramp_angle_deg": 16.0} if kind == "ramp" else {}))
        return SimpleNamespace(model=SimpleNamespace(release_params=model.release_params, base_params=base_params),
                               settings=SimpleNamespace(n_blocks=3))
    stand = _heldout_note(d("steer_stand", ("viscous_c",)), 3)
    assert "then only the held-out release's state fitted" in stand and "baseline fits no" not in stand
    shell = _heldout_note(d("shell_rock"), 3)
    assert "besides the release states" in shell
    ramp = _heldout_note(d("ramp"), 2)
    assert "predicts the held-out one from its detected release" in ramp and "no parameter at all" in ramp
    assert "3 contiguous time blocks" in _heldout_note(d("ramp"), 1)
    assert model_for("ramp", ramp_angle_deg=16.0).release_params == ()


def test_a_profiled_breakaway_gets_the_note_that_reads_its_profile():
    """report.md says where a joint's breakaway's interval comes from (its profile,
    roboball.diagnose.profile), whether the data bound it from above, and a held fit lower than the
    estimate; a diagnosis without a profile (a rolling shell's wide breakaway, other effects) gets no note."""
    from roboball.diagnose.markdown import _missing

    def js(effects):
        return {"missing_physics": [{"effect": e, "dof": "steer", "parameters": p, "ci95": {k: [v, v] for k, v in p.items()},
                                     "delta_bic": -50.0, "explains": "", "mechanism": ""} for e, p in effects]}

    coulomb = ("coulomb_friction", {"tau_c": 0.31})
    stiction = js([coulomb, ("stiction", {"tau_s": 0.5, "v_s": fx.V_STRIBECK})])
    prof = {"values": [0.0178, 0.25, 20.0], "interval": [0.31, 20.0], "q": 3.84, "to_bound": True,
            "lowest": {"value": 13.3, "rmse": 0.0231}, "lr_estimate": 0.36, "lr_zero": 3.92}
    text = "\n".join(_missing(stiction, {"stiction.tau_s": prof}))
    assert "profile likelihood" in text and "[0.31, 20] N m, up to the law's bound" in text
    assert "Held at 13.3 N m the model fits lower" in text and "likelihood ratio to it 0.36" in text
    assert "Without it (zero) the likelihood ratio is 3.92" in text and "borderline" in text
    bounded = "\n".join(_missing(stiction, {"stiction.tau_s": dict(prof, interval=[0.31, 0.9], to_bound=False,
                                                                   lowest=None, lr_zero=1000.0)}))
    assert "likelihood ratio is 1000." in bounded and "borderline" not in bounded
    assert "[0.31, 0.9] N m." in bounded and "bound" not in bounded.split("[0.31, 0.9]")[1].split(".")[0]
    assert "fits lower" not in bounded
    assert "profile" not in "\n".join(_missing(js([coulomb, ("stiction", {"tau_s": 4.0, "v_s": 2.9})]), {}))
    assert "profile" not in "\n".join(_missing(js([coulomb, ("quadratic_drag", {"c2": 0.06})])))
