"""The coupled steer test scored and diagnosed in Drake (issue 27): the authors' averaging and
objective, the shared pressure, the effects per coordinate, the CLI on a native log, and the
committed Fig. S2 table's held-out claim."""
import json

import numpy as np
import pandas as pd
import pytest

from conftest import COUPLED, REPO, real_file
from roboball.cli.main import main as cli_main
from roboball.diagnose.coupled import (AUTHORS_TAU_S, Repeat, authors_average, authors_loss, fit_authors_objective,
                                       fit_pressure, read_repeats, run)
from roboball.diagnose.coupled_effects import effect_spec, fit_chosen, folds_of, screen
from roboball.sim.coupled import AUTHORS_NM, model_spec
from roboball.sim.schedule import ShellLaws

LAWS = ShellLaws(0.23, -0.0386, 2.70, 0.0276)
FRICTION = {"f_w": 0.2, "f_c": 0.45, "sigma": 10.0, "omega_c": 0.1, "n": 1.0}


def _synthetic(spec, name, duration=2.0, pipe0=-0.36, steer0=0.38, rate=50.0) -> Repeat:
    t = np.arange(0.0, duration, 1.0 / rate)
    rep = Repeat(name, t, np.zeros_like(t) + pipe0, np.zeros_like(t) + steer0)
    pred = run(spec, rep)
    return Repeat(name, t, pred["pipe_angle_rad"], pred["steer_angle_rad"])


def test_the_authors_average_is_sample_by_sample_over_the_shortest_repeat_on_the_first_names_times():
    a = Repeat("b_second", np.array([0.0, 0.02, 0.04]), np.array([1.0, 2.0, 3.0]), np.array([0.0, 0.0, 0.0]))
    b = Repeat("a_first", np.array([0.0, 0.03]), np.array([3.0, 4.0]), np.array([2.0, 2.0]))
    t, pipe, steer = authors_average([a, b])
    assert t.tolist() == [0.0, 0.03] and pipe.tolist() == [2.0, 3.0] and steer.tolist() == [1.0, 1.0]


def test_the_authors_loss_vanishes_at_the_parameters_that_made_the_data_and_weights_early_errors():
    spec = model_spec("authors_nm", None, LAWS, FRICTION)
    data = [_synthetic(spec, "r1", duration=1.5)]
    assert authors_loss(AUTHORS_NM, data, FRICTION) < 1e-8
    assert authors_loss((AUTHORS_NM[0], 5 * AUTHORS_NM[1]), data, FRICTION) > 1e-6
    assert authors_loss((-1.0, 0.4), data, FRICTION) == np.inf
    assert AUTHORS_TAU_S == 3.0


def test_nelder_mead_from_their_parameters_never_ends_above_their_loss():
    spec = model_spec("injected", 20.0, LAWS, FRICTION)
    data = [_synthetic(spec, "r1", duration=1.5)]
    fit = fit_authors_objective(data, FRICTION, max_evals=5)
    assert fit["theirs_params"] == list(AUTHORS_NM)
    assert fit["ours_loss_rad2"] <= fit["theirs_loss_rad2"]
    assert fit["ours_loss_rad2"] == pytest.approx(authors_loss(fit["ours_params"], data, FRICTION), rel=1e-9)


def test_the_shared_pressure_is_recovered_from_runs_made_at_it_with_an_interval_around_it():
    spec = model_spec("injected", 15.0, LAWS, FRICTION)
    reps = [_synthetic(spec, "r1"), _synthetic(spec, "r2", pipe0=-0.3, steer0=0.33)]
    for r in reps:           # 1 mrad of sensor noise so that the interval has a width
        r.pipe = r.pipe + 1e-3 * np.sin(37.0 * r.t)
    fit = fit_pressure(reps, LAWS, FRICTION, grid=(6.9, 11.5, 16.1, 20.7, 25.3))
    assert fit.p_kpa == pytest.approx(15.0, abs=1.0)
    assert fit.ci95_kpa[0] <= 15.0 <= fit.ci95_kpa[1]
    assert set(fit.folds) == {"r1", "r2"} and not fit.extrapolated


