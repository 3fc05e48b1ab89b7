"""A shell release with the pendulum free on its steer joint (`--steer-joint free`, sidecar
`steer_joint`): the steer joint's unobserved release state is fitted inside the baseline, bad
settings are refused in one line, and on the real shell log (whose steer setting was not
recorded) the free baseline's diagnosis fits where the locked one cannot."""
import json
import sys

import numpy as np
import pandas as pd
import pytest

from roboball.cli.main import main as cli_main
from roboball.diagnose import diagnose
from roboball.diagnose.data import prepare
from roboball.diagnose.fit import Engine, Problem
from roboball.errors import RoboballError
from roboball.ingest.recording import Recording, write_recording
from roboball.reduced.shell_steer import ShellSteerModel

from conftest import REAL_DATA, REPO

sys.path.insert(0, str(REPO / "benchmarks"))
from diagnose_speed import imbalanced_free_releases  # noqa: E402  (the benchmark's recording)
REAL_SHELL = REAL_DATA / "dynamic_data.csv"


def _free_release(tmp_path, meta_extra=None, k=50.0, c=8.0, steer0=-0.4, rate0=-3.0, seed=3):
    """A 6 s release of the free-steer robot in Drake (coupled scenario, compliant point contact,
    1 ms steps, the shell stiffness and damping as a force on the roll), 100 Hz with noise."""
    from roboball.diagnose.drake import effect_term
    from roboball.sim.coupled import coupled_spec
    from roboball.sim.scenarios import simulate
    from roboball.sim.spec import ShellParams
    model = ShellSteerModel()
    effects = {"linear_stiffness": {"k": k}, "viscous_damping": {"c": c}}
    spec = coupled_spec("point", ShellParams(), model.majd, extra_terms=[effect_term(model, effects)], dt=1e-3)
    df = simulate(spec, 0.35, 6.0, sample_rate_hz=100, steer0=steer0, rates0={"pipe_rate": 0.0, "steer_rate": rate0})
    rng = np.random.default_rng(seed)
    t = df.time_s.to_numpy()
    y = df.pipe_angle_rad.to_numpy() + rng.normal(0.0, 5e-4, len(t))
    # a 1 s hold at the release angle before the let-go, as a hand-held release is logged
    hold = np.arange(0.0, 1.0, 0.01)
    data = {"time_s": np.concatenate([hold, t + 1.0]),
            "pipe_angle_rad": np.concatenate([0.35 + rng.normal(0.0, 5e-4, len(hold)), y])}
    path = tmp_path / "free.csv"
    write_recording(path, Recording(pd.DataFrame(data), {"kind": "shell_rock", "pressure_kpa": 13.8,
                                                         **(meta_extra or {})}))
    return path, df          # df: the truth, the unobserved steer joint's included


def test_hidden_release_state_is_fitted_per_release_and_reaches_the_model(tmp_path):
    """The engine carries the steer joint's release state as per-release keys with the model's
    bounds, and a fit of the baseline from the grid's best start recovers the state a Drake
    release was made with (stiffness and damping held at the truth)."""
    path, df = _free_release(tmp_path)
    from roboball.diagnose.data import read
    prep = prepare(read(path))
    eng = Engine(ShellSteerModel(), prep)
    w = prep.windows[0].index
    assert eng.info[f"steer_angle@{w}"][1:] == (-1.5, 1.0)
    assert set(eng.release_keys()) >= {f"steer_angle@{w}", f"steer_rate@{w}"}
    values = dict(eng.initial_values(), **{"linear_stiffness.k": 50.0, "viscous_damping.c": 8.0})
    prob = Problem(effects=("linear_stiffness", "viscous_damping"), values=values, free=eng.release_keys(),
                   masks={w: np.ones(prep.windows[0].n, bool)})
    prob.values = eng.best_of(prob, eng.hidden_variants(values))
    eng.fit([prob], max_iter=40)
    rms = np.sqrt(prob.rss / prob.n)
    assert rms < 3e-3, rms
    # the window starts at the first turning point, so the fitted state is the pendulum's there:
    # compare with Drake's own steer joint at that instant (the recording does not hold it)
    t0 = prep.windows[0].t0 + prob.values.get(f"ts@{w}", 0.0) - 1.0      # the hold's second
    ts = df.time_s.to_numpy()
    steer = np.interp(t0, ts, df.steer_angle_rad.to_numpy())
    rate = np.interp(t0, ts, np.gradient(df.steer_angle_rad.to_numpy(), ts))
    assert prob.values[f"steer_angle@{w}"] == pytest.approx(steer, abs=0.05)
    assert prob.values[f"steer_rate@{w}"] == pytest.approx(rate, abs=0.3)


