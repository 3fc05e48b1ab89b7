"""A batch's repeated rows are simulated once (ReducedModel.distinct_rows, used by
roboball.diagnose.fit.Engine): every row's numbers are those of the whole batch to the bit, and a
batch whose distinct rows would add the effects in another order is simulated whole."""
import numpy as np
import pytest

import roboball.diagnose.fit as fit
from roboball.diagnose.data import prepare, read
from roboball.diagnose.select import Selector
from roboball.physics import effects as fx
from roboball.reduced.ramp import RampModel
from roboball.reduced.shell import ShellModel
from roboball.reduced.shell_steer import ShellSteerModel
from roboball.reduced.stand import StandModel

from test_compiled import _batch


def _with_repeats(model, rng, B=24):
    """A batch of B/2 distinct rows (every effect on a random third of them), each row twice,
    shuffled, with the free pendulum's release state per row where the model has one."""
    q0 = rng.uniform(-0.4, 0.4, B // 2)
    P = _batch(model, B // 2, rng)
    for h in getattr(model, "hidden_release", ()):
        P[h.name] = rng.uniform(h.lo, h.hi, B // 2) * 0.3
    idx = rng.permutation(np.repeat(np.arange(B // 2), 2))
    return q0[idx], {k: v[idx] for k, v in P.items()}


@pytest.mark.parametrize("model", [StandModel("steer_stand"), ShellModel(), ShellSteerModel(), RampModel()],
                         ids=["stand", "shell", "free steer", "ramp"])
def test_each_distinct_row_simulated_once_gives_every_row_its_own_numbers(model):
    rng = np.random.default_rng(7)
    for _ in range(5):
        q0, P = _with_repeats(model, rng)
        found = model.distinct_rows(q0, P)
        if found is None:          # this draw would add the effects in another order
            continue
        rows, place = found
        assert rows.size == q0.size // 2 and np.all(np.diff(rows) > 0)     # the first of each, in order
        assert np.array_equal(q0[rows][place], q0)
        n = 300 if model.kind != "ramp" else 200
        Y, Yd = model.simulate(q0, P, n)
        y, yd = model.simulate(q0[rows], {k: v[rows] for k, v in P.items()}, n)
        assert np.array_equal(y[:, place], Y, equal_nan=True) and np.array_equal(yd[:, place], Yd, equal_nan=True)
        break
    else:
        pytest.fail("no draw kept its effects' order")


def test_a_batch_without_repeats_or_whose_effect_order_would_change_is_simulated_whole():
    model = StandModel("steer_stand")
    q0 = np.array([0.3, 0.1, 0.1, 0.2])
    P = {"viscous_c": np.full(4, 0.1), "quadratic_drag.c2": np.array([0.05, 0.0, 0.0, 0.07]),
         "linear_stiffness.k": np.full(4, 1.0)}
    # the drag on rows 0 and 3 of 4 is added after the stiffness (its rows are a half, not the
    # whole batch); on rows 0 and 2 of the 3 distinct ones it would be added before it
    assert [n for n, _ in model.effect_plan(P, ["quadratic_drag", "linear_stiffness"])] == \
        ["linear_stiffness", "quadratic_drag"]
    assert model.distinct_rows(q0, P) is None
    assert model.distinct_rows(np.array([0.3, 0.1, 0.2]), {k: v[[0, 1, 3]] for k, v in P.items()}) is None
    # repeats that differ in one bit are distinct rows
    assert model.distinct_rows(np.array([0.1, np.nextafter(0.1, 1.0)]), {"viscous_c": np.full(2, 0.1)}) is None
    found = model.distinct_rows(np.array([0.1, 0.1, 0.2]), {"viscous_c": np.full(3, 0.1)})
    assert found is not None and list(found[0]) == [0, 2] and list(found[1]) == [0, 0, 1]


def test_the_diagnosis_predicts_a_batch_with_repeats_as_it_does_row_by_row_whole(tmp_path, monkeypatch):
    """Engine.predict on a grid of starts asked for twice (as a ramp screen asks for its pooled
    fit's and a fold's rows) gives the same numbers with and without simulating each distinct row
    once, and simulates half the rows."""
    from roboball.testbed.synthetic import synthetic_release_log
    from roboball.ingest.recording import Recording, write_recording
    import pandas as pd

    t, y, _ = synthetic_release_log([dict(offset=0.6, zeta=0.05, omega_n=5.0, free_s=5.0),
                                     dict(offset=-0.4, zeta=0.05, omega_n=5.0, free_s=5.0)], rest=-0.0355, seed=3)
    path = tmp_path / "stand.csv"
    write_recording(path, Recording(pd.DataFrame({"time_s": t, "steer_angle_rad": y}),
                                    {"kind": "steer_stand", "pressure_kpa": None}))
    sel = Selector(prepare(read(path)))
    engine = sel.engine
    start = engine.initial_values()
    eff = fx.LIBRARY["coulomb_friction"]
    grid = [dict(start, **{"coulomb_friction.tau_c": x}) for x in eff.params[0].grid_values()]
    windows = [w.index for w in engine.prep.windows]
    items = [(v, w) for v in grid for w in windows] * 2          # every row asked twice
    n0 = engine.n_sims
    got = engine.predict(items)
    simulated = engine.n_sims - n0
    monkeypatch.setattr(type(engine.model), "distinct_rows", lambda self, q0, P: None)
    whole = engine.predict(items)
    assert simulated == len(items) // 2 and engine.n_sims - n0 - simulated == len(items)
    for (a, ad), (b, bd) in zip(got, whole):
        assert np.array_equal(a, b) and np.array_equal(ad, bd)
    assert fit.SPLIT_MIN > len(items)      # one batch: the rows' plan is the whole batch's
