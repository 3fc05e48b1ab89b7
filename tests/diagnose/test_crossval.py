"""The held-out folds of a single release (roboball.diagnose.crossval): a release's state is a
nuisance of the data that hold its start, fitted there with the model frozen, in a block fold as
in a held-out release's fold (issue 24: the real shell log's first block was predicted from a
state extrapolated backwards from the later, tiny swings)."""
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