def test_steer_joint_setting_is_checked_in_one_line(tmp_path, capsys):
    bad, _ = _free_release(tmp_path, {"steer_joint": "clamped"})
    with pytest.raises(RoboballError, match=r"free\.json: field steer_joint: 'clamped' is not a steer setting"):
        diagnose(bad)
    stand = tmp_path / "stand.csv"
    write_recording(stand, Recording(
        pd.DataFrame({"time_s": np.arange(0, 8, 0.01),
                                        "steer_angle_rad": 0.5 * np.cos(5.6 * np.arange(0, 8, 0.01))
                                        * np.exp(-0.2 * np.arange(0, 8, 0.01))}),
        {"kind": "steer_stand", "pressure_kpa": None}))
    for value in ("free", "unknown"):
        with pytest.raises(RoboballError, match=f"--steer-joint: '{value}' applies to shell_rock recordings only, "
                                                "not to steer_stand"):
            diagnose(stand, steer_joint=value)
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exc:
        cli_main(["diagnose", str(bad), "--out", str(out), "--steer-joint", "sideways"])
    assert exc.value.code != 0 and not out.exists()
    assert "invalid choice: 'sideways'" in capsys.readouterr().err


@pytest.mark.slow       # a diagnosis of the free-steer model: about a minute
def test_free_steer_diagnosis_finds_the_shell_stiffness_and_damping_of_a_drake_release(tmp_path):
    path, _ = _free_release(tmp_path, {"steer_joint": "free"})
    d, js = diagnose(path)
    assert js["baseline"]["fitted"].keys() >= {"release_1_steer_angle_rad", "release_1_steer_rate_rad_s"}
    mp = {m["effect"]: m for m in js["missing_physics"]}
    assert "linear_stiffness" in mp, list(mp)
    assert mp["linear_stiffness"]["parameters"]["k"] == pytest.approx(50.0, rel=0.15)
    damping = mp.get("viscous_damping") or next(
        (a for m in mp.values() for a in m.get("alternatives", []) if a["effect"] == "viscous_damping"), None)
    assert damping is not None, list(mp)
    assert js["fit"]["rmse_heldout_after"] < 3e-3


@pytest.mark.slow       # a real log, both steer settings: about 2 min with the Drake overlay
@pytest.mark.skipif(not REAL_SHELL.exists(), reason="real logs not available (../shared/data/roboball_real)")
def test_real_shell_log_of_unrecorded_steer_setting_is_the_free_pendulum_with_stiffness_and_damping(tmp_path):
    """Issue 24, acceptance 1.  The log does not record whether the steer joint was clamped (the
    authors' own model of it has the pendulum free); diagnosed both ways, the free pendulum's
    diagnosis predicts the held-out blocks six times better and is reported: it names the shell's
    linear stiffness and a damping (viscous_damping, chosen or the listed equivalent of the
    chosen velocity loss), the augmented Drake model swings with the recording, and the held-out
    RMS is within 30 mrad."""
    d, js = diagnose(REAL_SHELL, out_dir=tmp_path, steer_joint="unknown")
    assert d.steer_settings["free"]["rmse_heldout"] < 0.2 * d.steer_settings["locked"]["rmse_heldout"]
    assert "pendulum free on its steer joint" in js["baseline"]["description"]
    mp = {m["effect"]: m for m in js["missing_physics"]}
    assert "linear_stiffness" in mp, list(mp)
    assert 40.0 < mp["linear_stiffness"]["parameters"]["k"] < 80.0
    named = set(mp) | {a["effect"] for m in mp.values() for a in m.get("alternatives", [])}
    assert "viscous_damping" in named, named
    f = js["fit"]
    assert f["rmse_heldout_after"] <= 0.03
    assert f["drake_rmse_after"] <= 0.015          # the augmented Drake model swings with the log
    report = (tmp_path / "report.md").read_text()
    assert "pendulum free on its steer joint" in report and "reported: free, decided" in report
    # decided on the data's own evidence: sevenfold in RMS over a dozen independent samples
    assert d.steer_decision["decided"] and d.steer_decision["test"]["p_two_sided"] < 1e-6
    assert json.loads((tmp_path / "details.json").read_text())["steer_settings"] == json.loads(
        json.dumps(d.steer_settings))


