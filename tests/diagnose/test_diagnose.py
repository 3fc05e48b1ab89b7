"""`roboball diagnose` finds planted physics, leaves a matching recording alone, names
the dry friction of the real steer stand, writes the contract's files, and refuses bad input.

Test recordings come from the virtual test bed (its own LuGre dry friction with true sticking,
finer time step, sensor noise, quantisation and hand phases), which the diagnosis never sees."""
import json
from pathlib import Path

import numpy as np
import pytest

from roboball.cli.main import main as cli_main
from roboball.diagnose import diagnose
from roboball.diagnose.scored import Settings

from conftest import REPO
BAD = REPO / "tests" / "bad_recordings"
# The real logs sit in ../shared beside the repository (in CI as here), never inside it.
from conftest import REAL_DATA  # noqa: E402
REAL_STEER = REAL_DATA / "steering_static_stand_response.csv"
FAST = Settings(max_effects=2)


def _stand_recording(folder: Path, effects: dict, viscous_c: float, releases=(-0.8, 0.6), free_s=6.0, seed=1):
    from roboball.ingest.recording import write_recording
    from roboball.testbed.campaign import _rest_angle, release_recording
    from roboball.testbed.effects import conceal
    from roboball.testbed.physics import load_truth, true_robot
    from roboball.testbed.sensors import measure

    truth = load_truth()
    rng = np.random.default_rng(seed)
    terms, systems, robot = conceal("steer_stand", effects, true_robot(truth, perturbed=False))
    rest = _rest_angle("steer_stand", robot)
    dense = release_recording("steer_stand", None, [rest + a for a in releases], free_s, truth, rng, extras=(),
                              extra_terms=terms, extra_systems=systems,
                              base_friction={"steer": ("viscous", {"c": viscous_c})}, robot=robot)
    path = folder / "stand.csv"
    write_recording(path, measure(dense, truth["sensors"], rng), {"kind": "steer_stand", "pressure_kpa": None})
    return path


def test_planted_coulomb_friction_is_found_with_its_magnitude(tmp_path):
    path = _stand_recording(tmp_path, {"coulomb_friction": {"tau_c": 0.35}}, viscous_c=0.12)
    d, js = diagnose(path, settings=FAST)
    assert [m["effect"] for m in js["missing_physics"]] == ["coulomb_friction"]
    m = js["missing_physics"][0]
    assert m["dof"] == "steer"
    assert m["parameters"]["tau_c"] == pytest.approx(0.35, rel=0.15)
    lo, hi = m["ci95"]["tau_c"]
    assert lo < m["parameters"]["tau_c"] < hi
    assert m["delta_bic"] < -10
    assert js["verdict"] == "augmented"
    f = js["fit"]
    assert f["rmse_after"] < 0.2 * f["rmse_before"]
    assert f["rmse_heldout_after"] < 0.2 * f["rmse_heldout_before"]
    assert d.final.values["viscous_c"] == pytest.approx(0.12, rel=0.15)
    # The baseline's misfit concentrates where dry friction acts: slow, small late swings.
    top = js["located"][0]
    assert top["regime"] in ("low_speed", "near_stop", "rest_offset", "small_amplitude", "late_decay", "reversal")


def test_recording_matching_the_baseline_is_adequate(tmp_path):
    path = _stand_recording(tmp_path, {}, viscous_c=0.15, seed=2)
    d, js = diagnose(path, settings=FAST)
    assert js["verdict"] == "adequate"
    assert js["missing_physics"] == []
    assert js["baseline"]["fitted"]["viscous_c"] == pytest.approx(0.15, rel=0.1)
    assert js["fit"]["rmse_before"] < 2.0 * d.noise


