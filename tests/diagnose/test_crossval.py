"""The held-out folds of a single release (roboball.diagnose.crossval): a release's state is a
nuisance of the data that hold its start, fitted there with the model frozen, in a block fold as
in a held-out release's fold (issue 24: the real shell log's first block was predicted from a
state extrapolated backwards from the later, tiny swings)."""
import math

import numpy as np
import pytest

from roboball.diagnose.data import prepare, read
from roboball.diagnose.scored import Scored
from roboball.diagnose.select import Selector

from test_sensor_lag import _reduced_recording

C_HEAVY = 5.7       # N m s/rad: zeta about 0.3 on the shell (K_eq 21.9 N m/rad, M_eq 4.18 kg m^2)


@pytest.fixture(scope="module")
def single_release(tmp_path_factory):
    path = _reduced_recording(tmp_path_factory.mktemp("cv") / "shell.csv", 0.0, kind="shell_rock", releases=(0.4,),
                              params={"viscous_damping.c": C_HEAVY}, raw=True)
    return prepare(read(path))


def _fitted(sel):
    w = sel.prep.windows[0]
    values = dict(sel.engine.initial_values())
    values["viscous_damping.c"] = C_HEAVY
    sc = Scored(effects=("viscous_damping",), full=sel.full_problem(("viscous_damping",), values))
    sel.engine.fit([sc.full], max_iter=20)
    return sc, w


def test_the_first_block_of_a_single_release_has_its_state_fitted_on_it(single_release):
    sel = Selector(single_release)
    assert len(sel.prep.windows) == 1
    sc, w = _fitted(sel)
    state = sel.engine.release_keys([w.index])
    assert state
    # only the first block holds the release's start
    assert [held_w for _, held_w, _ in sel.folds] == [w.index, None, None]
    first = sel.folds[0][2][w.index]
    assert first[0] and not first.all()
    stage1 = sel._fold_problems([sc], cofit=False)
    for p in stage1:            # the later blocks, which depend on the state, fit it with the model
        assert set(state) <= set(p.free)
    sel.engine.fit(stage1, max_iter=sel.s.fold_iter)
    stage2 = sel._heldout_state_problems([sc], stage1)
    assert len(stage2) == 1
    q = stage2[0]
    assert q.tag == (id(sc), 0) and q.free == state
    assert list(q.masks) == [w.index] and np.array_equal(q.masks[w.index], first)
    # the model is the fold's, frozen: only the state differs from stage 1's fit on the later blocks
    frozen = {k: v for k, v in stage1[0].values.items() if k not in state}
    assert all(q.values[k] == v for k, v in frozen.items())
    # and the held-out prediction of the first block is the one made from that state
    sel.engine.fit(stage2, max_iter=sel.s.state_iter)
    sel.cross_validate([sc])
    assert np.allclose(sc.cv_pred[w.index][first], q.pred[w.index][first], rtol=0, atol=1e-9)
    assert np.isfinite(sc.cv_pred[w.index]).all()
    assert sc.cv_rmse < 3 * sel.prep.noise      # the true model predicts every block to the noise


def test_a_model_without_release_state_keeps_plain_blocks(single_release):
    """A model that fits no release state (the ramp's: each run starts at its detected instant)
    has nothing to fit on the first block: every block is predicted by the fit to the others."""
    from roboball.reduced.shell import ShellModel
    sel = Selector(single_release, model=ShellModel())
    sel.model.release_params = ()
    sel.folds = sel._folds()
    assert [held_w for _, held_w, _ in sel.folds] == [None, None, None]


def test_the_time_blocks_tile_the_window_and_split_the_free_response_evenly(single_release):
    """The folds and the overlay's dotted block edges come from one function."""
    from roboball.diagnose.crossval import time_blocks

    w = single_release.windows[0]
    blocks = time_blocks(w, 3)
    assert blocks[0][0] == 0 and blocks[-1][1] == w.n
    assert all(hi == lo for (_, hi), (lo, _) in zip(blocks, blocks[1:]))       # contiguous, no gap or overlap
    after = [int(np.sum(w.t[lo:hi] >= w.t0)) for lo, hi in blocks]
    assert max(after) - min(after) <= 1                                       # even split after the release


# ---- two models' held-out errors compared (roboball.diagnose.crossval.paired_heldout) --------
def _heldout(errors_a, errors_b, t=None):
    """Two cross-validated models whose held-out errors on one window are the given arrays."""
    from types import SimpleNamespace

    from roboball.diagnose.crossval import paired_heldout

    n = len(errors_a)
    t = np.arange(n) * 0.01 if t is None else t
    y = np.zeros(n)
    w = SimpleNamespace(index=0, t=t, y=y)
    ea, eb = np.asarray(errors_a, float), np.asarray(errors_b, float)
    a = Scored(effects=(), full=None, cv_pred={0: ea}, cv_err={0: ea})
    b = Scored(effects=(), full=None, cv_pred={0: eb}, cv_err={0: eb})
    return paired_heldout(a, [w], b, [w])