@pytest.mark.slow       # the real shell log both ways at a quarter of the step: about 2 min
@pytest.mark.skipif(not REAL_SHELL.exists(), reason="real logs not available (../shared/data/roboball_real)")
def test_the_real_shell_log_s_findings_are_the_same_at_a_quarter_of_the_reduced_models_step():
    """The log's noise (33 µrad) is below the free model's 2 ms step error with its rolling
    resistance (18 µrad against 0.1 ms), and its misfit (180 noise levels) leaves the search's last
    choice on a knife edge: a softening cubic at its bound comes and goes with the step and with
    NumPy's last bits (docs/diagnosis.md, Known limits).  What the diagnosis reports must not:
    at 0.5 ms (5 µrad) as at 2 ms, the shell's stiffness, a rolling resistance and a velocity loss
    (its shape undecided: the drag or the viscous damping, the other listed), their values inside
    each other's intervals, and nothing else but that cubic."""
    from roboball.diagnose.scored import Settings

    runs = {dt: diagnose(REAL_SHELL, steer_joint="unknown", settings=Settings(dt=dt))[1] for dt in (2e-3, 5e-4)}
    found = {dt: {m["effect"]: m for m in js["missing_physics"]} for dt, js in runs.items()}
    for dt, mp in found.items():
        loss = {"quadratic_drag", "viscous_damping"} & set(mp)
        assert {"linear_stiffness", "rolling_resistance"} <= set(mp) and len(loss) == 1, (dt, list(mp))
        listed = {a["effect"] for a in mp[loss.pop()].get("alternatives", [])}
        assert set(mp) | listed >= {"quadratic_drag", "viscous_damping"}, (dt, list(mp), listed)
        assert set(mp) <= {"linear_stiffness", "rolling_resistance", "quadratic_drag", "viscous_damping",
                           "cubic_stiffness"}, (dt, list(mp))
    for effect, p in (("linear_stiffness", "k"), ("rolling_resistance", "tau_rr")):
        (lo1, hi1), (lo2, hi2) = (found[dt][effect]["ci95"][p] for dt in (2e-3, 5e-4))
        assert lo1 <= hi2 and lo2 <= hi1, (effect, (lo1, hi1), (lo2, hi2))


@pytest.mark.slow       # a test-bed shell release, both steer settings: about 2 min
def test_a_locked_steer_release_of_unrecorded_setting_is_reported_locked(tmp_path):
    """The test bed's own robot's shell releases are made with the steering locked (its membrane
    shell, not any fitted form): told the setting is unknown, the diagnosis keeps the locked
    baseline, since the free pendulum's does not predict the held-out data better.  (The
    campaign's file of the same name, until it was the twin's.)"""
    from roboball.testbed.campaign import jobs, make_file
    from roboball.testbed.physics import load_truth
    truth = load_truth()
    job = next(j for j in jobs(truth) if j["file"].endswith("shell_rock_20.7kpa_r1.csv"))
    make_file(job, str(tmp_path), truth)
    d, js = diagnose(tmp_path / job["file"], steer_joint="unknown")
    assert "steering locked" in js["baseline"]["description"]
    assert "reported: locked" in d.prep.notes[-1]
    assert d.steer_settings.keys() == {"locked", "free"}


# Not met on the twin's campaign (docs/diagnosis.md, "A shell release with the pendulum free"): its
# clamped releases are read as free, decisively: at 20.7 kPa held-out 0.0050 rad free against 0.0088
# locked (p = 1e-11), at 6.9 kPa 0.0067 against 0.0131.
TWIN_LOCKED = ("measured: the twin's clamped 20.7 kPa release reads free (held-out 0.0050 against 0.0088 rad locked): "
               "the free pendulum with a stiffness and a damping mimics the twin's shell better than any locked set")