@pytest.mark.slow       # a real log: 15-45 s each; run by make test-slow and CI
@pytest.mark.skipif(not REAL_STEER.exists(), reason="real logs not available (../shared/data/roboball_real)")
def test_real_shell_log_is_unexplained_and_says_where(tmp_path):
    """The real shell log's first half swing after the turning point takes about 1.3 s, the later
    ones about 0.65 s: no effect of the vocabulary on a rigid rolling sphere reproduces that, and
    the diagnosis says so.  diagnosis.json's `located` stays the contract's (the baseline's
    residual, shares of one whole); where the residual remains after the effects is in the
    report and in details.json."""
    d, js = diagnose(REAL_STEER.with_name("dynamic_data.csv"), out_dir=tmp_path, drake=False)
    assert js["verdict"] == "unexplained" and js["missing_physics"]
    # issue 24: the paper's injected terms, a stiffness and a damping (a damped sine from the
    # turning point gives 0.028 rad; with the 0.04 rad offset at rest, 0.028-0.034)
    names = {m["effect"] for m in js["missing_physics"]}
    assert {"linear_stiffness", "viscous_damping"} <= names, names
    assert js["fit"]["rmse_after"] <= 0.034
    assert sum(loc["share_of_residual"] for loc in js["located"]) <= 1.0 + 1e-9
    assert all(set(loc) == {"start_s", "end_s", "signal", "regime", "share_of_residual"} for loc in js["located"])
    after = json.loads((tmp_path / "details.json").read_text())["located_augmented"]
    report = (tmp_path / "report.md").read_text()
    assert after and "## Unexplained residual" in report
    assert f"{after[0]['start_s']:.2f}-{after[0]['end_s']:.2f} s" in report.split("## Unexplained residual")[1]


@pytest.mark.slow       # a real log: 15-45 s each; run by make test-slow and CI
@pytest.mark.skipif(not REAL_STEER.exists(), reason="real logs not available (../shared/data/roboball_real)")
@pytest.mark.xfail(strict=True, reason="with the steer joint LOCKED (the contract's default baseline) the later "
                   "swings do not carry the first one; blocks of 2 s, the first with its release state fitted on it: "
                   "0.063, 0.041, 0.004 rad, held-out 0.044 rad (fitted 0.0295).  With the pendulum free, as the "
                   "pipeline diagnoses this log, it is 0.0068 rad (tests/diagnose/test_steer_joint.py)")
def test_real_shell_log_with_the_steer_locked_heldout_rms_is_within_30_mrad():
    d, js = diagnose(REAL_STEER.with_name("dynamic_data.csv"))
    assert js["fit"]["rmse_heldout_after"] <= 0.03


@pytest.mark.slow       # a real log: 15-45 s each; run by make test-slow and CI
@pytest.mark.skipif(not REAL_STEER.exists(), reason="real logs not available (../shared/data/roboball_real)")
def test_real_steer_stand_log_shows_dry_friction_and_its_heldout_error_falls():
    """Issue 6, acceptance 3: the swings stop off rest; the diagnosis names the dry friction."""
    d, js = diagnose(REAL_STEER, settings=Settings(max_effects=2))
    names = [m["effect"] for m in js["missing_physics"]]
    assert "coulomb_friction" in names or "stiction" in names, names
    f = js["fit"]
    assert f["rmse_heldout_after"] < 0.5 * f["rmse_heldout_before"]
    dry = next(m for m in js["missing_physics"] if m["effect"] in ("coulomb_friction", "stiction"))
    value = next(iter(dry["parameters"].values()))
    assert 0.05 < value < 2.0          # N m: the order of Table I's dry friction (0.45-0.65)


