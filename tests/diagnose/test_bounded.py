"""Grids of starts bounded by what each start has cost so far (roboball.diagnose.bounded) pick the
very start that simulating every start to the end picks."""
import pandas as pd
import pytest

import roboball.diagnose.fit as fit
from roboball.diagnose.data import prepare, read
from roboball.diagnose.fit import Engine
from roboball.diagnose.select import Selector
from roboball.ingest.recording import Recording, write_recording
from roboball.testbed.synthetic import synthetic_release_log


@pytest.fixture
def stand_log(tmp_path):
    t, y, _ = synthetic_release_log([dict(offset=0.7, zeta=0.04, omega_n=5.5, free_s=6.0),
                                     dict(offset=-0.5, zeta=0.04, omega_n=5.5, free_s=6.0)], rest=-0.0355, seed=4)
    path = tmp_path / "stand.csv"
    write_recording(path, Recording(pd.DataFrame({"time_s": t, "steer_angle_rad": y}),
                                    {"kind": "steer_stand", "pressure_kpa": None}))
    return path


def test_bounded_grids_choose_the_starts_that_whole_runs_choose(stand_log, monkeypatch):
    sel = Selector(prepare(read(stand_log)))
    start = sel.engine.initial_values()
    trials = [(sel.full_problem((e,), start), e, [start, dict(start, viscous_c=0.3)])
              for e in ("coulomb_friction", "quadratic_drag", "linear_stiffness", "com_offset", "backlash")]
    assert fit.bounded_grid(sel.engine)
    bounded = sel.engine.best_starts(trials)
    monkeypatch.setattr(fit, "bounded_grid", lambda engine: False)
    whole = sel.engine.best_starts(trials)
    assert bounded == whole


def test_a_lagged_sensor_or_a_numpy_loop_simulates_every_start_to_the_end(stand_log):
    eng = Engine(Selector(prepare(read(stand_log))).model, prepare(read(stand_log)))
    assert fit.bounded_grid(eng)
    eng.sensor = {"sensor_lag_s": 0.02}
    assert not fit.bounded_grid(eng)
    eng.sensor = {}
    eng.model.compiled = False
    assert not fit.bounded_grid(eng)


def test_the_stretches_add_up_to_each_start_s_whole_cost(stand_log, monkeypatch):
    """Run every start through every stretch (nothing pruned): the costs the stretches accumulate
    are the whole runs' costs, so each stretch reads every sample once (a stretch reads only the
    columns its steps can reach)."""
    import numpy as np
    from roboball.diagnose import bounded

    sel = Selector(prepare(read(stand_log)))
    engine = sel.engine
    start = engine.initial_values()
    trials = [(sel.full_problem((e,), start), e, [start, dict(start, viscous_c=0.3)])
              for e in ("coulomb_friction", "linear_stiffness")]
    seen = {}
    monkeypatch.setattr(fit, "best_costs", lambda eng, items, spans: seen.update(items=items, spans=spans)
                        or bounded.best_costs(eng, items, spans))
    engine.best_starts(trials)
    items, spans = seen["items"], seen["spans"]
    owner, _ = bounded._owners(items, spans)
    g = sum(len(c) for _, c, _, _ in spans)
    partial = np.zeros(g)
    masks = bounded._item_masks(items, spans)
    runs = [bounded._Run(engine, items, rows, owner, masks) for rows in bounded._by_window(items)]
    n = 0
    while any(r.left for r in runs):
        for r in runs:
            r.stretch(partial, np.ones(g, bool))
        n += 1
    assert n > 4
    outs = engine.predict(items)
    whole = np.concatenate([engine._costs(outs, s0, len(c), u, p) for s0, c, u, p in spans])
    np.testing.assert_allclose(partial, whole, rtol=1e-9)