@pytest.mark.slow       # a campaign shell release, both steer settings: about 1 min
@pytest.mark.xfail(strict=True, reason=TWIN_LOCKED)
def test_the_twins_clamped_shell_release_of_unrecorded_setting_is_reported_locked():
    from conftest import REPO
    d, js = diagnose(REPO / "raw_data" / "shell_rock" / "shell_rock_20.7kpa_r1.csv", steer_joint="unknown")
    assert "reported: locked" in d.prep.notes[-1]


@pytest.mark.slow       # Drake releases and a diagnosis both ways: 1-2 min each
@pytest.mark.parametrize("releases, delta", [((0.35, -0.35), 0.04), ((0.35,), 0.04), ((-0.3,), -0.03)],
                         ids=["both sides", "one side", "the other side"])
def test_a_free_pendulum_shell_with_a_sideways_imbalance_is_diagnosed_free_with_its_com_offset(
        tmp_path, releases, delta):
    """Issue 48, acceptance 3: a shell whose rest is shifted by a sideways imbalance, released with
    the pendulum free and its steer setting unrecorded, is reported free, with the com_offset
    beside the shell's stiffness and damping (not the joint locked with a rolling resistance
    standing in for the shifted rest).  From the other side the search judged the stiffness with a
    rolling resistance and the offset with it, both failing, and never the stiffness with the
    damping (roboball.diagnose.select.Selector._judge now judges on while none passes)."""
    path = imbalanced_free_releases(tmp_path / "imbalanced.csv", releases, delta, seed=3 + len(releases))
    d, js = diagnose(path)
    assert "pendulum free on its steer joint" in js["baseline"]["description"]
    mp = {m["effect"]: m["parameters"] for m in js["missing_physics"]}
    assert set(mp) == {"com_offset", "linear_stiffness", "viscous_damping"}, mp
    assert mp["com_offset"]["delta"] == pytest.approx(delta, rel=0.05)
    assert mp["linear_stiffness"]["k"] == pytest.approx(50.0, rel=0.05)
    assert js["verdict"] == "augmented" and js["fit"]["rmse_heldout_after"] < 1e-3


def _reduced_releases(path, releases, k=50.0, c=8.0, free_s=6.0, seed=3, dt=5e-4):
    """Shell releases of the free-steer reduced model itself (its NumPy loop at a quarter of the
    fits' step), each from a 1 s hold at (pipe angle from rest, steer joint angle, steer rate) of
    `releases`, 100 Hz with 0.5 mrad noise; returns the path and, per release, (let-go instant,
    times after it, steer angle, steer rate): the truth the recording does not hold."""
    from roboball.reduced.base import active_effects
    from roboball.reduced.shell_steer import integrate
    from roboball.testbed.sensors import min_jerk
    model = ShellSteerModel()
    P = {"linear_stiffness.k": np.array([k]), "viscous_damping.c": np.array([c])}
    extra = model.bind_effects(P, active_effects(P, model.candidates))
    ts, ys, truth = [np.arange(0.0, 1.0, 0.01)], [np.full(100, model.rest)], []
    t_now, y_now = 1.0, model.rest
    n, every = int(round(free_s / dt)), int(round(0.01 / dt))
    for rel, steer0, rate0 in releases:
        held = model.rest + rel
        ts += [t_now + np.arange(80) * 0.01, t_now + 0.8 + np.arange(100) * 0.01]
        ys += [min_jerk(y_now, held, 80), np.full(100, held)]
        t_now += 1.8
        Q, _, TH, W = integrate(model, extra, np.array([held]), np.array([steer0]), np.array([rate0]), n, dt)
        after = np.arange(n + 1) * dt
        truth.append((t_now, after, TH[:, 0], W[:, 0]))
        ts.append(t_now + after[every::every])
        ys.append(Q[every::every, 0])
        t_now, y_now = t_now + after[-1], float(Q[-1, 0])
    t = np.concatenate(ts)
    y = np.concatenate(ys) + np.random.default_rng(seed).normal(0.0, 5e-4, len(t))
    write_recording(path, Recording(pd.DataFrame({"time_s": t, "pipe_angle_rad": y}),
                                    {"kind": "shell_rock", "pressure_kpa": 13.8, "steer_joint": "free"}))
    return path, truth