@pytest.mark.slow       # a real log: 15-45 s each; run by make test-slow and CI
@pytest.mark.skipif(not REAL_STEER.exists(), reason="real logs not available (../shared/data/roboball_real)")
def test_real_steer_stand_log_slow_swing_is_inertia_or_softer_restoring_torque_and_says_so(tmp_path):
    """Issue 24: the real pendulum swings about 4% slower than the URDF.  A uniform slowing is
    more inertia (the 15:1 steer gearbox reflects the motor's rotor inertia J N^2, which the URDF
    leaves out), and a negative stiffness is a softer restoring torque; the data barely tell them
    apart.  The diagnosis names the dry friction and one of the two for the slow swing, lists the
    other as its alternative with its held-out RMS, and the report names both mechanisms.  The
    search reaches the Coulomb friction's better basin (tau_c near 0.5 N m) that a greedy path
    through the stiffness missed (0.29 N m, held-out 0.0279 rad)."""
    d, js = diagnose(REAL_STEER, out_dir=tmp_path, drake=False)
    mp = {m["effect"]: m for m in js["missing_physics"]}
    assert "coulomb_friction" in mp and mp["coulomb_friction"]["parameters"]["tau_c"] > 0.4
    slow = [e for e in ("added_inertia", "linear_stiffness") if e in mp]
    assert len(slow) == 1, list(mp)
    other = {"added_inertia": "linear_stiffness", "linear_stiffness": "added_inertia"}[slow[0]]
    (alt,) = [a for a in mp[slow[0]]["alternatives"] if a["effect"] == other]
    assert alt["rmse_heldout"] <= (1 + d.settings.equivalent_tol) * js["fit"]["rmse_heldout_after"]
    inertia = mp["added_inertia"]["parameters"] if slow[0] == "added_inertia" else alt["parameters"]
    stiffness = mp["linear_stiffness"]["parameters"] if slow[0] == "linear_stiffness" else alt["parameters"]
    assert 0.03 < inertia["delta_i"] < 0.09 and -2.0 < stiffness["k"] < -1.2    # kg m^2; N m/rad
    assert js["fit"]["rmse_heldout_after"] <= 0.025
    report = (tmp_path / "report.md").read_text()
    section = report.split("### Equivalent explanations")[1].split("## Fit")[0]
    assert "reflected rotor inertia of a geared joint" in section and "softer restoring torque" in section
    # a breakaway beside them lowers the BIC and the held-out error, but any value from a few N m to
    # the law's bound fits about as well (its Wald interval was 0.02 N m wide), and none nearly so:
    # its likelihood ratio at zero sits at the 95% quantile (2.93 under the pipeline's
    # pinned numerics: refused; 3.92 with this machine's native vector code: kept), so either way
    # the profile decides it (roboball.diagnose.profile), and a kept one is bounded from below only
    if "stiction" in mp:
        lo, hi = mp["stiction"]["ci95"]["tau_s"]
        assert 0.5 < lo < mp["stiction"]["parameters"]["tau_s"] and hi == 20.0
    else:
        rounds = json.loads((tmp_path / "details.json").read_text())["rounds"]
        judged = [i for step in rounds for i in step if i["effect"] == "stiction" and "itself" in i["failed"]]
        assert judged and "profile" in judged[0]["reason"]


def test_cli_writes_the_contract_files(tmp_path, capsys):
    path = _stand_recording(tmp_path, {"coulomb_friction": {"tau_c": 0.3}}, viscous_c=0.1, releases=(-0.7,),
                            free_s=5.0, seed=3)
    out = tmp_path / "diag"
    assert cli_main(["diagnose", str(path), "--out", str(out)]) == 0
    assert "augmented (coulomb_friction)" in capsys.readouterr().out
    js = json.loads((out / "diagnosis.json").read_text())
    assert set(js) == {"kind", "baseline", "verdict", "located", "missing_physics", "fit"}
    assert js["kind"] == "steer_stand" and js["verdict"] in ("adequate", "augmented", "unexplained")
    assert set(js["baseline"]) == {"description", "fitted", "refitted_with_effects"}
    assert "viscous_c" in js["baseline"]["fitted"]
    # the augmented model = the baseline refitted with the effects: its own values are given
    refit = js["baseline"]["refitted_with_effects"]
    assert set(refit) == set(js["baseline"]["fitted"])
    report = (out / "report.md").read_text()
    assert "Refitted with the effects (the augmented model): viscous_c = " in report
    assert "A window starts at the first turning point" in report and "averaged trend" not in report
    for loc in js["located"]:
        assert {"start_s", "end_s", "signal", "regime", "share_of_residual"} <= set(loc)
        assert loc["start_s"] <= loc["end_s"] and 0 <= loc["share_of_residual"] <= 1
        assert loc["signal"] == "steer_angle_rad"
    # the baseline's residual only: the windows' shares of it cannot add up to more than all of it
    assert sum(loc["share_of_residual"] for loc in js["located"]) <= 1.0 + 1e-9
    for m in js["missing_physics"]:
        assert {"effect", "dof", "parameters", "ci95", "delta_bic", "explains"} <= set(m)
        assert set(m["parameters"]) == set(m["ci95"])
    f = js["fit"]
    assert {"rmse_before", "rmse_after", "rmse_heldout_before", "rmse_heldout_after", "units"} <= set(f)
    assert f["units"] == "rad"
    # One release: held out by time blocks.  The augmented model also runs in Drake and fits there.
    assert f["drake_rmse_after"] < 0.2 * f["drake_rmse_before"]
    for name in ("report.md", "overlay.png", "regimes.png", "windows.png", "details.json"):
        assert (out / name).stat().st_size > 0
    from roboball.diagnose.report import OUTPUT_FILES      # what the command checks before any work
    assert {p.name for p in out.iterdir()} <= set(OUTPUT_FILES)
    assert "coulomb_friction" in (out / "report.md").read_text()