def test_a_centre_of_mass_shift_of_the_shell_is_found_on_the_pipe_coordinate():
    base = model_spec("injected", 20.0, LAWS, FRICTION)
    truth = effect_spec(base, {("pipe", "com_offset"): 0.06})
    reps = [_synthetic(truth, "r1", duration=3.0), _synthetic(truth, "r2", duration=3.0, pipe0=-0.3, steer0=0.33)]
    masks = {r.name: np.ones(len(r.t), bool) for r in reps}
    chosen, table = screen(base, reps, masks)
    assert ("pipe", "com_offset") in chosen
    assert table["pipe.com_offset"]["step"][0] == pytest.approx(0.06, rel=0.3)


def test_an_effect_the_data_cannot_tell_from_zero_is_dropped_and_the_rest_refitted():
    base = model_spec("injected", 20.0, LAWS, FRICTION)
    truth = effect_spec(base, {("pipe", "com_offset"): 0.06})
    reps = [_synthetic(truth, "r1", duration=3.0), _synthetic(truth, "r2", duration=3.0, pipe0=-0.3, steer0=0.33)]
    masks = {r.name: np.ones(len(r.t), bool) for r in reps}
    kept, fit, dropped = fit_chosen(base, [("pipe", "com_offset"), ("steer", "viscous_damping")], reps, masks)
    assert kept == [("pipe", "com_offset")] and dropped == [("steer", "viscous_damping")]
    assert fit.values[("pipe", "com_offset")] == pytest.approx(0.06, abs=0.01)


def test_one_recording_is_held_out_by_its_last_third():
    r = Repeat("one", np.linspace(0.0, 3.0, 31), np.zeros(31), np.zeros(31))
    (fold,) = folds_of([r])
    assert fold.train["one"].sum() == 21 and fold.test["one"].sum() == 10
    assert not (fold.train["one"] & fold.test["one"]).any()


def test_read_repeats_refuses_a_log_without_the_steer_angle_in_one_line(tmp_path):
    from roboball.errors import RoboballError
    path = tmp_path / "pipe_only.csv"
    path.write_text("time_s,pipe_angle_rad\n0,-0.3\n0.02,-0.29\n")
    (tmp_path / "pipe_only.json").write_text('{"kind": "shell_rock", "pressure_kpa": 10}')
    with pytest.raises(RoboballError) as info:
        read_repeats([path])
    assert "\n" not in str(info.value) and str(path) in str(info.value)


def _verdict_case(rmse_base, rmse_after, effects, noise_amp, rho_kind):
    """Two coordinates of one repeat, a baseline whose residual is smooth (rho_kind 'smooth') or
    white ('white'), and a fit summary as `fit_chosen` returns it."""
    from types import SimpleNamespace
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 3.0, 0.02)
    pipe = 0.3 * np.cos(3 * t) + noise_amp * rng.standard_normal(t.size)
    steer = 0.3 * np.sin(3 * t) + noise_amp * rng.standard_normal(t.size)
    rep = Repeat("r", t, pipe, steer)
    err = rmse_base * (np.sin(0.7 * t) * np.sqrt(2) if rho_kind == "smooth" else rng.standard_normal(t.size))
    pred = {"r": {"pipe_angle_rad": pipe + err, "steer_angle_rad": steer + err}}
    fit = SimpleNamespace(values=effects, rmse_train=rmse_after, rmse_base_train=rmse_base)
    return fit, pred, [rep], {"r": np.ones(t.size, bool)}


@pytest.mark.parametrize("rmse_after,effects,expected", [
    (0.009, {("pipe", "com_offset"): 0.1}, "augmented"),      # a tenth of the baseline's 0.1 rad
    (0.075, {("pipe", "com_offset"): 0.1}, "unexplained"),    # the real 165825 log: 0.107 -> 0.075
    (0.1, {}, "unexplained"),                                   # nothing found, a smooth residual remains
])
def test_the_coupled_verdict_follows_the_rule_of_the_other_kinds(rmse_after, effects, expected):
    from roboball.diagnose.coupled_report import recorded_noise, verdict
    fit, pred, reps, masks = _verdict_case(0.1, rmse_after, effects, 1e-3, "smooth")
    noise = recorded_noise(reps, masks)
    assert 0.5e-3 < noise < 2e-3
    assert verdict(fit, pred, reps, masks, noise) == expected