def test_each_release_gets_its_own_hidden_start_and_the_fit_finds_each(tmp_path):
    """Issue 48, point 3.  Two releases with the pendulum hanging at the let-go, 0.3 and 0.6 rad
    from rest: the first window starts at the swing's first turning point with the pendulum
    swinging, the second at the let-go with it at rest, 0.8 rad apart.  The starts are chosen per
    release (roboball.diagnose.hidden), so the fit (stiffness and damping held at the truth)
    recovers each window's state.  With the same start in every window (as before) the best shared
    start suits neither and the fit ends 0.09 rad and 0.4 rad/s off in the first window, RMS 5.6
    mrad."""
    from roboball.diagnose.data import read
    model = ShellSteerModel()
    path, truth = _reduced_releases(tmp_path / "two.csv", [(-0.3, model.steer_rest + 0.3, 0.0),
                                                           (-0.6, model.steer_rest + 0.6, 0.0)])
    prep = prepare(read(path))
    assert [w.start for w in prep.windows] == ["turning point", "release"]
    eng = Engine(ShellSteerModel(), prep)
    values = dict(eng.initial_values(), **{"linear_stiffness.k": 50.0, "viscous_damping.c": 8.0})
    prob = Problem(effects=("linear_stiffness", "viscous_damping"), values=values, free=eng.release_keys(),
                   masks={w.index: np.ones(w.n, bool) for w in prep.windows})
    variants = eng.hidden_variants(values)
    prob.values = eng.best_of(prob, variants)
    eng.fit([prob], max_iter=40)
    assert np.sqrt(prob.rss / prob.n) < 1e-3
    states = []
    for w, (t_go, after, steer, rate) in zip(prep.windows, truth):
        at = w.t0 + prob.values[f"ts@{w.index}"] - t_go
        states.append(np.interp(at, after, steer))
        assert prob.values[f"steer_angle@{w.index}"] == pytest.approx(states[-1], abs=0.02)
        assert prob.values[f"steer_rate@{w.index}"] == pytest.approx(np.interp(at, after, rate), abs=0.1)
    assert abs(states[0] - states[1]) > 0.5
    assert len(variants) == 7          # each window's seven best of the model's 25 starts


def test_the_steer_decision_asks_the_winner_to_explain_the_recording_or_to_remove_nearly_all_of_the_other_s_error():
    """roboball.diagnose.steer.decide: the margin, the significance, and the winner explains the
    recording, by its own verdict or by holding out at a tenth of the other's RMS (99% of its
    square removed).  The held-out values are measured ones: a test-bed release of 0.02-0.04 rad,
    truly locked, free 4.5 mrad unexplained against locked 12.4 (p 0.006): undecided; the
    steer-setting closed loop's case 1, truly free, joint with a 0.45 rad release, free 1.75 mrad
    (the reduced free model 4 noise levels from the test bed's coupled pendulum, unexplained)
    against locked 20.2 (p 2e-24): decided free, where the verdict alone left it undecided."""
    from roboball.diagnose.scored import Settings
    from roboball.diagnose.steer import decide

    s = Settings()
    strong = {"ms_ratio": 133.0, "p_two_sided": 2e-24, "n_eff": 30.0}
    weak = {"ms_ratio": 7.6, "p_two_sided": 0.006, "n_eff": 12.0}
    misfits = {"free": "unexplained", "locked": "unexplained"}
    assert decide({"free": 0.0045, "locked": 0.0124}, misfits, weak, s)[:2] == ("free", False)
    better, decided, said = decide({"free": 0.00175, "locked": 0.0202}, misfits, strong, s)
    assert (better, decided) == ("free", True) and said.startswith("reported: free, decided")
    # explained by its own verdict, a smaller gain decides
    assert decide({"free": 0.0045, "locked": 0.0124}, {"free": "augmented", "locked": "unexplained"}, weak, s)[1]
    # not significant, or within the margin: undecided, whatever the ratio
    assert not decide({"free": 0.00175, "locked": 0.0202}, misfits, dict(strong, p_two_sided=0.2), s)[1]
    b, dec, said = decide({"free": 0.0100, "locked": 0.0102}, misfits, strong, s)
    assert b is None and not dec and "within 5%" in said
    # the same rule for a locked winner
    assert decide({"free": 0.0202, "locked": 0.00175}, misfits, dict(strong, ms_ratio=1 / 133.0), s)[:2] == ("locked", True)


