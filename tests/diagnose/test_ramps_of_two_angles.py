"""Ramp runs on ramps of different angles diagnosed together (what `roboball design` proposes
for a ramp diagnosis: a run on another ramp beside the user's): each run is simulated on its own
ramp, in the reduced models (RampModel.window_values, per batch row) and in the report's Drake
runs (one diagram per angle)."""
import json
import shutil

import numpy as np

from roboball.diagnose.data import pool, prepare, read
from roboball.diagnose.fit import Engine, Problem
from roboball.reduced.ramp import RampModel

from conftest import REPO

RUN = REPO / "raw_data" / "ramp" / "ramp_10.3kpa_r1.csv"
TRUTH = {"stiction.tau_s": 4.5, "stiction.v_s": 2.9, "quadratic_drag.c2": 0.02}


def _on_ramp(tmp_path, name, angle):
    """The campaign run's samples as a recording made on a ramp of `angle` deg."""
    csv = tmp_path / f"{name}.csv"
    shutil.copy(RUN, csv)
    meta = json.loads(RUN.with_suffix(".json").read_text())
    meta["ramp_angle_deg"] = angle
    csv.with_suffix(".json").write_text(json.dumps(meta))
    return prepare(read(csv))


def test_each_row_runs_on_its_own_ramp_in_both_loops():
    model = RampModel(ramp_angle_deg=16.0)
    B = 6
    P = {k: np.full(B, v) for k, v in TRUTH.items()}
    P["ramp_angle_rad"] = np.radians([16.0, 6.0, 24.0, 16.0, 10.0, 6.0])
    model.compiled = False
    Yn, _ = model.simulate(np.zeros(B), P, 1200)
    model.compiled = True
    Yc, _ = model.simulate(np.zeros(B), P, 1200)
    assert np.max(np.abs(Yc - Yn)) < 1e-9
    for j, a in enumerate((16.0, 6.0, 24.0)):
        alone = RampModel(ramp_angle_deg=a).simulate(np.zeros(1), {k: np.array([v]) for k, v in TRUTH.items()}, 1200)[0]
        assert np.array_equal(Yc[:, j], alone[:, 0])          # the row is that ramp's run, to the bit
    assert Yc[-1, 2] > Yc[-1, 0] > Yc[-1, 1]                  # steeper is faster


def test_runs_on_two_ramps_are_pooled_and_fitted_together(tmp_path):
    """A run the reduced model makes on 16 deg and one on 6 deg, pooled: the fit recovers the
    breakaway and the drag from both."""
    preps = [_on_ramp(tmp_path, "steep", 16.0), _on_ramp(tmp_path, "shallow", 6.0)]
    prep = pool(preps)
    assert any("ramps of 6, 16 deg" in n for n in prep.notes)
    model = RampModel(ramp_angle_deg=16.0)
    engine = Engine(model, prep)
    assert [engine.window_values[w.index]["ramp_angle_rad"] for w in prep.windows] == list(np.radians([16.0, 6.0]))
    out = engine.predict([(dict(TRUTH), w.index) for w in prep.windows])
    for w, (y, _) in zip(prep.windows, out):
        w.y = y.copy()                      # noise-free runs of the truth, each on its ramp
    assert out[0][0].max() > 1.5 * out[1][0].max()
    start = {"stiction.tau_s": 3.0, "stiction.v_s": 2.0, "quadratic_drag.c2": 0.03}
    prob = Problem(effects=("stiction", "quadratic_drag"), values=start, free=list(TRUTH),
                   masks={w.index: np.ones(w.n, bool) for w in prep.windows})
    engine.fit([prob], max_iter=80, rtol=1e-10)
    for k, v in TRUTH.items():
        assert abs(prob.values[k] / v - 1) < 0.01, (k, prob.values[k])


def test_the_report_runs_each_window_on_its_own_ramp_in_drake(tmp_path, monkeypatch):
    from roboball.diagnose import drake

    prep = pool([_on_ramp(tmp_path, "steep", 16.0), _on_ramp(tmp_path, "shallow", 6.0),
                 _on_ramp(tmp_path, "again", 16.0)])
    built = []
    real_build = drake.build

    def build(spec, **kw):
        built.append(spec.ramp_angle_deg)
        return real_build(spec, **kw)
    monkeypatch.setattr(drake, "build", build)
    out = drake.simulate_windows(prep, RampModel(ramp_angle_deg=16.0), {}, ())
    assert built == [16.0, 6.0]                                # one diagram per angle
    assert np.max(out[0]) > 1.5 * np.max(out[1]) and np.allclose(out[0], out[2])