def test_a_coupled_baseline_with_a_white_residual_at_the_noise_is_adequate():
    from roboball.diagnose.coupled_report import recorded_noise, verdict
    fit, pred, reps, masks = _verdict_case(2e-3, 2e-3, {}, 1e-3, "white")
    assert verdict(fit, pred, reps, masks, recorded_noise(reps, masks)) == "adequate"


# ---- the real repeats ------------------------------------------------------------------------
def test_diagnose_runs_on_the_native_coupled_log_and_reports_both_coordinates(tmp_path, capsys):
    """Acceptance 4: `roboball diagnose --kind steer_coupled` on the authors' native file."""
    path = real_file(COUPLED[0])
    for f in ("results/identify/shell_regression.csv", "results/friction/real/steer_majd.json"):
        if not (REPO / f).is_file():
            pytest.skip(f"{f} not produced yet (run the pipeline)")
    out = tmp_path / "d"
    code = cli_main(["diagnose", str(path), "--kind", "steer_coupled", "--out", str(out),
                     "--regression", str(REPO / "results/identify/shell_regression.csv"),
                     "--friction-steer", str(REPO / "results/friction/real/steer_majd.json")])
    assert code == 0
    js = json.loads((out / "diagnosis.json").read_text())
    assert js["kind"] == "steer_coupled" and js["verdict"] in ("adequate", "augmented", "unexplained")
    pc = js["fit"]["per_coordinate"]
    assert set(pc["heldout_before"]) == set(pc["heldout_after"]) == {"pipe_angle_rad", "steer_angle_rad"}
    assert {loc["signal"] for loc in js["located"]} == {"pipe_angle_rad", "steer_angle_rad"}
    assert sum(loc["share_of_residual"] for loc in js["located"]) == pytest.approx(1.0)
    from roboball.physics.effects import VOCABULARY
    for m in js["missing_physics"]:
        assert m["effect"] in VOCABULARY and m["dof"] in ("pipe", "steer")
        (p, v), = m["parameters"].items()
        assert m["ci95"][p][0] <= v <= m["ci95"][p][1]
    assert js["fit"]["rmse_after"] <= js["fit"]["rmse_before"]
    for f in ("report.md", "overlay.png", "predictions.csv"):
        assert (out / f).is_file()
    from roboball.diagnose.coupled_report import OUTPUT_FILES  # what the command checks before any work
    assert {p.name for p in out.iterdir()} <= set(OUTPUT_FILES)


def test_their_published_parameters_lose_to_our_fit_of_their_objective_on_the_real_repeats():
    """Acceptance 2 with a budget of 6 Drake runs: our loss is at or below theirs."""
    reps = read_repeats([real_file(name) for name in COUPLED])
    fit = fit_authors_objective(reps, FRICTION, max_evals=6)
    assert fit["ours_loss_rad2"] <= fit["theirs_loss_rad2"]


def test_the_committed_table_has_the_diagnosed_model_beat_every_paper_model_on_every_held_out_repeat():
    """Acceptance 3 as regenerated by make figures (paper_figures/table_coupled_rms_real.csv)."""
    table = pd.read_csv(REPO / "paper_figures" / "table_coupled_rms_real.csv")
    paper = ["point", "injected", "hydroelastic", "hydro_half", "authors_nm", "authors_hand"]
    # the calibrated hydroelastic shell (Fig. S3) runs when the calibration exists: beaten too
    assert set(paper) | {"diagnosed", "ours_nm"} <= set(table.model) <= set(paper) | {"diagnosed", "ours_nm", "hydro_tuned"}
    paper += ["hydro_tuned"]
    assert table[table.model == "diagnosed"].held_out.all()
    for rep, d in table.groupby("repeat"):
        diag = d[d.model == "diagnosed"].iloc[0]
        for c in ("rms_pipe_angle_rad", "rms_steer_angle_rad"):
            assert (diag[c] < d[d.model.isin(paper)][c]).all(), (rep, c)