def test_both_settings_side_by_side_return_and_say_what_one_after_the_other_does(monkeypatch):
    """Given a second thread the two settings' diagnoses run at once, the free one in a worker
    thread; the runs and the order of the messages are a sequential run's: the free one's are
    held while the locked one runs, and once it is done they pass as they come."""
    import threading
    import time

    from roboball.diagnose import steer

    where, said = {}, []

    def one(setting, say):
        where[setting] = threading.current_thread() is threading.main_thread()
        for step in ("data", "baseline", "round"):
            if setting == "free" and step == "round" and where["free"] is False:
                deadline = time.monotonic() + 5.0
                while "data: free" not in said and time.monotonic() < deadline:
                    time.sleep(0.001)                   # the locked one done, the held ones said
            if say:
                say(f"{step}: {setting}")
                if setting == "free" and step == "round" and where["free"] is False:
                    assert said[-1] == "round: free"
            time.sleep(0.01 if setting == "locked" else 0.005)   # interleaved if said as they come
        return setting.upper()

    for n in (1, 2):
        monkeypatch.setattr(steer, "second_thread", lambda n=n: n > 1)
        said.clear()
        assert steer.both_settings(one, said.append) == {"locked": "LOCKED", "free": "FREE"}
        assert said == [f"{step}: {s}" for s in ("locked", "free") for step in ("data", "baseline", "round")]
        assert where == {"locked": True, "free": n == 1}
        said.append("data: free")               # the run without a log waits on this
        assert steer.both_settings(one, None) == {"locked": "LOCKED", "free": "FREE"}


@pytest.mark.slow       # a campaign shell release, both steer settings, twice: about 2 min
def test_a_diagnosis_of_unrecorded_steer_setting_is_the_same_in_one_thread_as_in_two(tmp_path, monkeypatch):
    """The two settings' searches and the report's two Drake models side by side (two threads)
    write the same diagnosis, predictions and figures as one after the other."""
    from roboball.diagnose import beside

    csv = REPO / "raw_data" / "shell_rock" / "shell_rock_20.7kpa_r1.csv"
    files = ("diagnosis.json", "predictions.csv", "overlay.png", "windows.png", "regimes.png")
    out = {}
    for n in (1, 2):
        monkeypatch.setattr(beside.numba, "get_num_threads", lambda n=n: n)
        diagnose(csv, out_dir=tmp_path / str(n), steer_joint="unknown")
        out[n] = {f: (tmp_path / str(n) / f).read_bytes() for f in files}
    assert out[1] == out[2]


def test_an_error_in_the_locked_setting_ends_the_diagnosis_without_waiting_for_the_free_one(monkeypatch):
    """The free setting's search runs beside in a daemon thread: an error (or Ctrl-C) in the
    locked one is raised at once, not after the free one has finished."""
    import time

    from roboball.diagnose import steer

    def one(setting, say):
        if setting == "locked":
            raise KeyboardInterrupt
        time.sleep(3.0)
        return "FREE"

    monkeypatch.setattr(steer, "second_thread", lambda: True)
    t0 = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        steer.both_settings(one, None)
    assert time.monotonic() - t0 < 1.0


def test_an_error_beside_is_raised_where_its_result_is_asked_for():
    from roboball.diagnose.beside import Beside
    from roboball.errors import SimulationError

    def fails():
        raise SimulationError("Drake failed (a run)")

    with pytest.raises(SimulationError, match="Drake failed"):
        Beside(fails).result()
    assert Beside(lambda a, b=0: a + b, 2, b=3).result() == 5