@pytest.mark.parametrize("args,needle", [
    ([str(BAD / "empty.csv")], "empty"),
    ([str(BAD / "misspelled_column.csv")], "steer_angel_rad"),
    ([str(BAD / "unknown_kind.csv")], "kind"),
    ([str(BAD / "ok_crlf.csv"), "--kind", "banana"], "banana"),
    ([str(BAD / "missing_file.csv")], "not found"),
])
def test_bad_input_exits_nonzero_with_one_line(tmp_path, capsys, args, needle):
    try:
        code = cli_main(["diagnose", *args, "--out", str(tmp_path / "o")])
    except SystemExit as exc:          # argparse usage errors (one line, exit 2)
        code = exc.code
    err = capsys.readouterr().err.strip()
    assert code != 0
    assert len(err.splitlines()) == 1, err
    assert needle in err
    assert not (tmp_path / "o" / "diagnosis.json").exists()


def test_drake_runs_start_a_release_past_the_steer_stop_at_the_stop_with_a_note():
    """The reduced model has no joint stop; a fitted start past it (the real log's 1.044 rad)
    must not abort the Drake overlay (Drake refuses such a release): it starts at the limit and
    the report says so."""
    from roboball.diagnose.data import prepare, read
    from roboball.diagnose.drake import simulate_windows
    from roboball.reduced.models import model_for

    prep = prepare(read(REPO / "raw_data" / "steer_stand" / "steer_stand_r1.csv"))
    prep.windows = prep.windows[:1]
    w = prep.windows[0]
    w.t, w.y = w.t[w.t <= w.t0 + 1.0], w.y[w.t <= w.t0 + 1.0]
    pred = simulate_windows(prep, model_for("steer_stand"), {"viscous_c": 0.2, "q0@0": 1.2}, ())
    assert np.all(np.isfinite(pred[0])) and abs(pred[0][0] - 1.0) < 0.02
    assert any("past the steer joint's limits" in n and "start at the limit" in n for n in prep.notes)


@pytest.mark.parametrize("case_id, found", [("shell_rock-23", ["linear_stiffness"]),
                                            ("shell_rock-24", ["cubic_stiffness"])])
def test_undamped_shell_grabbed_mid_swing_and_held_between_its_extremes(tmp_path, case_id, found):
    """Two cases of the blind benchmark's seed 7: a shell that hardly loses amplitude is grabbed
    mid-swing and held between the extremes of its swings.  The hold was taken for the rest the
    swings settled at (release missed: shell_rock-23), and the hand's move into the next hold
    was fitted as a free half swing (shell_rock-24); both diagnoses then failed."""
    import sys

    sys.path.insert(0, str(REPO / "benchmarks"))
    import blind_cases
    import diagnose_blind

    case = next(c for c in blind_cases.draw_cases(7) if c["id"] == case_id)
    csv = diagnose_blind.make_recording(case, tmp_path)
    d, js = diagnose(str(csv), settings=FAST, drake=False)
    assert len(d.prep.windows) == 3
    assert sorted(m["effect"] for m in js["missing_physics"]) == found
    assert js["verdict"] == "augmented"


@pytest.mark.parametrize("case_id, found", [("steer_stand-12", ["coulomb_friction", "linear_stiffness"]),
                                            ("steer_stand-16", ["linear_stiffness", "quadratic_drag"])])
def test_a_stiffness_is_not_reported_as_backlash_without_free_play(tmp_path, case_id, found):
    """Two cases of the blind benchmark's seed 8: a positive linear stiffness (with Coulomb
    friction, or with quadratic drag) was reported as backlash of free play b = 0.0001 rad
    (95% interval [-0.0001, 0.0002]), which fitted a hair better than linear stiffness and so
    won on BIC.  Backlash with b = 0 is linear stiffness; the keep rule now asks b's interval to
    exclude zero too (Effect.reduces_to)."""
    import sys

    sys.path.insert(0, str(REPO / "benchmarks"))
    import blind_cases
    import diagnose_blind

    case = next(c for c in blind_cases.draw_cases(8) if c["id"] == case_id)
    csv = diagnose_blind.make_recording(case, tmp_path)
    d, js = diagnose(str(csv), settings=FAST, drake=False)
    assert sorted(m["effect"] for m in js["missing_physics"]) == found
    k = next(m for m in js["missing_physics"] if m["effect"] == "linear_stiffness")["parameters"]["k"]
    assert k == pytest.approx(case["effects"]["linear_stiffness"]["k"], rel=0.02)