def test_the_coupled_table_says_what_each_model_key_stands_for():
    """`hydroelastic` means eq. 10/11 here and the x0.5 variant in the PME table: each table says."""
    from roboball.pipeline.coupled import table_markdown
    table = pd.DataFrame([{"model": m, "repeat": "r", "held_out": True, "pressure_kpa": 8.0,
                           "rms_pipe_angle_rad": 0.1, "rms_steer_angle_rad": 0.1}
                          for m in ("hydroelastic", "hydro_half", "hydro_tuned", "diagnosed")])
    summary = {"pressure": {"p_kpa": 8.0, "ci95_kpa": [7.0, 9.0], "folds": {"r": 8.0}},
               "authors_objective": {"theirs_loss_rad2": 0.2, "theirs_params": [1.5e5, 0.4], "ours_loss_rad2": 0.1,
                                     "ours_params": [6e5, 0.05], "evaluations": 30}}
    md = table_markdown(table, summary)
    assert "`hydroelastic`: hydroelastic (eq. 10/11)" in md
    assert "`hydro_half`: hydroelastic, x0.5 dissipation (paper's tuned)" in md
    assert "`hydro_tuned`: hydroelastic, calibrated (Fig. S3)" in md
    assert "`diagnosed`: diagnosed (held out)" in md


# ---- a logged pressure -----------------------------------------------------------------------
def _logged(path, p_kpa, duration=3.0):
    """A coupled recording of the injected model at `p_kpa`, its pressure in the sidecar (or none)."""
    from roboball.ingest.recording import write_recording
    rep = _synthetic(model_spec("injected", 10.3, LAWS, FRICTION), path.stem, duration=duration)
    rec = pd.DataFrame({"time_s": rep.t, "pipe_angle_rad": rep.pipe, "steer_angle_rad": rep.steer})
    write_recording(path, rec, {"kind": "steer_coupled", "pressure_kpa": p_kpa})
    return str(path)


def test_the_logged_pressure_of_coupled_repeats_is_shared_or_refused_in_one_line(tmp_path):
    from roboball.diagnose.coupled import logged_pressure_of
    from roboball.errors import RoboballError
    a, b = _logged(tmp_path / "a.csv", 10.3, 1.0), _logged(tmp_path / "b.csv", 10.3, 1.0)
    none, other = _logged(tmp_path / "n.csv", None, 1.0), _logged(tmp_path / "o.csv", 13.8, 1.0)
    assert logged_pressure_of([a, b]) == 10.3 and logged_pressure_of([none]) is None
    assert logged_pressure_of([none, a], pressure_kpa=6.9) == 6.9          # the flag speaks for all
    for paths, bad in (([a, other], other), ([a, none], none)):
        with pytest.raises(RoboballError) as info:
            logged_pressure_of(paths)
        assert str(info.value).startswith(f"{bad}: pressure ") and "share their pressure" in str(info.value)
        assert "\n" not in str(info.value)


def test_diagnose_takes_a_coupled_recordings_logged_pressure_instead_of_fitting_one(tmp_path):
    """The contract's steer_coupled baseline fits the release states only: a pressure the sidecar
    logs is the baseline's, and the injected model that made the run at it needs nothing added."""
    path = _logged(tmp_path / "run.csv", 10.3)
    reg, fric = tmp_path / "reg.csv", tmp_path / "steer.json"
    reg.write_text(f"name,value\nzeta_a,{LAWS.zeta_a}\nzeta_b,{LAWS.zeta_b}\nomega_n_c,{LAWS.omega_n_c}\n"
                   f"omega_n_d,{LAWS.omega_n_d}\n")
    fric.write_text(json.dumps(FRICTION))
    out = tmp_path / "d"
    assert cli_main(["diagnose", path, "--out", str(out), "--regression", str(reg), "--friction-steer", str(fric)]) == 0
    js = json.loads((out / "diagnosis.json").read_text())
    assert js["baseline"]["pressure_kpa"] == 10.3 and js["baseline"]["fitted"] == {}
    assert "at the logged pressure" in js["baseline"]["description"]
    assert js["fit"]["rmse_before"] < 1e-3
    assert "Logged pressure 10.3 kPa (not fitted)." in (out / "report.md").read_text()


