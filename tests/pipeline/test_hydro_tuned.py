"""The tuned hydroelastic contact model's parameters at a pressure (roboball.pipeline.simulation):
the calibration's values at its pressures, log-interpolated between them, refused outside, and
handed to Drake as hydroelastic contact with that modulus and dissipation."""
import math

import pandas as pd
import pytest

from roboball.errors import RoboballError
from roboball.pipeline.simulation import shell_params, tuned_at


@pytest.fixture
def files(tmp_path):
    fit = tmp_path / "hydro_tuned.csv"
    pd.DataFrame({"pressure_kpa": [13.8, 6.9], "hydro_modulus_pa": [1.0e4, 4.0e4],
                  "hydro_dissipation_s_m": [0.4, 0.9]}).to_csv(fit, index=False)
    reg = tmp_path / "shell_regression.csv"
    pd.DataFrame({"name": ["zeta_a", "zeta_b", "omega_n_c", "omega_n_d"],
                  "value": [0.23, -0.0386, 2.70, 0.0276]}).to_csv(reg, index=False)
    return str(fit), str(reg)


def test_tuned_values_at_and_between_the_calibrated_pressures(files):
    fit, _ = files
    assert tuned_at(fit, 6.9) == pytest.approx((4.0e4, 0.9))
    m, d = tuned_at(fit, 10.35)                       # halfway: the geometric mean
    assert m == pytest.approx(2.0e4) and d == pytest.approx(math.sqrt(0.4 * 0.9))
    with pytest.raises(RoboballError, match="outside the calibrated"):
        tuned_at(fit, 20.7)
    with pytest.raises(RoboballError, match="needs the hydroelastic calibration"):
        tuned_at("", 13.8)


def test_hydro_tuned_is_drakes_hydroelastic_contact_with_the_calibrated_values(files):
    fit, reg = files
    contact, sp = shell_params("hydro_tuned", 13.8, reg, fit)
    assert contact == "hydroelastic"
    assert (sp.hydro_modulus, sp.hydro_dissipation) == pytest.approx((1.0e4, 0.4))
    contact, sp = shell_params("hydroelastic", 13.8, reg, fit, dissipation_scale=0.5)
    assert contact == "hydroelastic" and sp.hydro_modulus is None and sp.dissipation_scale == 0.5


def test_the_coupled_test_runs_the_calibrated_shell_only_inside_its_calibrated_pressures(files):
    """Fig. S2: the repeats' pressure is fitted and may lie beyond the shell releases'; the
    calibrated hydroelastic shell is then left out, and the table says why."""
    from types import SimpleNamespace

    from roboball.diagnose.coupled import PressureFit
    from roboball.pipeline.coupled import calibrated_shell, table_markdown
    fit, _ = files
    reps = [SimpleNamespace(name="a"), SimpleNamespace(name="b")]
    laws = SimpleNamespace(pressure_free=False)
    inside = PressureFit(10.0, (9.0, 11.0), (), [], {"a": 9.5, "b": 12.0})
    extra, left_out = calibrated_shell(fit, reps, inside, laws)
    assert [m.name for m in extra] == ["hydro_tuned"] and left_out == {}
    assert extra[0].shell(9.5, None)[1].hydro_modulus == pytest.approx(tuned_at(fit, 9.5)[0])
    beyond = PressureFit(12.0, (11.0, 15.0), (), [], {"a": 12.0, "b": 14.2})
    extra, left_out = calibrated_shell(fit, reps, beyond, laws)
    assert extra == () and left_out == {"hydro_tuned": "the repeats' fitted pressures 14.2 kPa lie outside its "
                                                       "calibrated 6.9-13.8 kPa"}
    assert calibrated_shell("", reps, inside, laws) == ((), {})
    table = pd.DataFrame([{"model": "injected", "repeat": "a", "held_out": True, "pressure_kpa": 12.0,
                           "rms_pipe_angle_rad": 0.1, "rms_steer_angle_rad": 0.1}])
    summary = {"pressure": {"p_kpa": 12.0, "ci95_kpa": [11.0, 15.0], "folds": {"a": 12.0}, "extrapolated": True},
               "authors_objective": {"theirs_loss_rad2": 0.2, "theirs_params": [1.5e5, 0.4], "ours_loss_rad2": 0.1,
                                     "ours_params": [6e5, 0.05], "evaluations": 30}, "left_out": left_out}
    md = table_markdown(table, summary)
    assert "(beyond the shell releases' pressures: the shell laws extrapolated)." in md
    assert "Not run: `hydro_tuned`, the repeats' fitted pressures 14.2 kPa lie outside its calibrated 6.9-13.8 kPa." in md


def test_fig_s2_names_a_model_it_could_not_run_under_its_title(tmp_path, monkeypatch):
    """A model the coupled stage left out is said in the figure too, not only in the table."""
    import roboball.figures.style as style
    from roboball.figures.coupled import plot
    seen = {}
    monkeypatch.setattr(style, "save", lambda fig, out: seen.update(title=fig.texts[-1].get_text()))
    traces = pd.DataFrame([{"model": m, "repeat": "rep_1", "time_s": t, "pipe_angle_rad": 0.1 * t,
                            "steer_angle_rad": -0.1 * t} for m in ("recording", "injected") for t in (0.0, 0.5, 1.0)])
    plot(traces, pd.DataFrame(), str(tmp_path / "s2.png"), left_out={"hydro_tuned": "fitted pressures outside it"})
    assert seen["title"].endswith("\nnot run: hydroelastic, calibrated (Fig. S3): fitted pressures outside it")
    plot(traces, pd.DataFrame(), str(tmp_path / "s2.png"))
    assert seen["title"].startswith("Fig. S2") and "not run" not in seen["title"]