def test_white_held_out_errors_twice_as_large_are_a_decided_difference_and_equal_ones_are_not():
    rng = np.random.default_rng(1)
    e = rng.normal(0.0, 1e-3, 2000)
    res = _heldout(e, 2.0 * rng.normal(0.0, 1e-3, 2000))
    assert res["n"] == 2000 and res["n_eff"] > 1000          # white: every sample independent
    assert res["ms_ratio"] == pytest.approx(4.0, rel=0.15) and res["p_two_sided"] < 1e-12
    same = _heldout(e, rng.permutation(e))
    assert same["ms_ratio"] == pytest.approx(1.0) and same["p_two_sided"] > 0.9


def test_a_misfit_that_lasts_a_swing_counts_as_few_independent_samples():
    """A slow sinusoidal misfit, two swings in 2000 samples: the same RMS ratio that white errors
    make certain is undecided here, because the recording holds a handful of independent samples."""
    t = np.arange(2000) * 0.01
    rng = np.random.default_rng(2)
    slow_a = 1e-3 * np.sin(2 * np.pi * t / 10.0 + 0.3) + rng.normal(0, 1e-5, t.size)
    slow_b = 1.5e-3 * np.sin(2 * np.pi * t / 10.0 + 1.1) + rng.normal(0, 1e-5, t.size)
    res = _heldout(slow_a, slow_b, t)
    assert res["tau_samples"] > 50 and res["n_eff"] < 40
    assert res["ms_ratio"] > 2.0 and res["p_two_sided"] > 0.05
    white = _heldout(rng.normal(0, 1e-3, 2000), rng.normal(0, 1.5e-3, 2000))
    assert white["p_two_sided"] < 1e-6


def test_only_the_samples_both_models_predicted_are_compared():
    e = np.r_[np.full(50, np.nan), np.random.default_rng(3).normal(0, 1e-3, 500)]
    res = _heldout(e, 3.0 * np.nan_to_num(e, nan=1.0))
    assert res["n"] == 500 and res["ms_ratio"] == pytest.approx(9.0)
    assert math.isnan(_heldout([np.nan] * 5, [1.0] * 5)["p_two_sided"])


# ---- the level at which a joint comes to rest (roboball.diagnose.crossval.heldout_error) -----
def _stuck_window(rest_level=-0.065, noise=5e-4, rest_s=1.3, seed=4):
    """A stand swing that decays and sticks at `rest_level` for its last `rest_s` seconds."""
    from types import SimpleNamespace

    t = np.arange(0.0, 7.3, 0.01)
    t_stop = t[-1] - rest_s
    swing = 0.4 * np.exp(-0.35 * t) * np.cos(2 * np.pi * t / 1.1)
    y = np.where(t < t_stop, swing + rest_level * t / t_stop, rest_level)
    y = y + np.random.default_rng(seed).normal(0.0, noise, t.size)
    return SimpleNamespace(index=0, t=t, y=y, t0=0.0, n=t.size, smooth_s=0.0), t_stop


def test_a_recording_that_ends_at_rest_is_scored_about_its_level_and_a_swinging_one_is_not():
    from roboball.diagnose.crossval import heldout_error, rest_start

    w, t_stop = _stuck_window()
    i = rest_start(w, 5e-4)
    assert i is not None and abs(w.t[i] - t_stop) < 0.05
    # a prediction that sticks 30 mrad off the recorded level pays only before the stop
    pred = w.y.copy()
    pred[i:] += 0.03
    e = heldout_error(pred, w, 5e-4)
    assert np.max(np.abs(e)) < 1e-12
    # one that keeps swinging there pays for its swing
    pred = w.y.copy()
    pred[i:] += 0.03 + 0.01 * np.sin(2 * np.pi * w.t[i:] / 1.1)
    e = heldout_error(pred, w, 5e-4)
    assert np.sqrt(np.mean(e[i:] ** 2)) == pytest.approx(0.01 / math.sqrt(2), rel=0.1)
    # a swing that is still moving at its end (or rests under half a second) is scored as it is
    moving, _ = _stuck_window(rest_s=0.3)
    assert rest_start(moving, 5e-4) is None
    pred = moving.y + 0.03
    assert np.allclose(heldout_error(pred, moving, 5e-4), 0.03)
    # a ramp's averaged drive rate has no stick band: never
    averaged, _ = _stuck_window()
    averaged.smooth_s = 0.1
    assert rest_start(averaged, 5e-4) is None
