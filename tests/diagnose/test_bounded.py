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