@pytest.mark.parametrize("case_id", ["steer_stand-13", "steer_stand-14"])
def test_stiction_that_stops_the_swings_early_is_found(tmp_path, case_id):
    """Two Coulomb + stiction cases of the blind benchmark's seed 8, where the swings come to
    rest within the recording.  With a breakaway hump 20 mrad/s wide the diagnosis reported an
    extra linear stiffness (13) or quadratic drag in place of the stiction (14): the hump acted
    at every reversal of the swings and delayed it, which the test bed's LuGre bristles do not
    (a reversal lasts too short a slide for them to load up).  Its width is now 2 V_EPS, where
    the law holds the joint.  With the old width case 14 fails here; case 13's extra stiffness
    came third, beyond these two-effect settings (the benchmark shows it).  The breakaway
    excess is found within a factor 2.5 of the truth (a memoryless law holds the joint only in
    its creep band, where the bristles hold it in full)."""
    import sys

    sys.path.insert(0, str(REPO / "benchmarks"))
    import blind_cases
    import diagnose_blind

    case = next(c for c in blind_cases.draw_cases(8) if c["id"] == case_id)
    csv = diagnose_blind.make_recording(case, tmp_path)
    d, js = diagnose(str(csv), settings=FAST, drake=False)
    assert sorted(m["effect"] for m in js["missing_physics"]) == ["coulomb_friction", "stiction"]
    tau_c = next(m for m in js["missing_physics"] if m["effect"] == "coulomb_friction")["parameters"]["tau_c"]
    assert tau_c == pytest.approx(case["effects"]["coulomb_friction"]["tau_c"], rel=0.25)
    tau_s = next(m for m in js["missing_physics"] if m["effect"] == "stiction")["parameters"]["tau_s"]
    # tau_s is the breakaway excess the law holds (0.47 and 0.88 N m against the truth's 0.50
    # and 0.45); as the former hump amplitude it read 0.78 and 1.48, 1.6 and 3.3 times the truth
    assert 0.4 < tau_s / case["effects"]["stiction"]["tau_s"] < 2.5


def test_the_report_s_two_drake_models_run_side_by_side_with_the_sequential_result(monkeypatch):
    """Given a second thread the report runs the baseline and the augmented model in Drake at
    once (Drake steps without the GIL); the predictions are the same bits as one after the other,
    and the notes each run adds come in the sequential order (the baseline's first)."""
    import threading
    from types import SimpleNamespace

    from roboball.diagnose import drake, report
    from roboball.diagnose.data import prepare, read
    from roboball.reduced.models import model_for

    def case():
        prep = prepare(read(REPO / "raw_data" / "steer_stand" / "steer_stand_r1.csv"))
        prep.windows = prep.windows[:1]
        w = prep.windows[0]
        w.t, w.y = w.t[w.t <= w.t0 + 1.0], w.y[w.t <= w.t0 + 1.0]
        # both starts past the steer stop, at different angles: each run notes its own
        return SimpleNamespace(prep=prep, model=model_for("steer_stand"), chosen=("coulomb_friction",),
                               baseline=SimpleNamespace(values={"viscous_c": 0.2, "q0@0": 1.2}),
                               final=SimpleNamespace(values={"viscous_c": 0.2, "q0@0": 1.1,
                                                             "coulomb_friction.tau_c": 0.3}))

    threads = []
    run = drake.simulate_windows

    def spy(*a, **kw):
        threads.append((a[2]["q0@0"], threading.current_thread() is threading.main_thread()))
        return run(*a, **kw)

    monkeypatch.setattr(report, "simulate_windows", spy)
    out = {}
    for n in (1, 2):
        monkeypatch.setattr(report, "second_thread", lambda n=n: n > 1)
        d = case()
        out[n] = (report._drake_predictions(d, True), list(d.prep.notes))
        # one thread: both in this one; two: the final model in the other
        assert sorted(threads) == [(1.1, n == 1), (1.2, True)]
        threads.clear()
    (base1, aug1, stats1), notes1 = out[1]
    (base2, aug2, stats2), notes2 = out[2]
    assert np.array_equal(base1[0], base2[0]) and np.array_equal(aug1[0], aug2[0])
    assert not np.array_equal(base1[0], aug1[0]) and stats1 == stats2
    assert notes1 == notes2 and len(notes1) == 2
    assert "1.2 rad" in notes1[0] and "1.1 rad" in notes1[1]