def test_effects_that_make_a_held_out_coordinate_worse_are_reported_not_confirmed():
    """The real second repeat alone: its effects fit the first two thirds (0.100 -> 0.010 rad) and
    predict the last third worse (pipe 0.0796 -> 0.0861, steer 0.0750 -> 0.0984): the report, the
    JSON and the command's line say so; a coordinate predicted better raises nothing."""
    from roboball.diagnose.coupled_report import heldout_warning, report_md
    pc = {"before": {"pipe_angle_rad": 0.107, "steer_angle_rad": 0.093},
          "after": {"pipe_angle_rad": 0.0099, "steer_angle_rad": 0.0109},
          "heldout_before": {"pipe_angle_rad": 0.0796, "steer_angle_rad": 0.0750},
          "heldout_after": {"pipe_angle_rad": 0.0861, "steer_angle_rad": 0.0740}}
    w = heldout_warning(pc, effects=True, one_recording=True)
    assert "pipe_angle_rad worse than the baseline (0.0796 -> 0.0861 rad)" in w and "steer_angle_rad" not in w
    assert "last third" in w
    assert "left out in turn" in heldout_warning(pc, effects=True, one_recording=False)
    assert heldout_warning(pc, effects=False, one_recording=True) is None     # nothing added, nothing to confirm
    better = dict(pc, heldout_after={"pipe_angle_rad": 0.05, "steer_angle_rad": 0.06})
    assert heldout_warning(better, effects=True, one_recording=True) is None
    js = {"verdict": "unexplained", "baseline": {"description": "b", "fitted": {}, "pressure_kpa": 10.3},
          "fit": {"per_coordinate": pc}, "noise_rad": 0.0016, "located_augmented": [], "dropped": [],
          "missing_physics": [{"effect": "com_offset", "dof": "pipe", "parameters": {"delta": 0.11},
                               "ci95": {"delta": [0.1, 0.12]}, "units": {"delta": "rad"}, "explains": "e",
                               "mechanism": "m"}],
          "heldout_folds": [], "notes": [], "heldout_warning": w}
    assert "**Not confirmed held out:** The augmented model predicts pipe_angle_rad worse" in report_md(js)
    assert "Not confirmed" not in report_md(dict(js, heldout_warning=None))


def test_the_drake_refit_stops_once_it_has_converged_on_a_rough_cost(monkeypatch):
    """Drake's discrete steps make the refit's cost rough at its finest scales; SciPy's default
    tolerances then spent the rest of the budget on parameter changes in the 4th-5th digit. Here a
    damped swing stands in for Drake, with a roughness of 1e-5 rad: the fit must stop well inside
    its budget, at the truth."""
    from roboball.diagnose import coupled_effects as ce
    t = np.linspace(0.0, 4.0, 201)
    truth = {("pipe", "linear_stiffness"): 60.0, ("pipe", "viscous_damping"): 4.0}

    def swing(values):
        k = values.get(("pipe", "linear_stiffness"), 0.0)
        c = values.get(("pipe", "viscous_damping"), 0.0)
        y = 0.3 * np.exp(-c * t / 8.0) * np.cos(np.sqrt(10.0 + k / 4.0) * t)
        return y + 1e-5 * np.sin(1e7 * (k + c))          # Drake's rough last digits

    rng = np.random.default_rng(2)
    rep = Repeat("r", t, swing(truth) + rng.normal(0.0, 1e-3, t.size), np.zeros(t.size))
    calls = []
    monkeypatch.setattr(ce, "effect_spec", lambda base, chosen: dict(chosen))

    def predict_all(spec, reps, names=None):
        calls.append(spec)
        return {r.name: {"pipe_angle_rad": swing(spec), "steer_angle_rad": np.zeros(t.size)} for r in reps}

    monkeypatch.setattr(ce, "predict_all", predict_all)
    start = {k: 0.7 * v for k, v in truth.items()}
    fit = ce.refit({}, list(truth), [rep], {"r": np.ones(t.size, bool)}, start=start, max_nfev=40)
    for k, v in truth.items():
        assert fit.values[k] == pytest.approx(v, rel=0.01)
    assert len(calls) <= 25, len(calls)     # Drake runs, Jacobians' included (SciPy's defaults: 30)
