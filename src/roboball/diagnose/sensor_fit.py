"""Whether a recording calls for a sensor lag, and the lag fitted inside the baseline.

The contract (../shared/specs/diagnosis.md): a sensor's own dynamics are not physics; they may
be fitted inside the baseline and listed under `baseline.fitted`, never reported as missing.
The operator is roboball.diagnose.sensor's first-order lag.  The criterion, both parts needed:

1. the signal is smooth (`smooth`): the windows are the recording's own samples (not a ramp's
   averaged trend), on no quantisation grid (a step below 1e-5: a float estimate, not an
   encoder's count), and the noise of their fresh samples about their neighbours (`fresh`,
   `sample_noise`) is below `SMOOTH_NOISE` = 0.2 mrad (or mrad/s), under the 0.29 mrad that
   the robot's 1 mrad encoder steps alone give (the test bed's raw sensors: 0.5 mrad; the real
   dynamic log: 0.11 mrad while it swings, 0.03 at rest).  Only an estimator or a filter makes
   such a signal, and only those lag.  A raw log keeps its diagnosis bit for bit: nothing here
   runs for it (the campaign's and the real steer log's diagnosis.json are unchanged);
2. the lag is supported: the model with the lag fitted (every release state refitted with it)
   lowers the BIC by more than the keep rule's `bic_min` (10, "very strong" evidence for one
   parameter more), the 95% interval of the lag excludes zero, and the lag stays below 90% of
   its 0.25 s bound (a lag run to its bound stands in for something else).

It is tried on the baseline first (`fit_sensor_lag`): when supported, the lagged baseline
replaces the plain one and the lag is fitted with everything after it.  A baseline that misses
much (a shell without dissipation) cannot show a lag: then it is tried on the models of the
first effects found (`run_with_sensor_lag`), and when supported there the selection runs again
with the lag starting at that value: held in the baseline (which cannot show it: freed, it runs
off, to 0.12 s, say) and fitted with everything else in every model with effects.  Held in
those too, the lag of a model of the first run's effects (40.5 ms where the test bed's was 45.8)
left a residual that a cubic stiffness took up beside the true Coulomb friction; fitted, it
comes back at 45.2 ms and the friction alone is found.  Either way it is reported under `baseline.fitted` as
`sensor_lag_s`, and the notes say what was decided and why.

A smooth estimate logged faster than it is updated repeats its last value (`without_stale`):
such repeats are left out of a smooth recording's windows.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from roboball.diagnose.scored import Scored
from roboball.diagnose.sensor import LAG_BOUNDS, LAG_KEY

SMOOTH_NOISE = 2e-4           # rad (rad/s): below the 0.29 mrad of a 1 mrad encoder step alone
UNQUANTISED = 1e-5            # rad (rad/s): a quantisation step finer than this is a float's
LAG_AT_BOUND = 0.9            # a lag fitted beyond this share of its bound stands in for something else
LAG_STARTS = (0.005, 0.01, 0.02, 0.035, 0.05, 0.07, 0.1, 0.15)   # s: grid of starting values


def sample_noise(t, y) -> float:
    """Noise level of recorded samples: the robust spread of each sample about the cubic through
    its two neighbours on either side, divided by the spread that noise alone gives that
    difference (sqrt(1 + the sum of the cubic's squared weights)).  Read on the raw samples at
    their own instants, a smooth signal's curvature adds only about u'''' h^4 / 6 (1e-6 rad for
    the stand's fastest swing at 100 Hz), where the release finder's estimate (about a fit on a
    resampled grid) carries the resampling's error of a fast swing, 1e-4 rad and more."""
    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    keep = np.concatenate([[True], np.diff(t) > 0])
    t, y = t[keep], y[keep]
    if len(t) < 5:
        return float("inf")
    nb = np.stack([t[:-4], t[1:-3], t[3:-1], t[4:]])      # the neighbours of samples 2 .. n-3
    x = t[2:-2]
    w = np.ones_like(nb)
    for j in range(4):
        for k in range(4):
            if k != j:
                w[j] *= (x - nb[k]) / (nb[j] - nb[k])
    ys = np.stack([y[:-4], y[1:-3], y[3:-1], y[4:]])
    r = (y[2:-2] - np.sum(w * ys, axis=0)) / np.sqrt(1.0 + np.sum(w * w, axis=0))
    return float(1.4826 * np.median(np.abs(r - np.median(r))))


def fresh(y) -> np.ndarray:
    """Samples that do not repeat their predecessor exactly.  A float estimate never repeats
    itself while the body moves; an estimator logged faster than it updates does (every fifth
    sample of the real dynamic log): the repeat carries the earlier instant's value under a later
    stamp, up to 4 mrad off where the shell moves fastest."""
    return np.concatenate([[True], np.diff(y) != 0])


def recorded_noise(prep) -> float:
    """The noise level of the windows' fresh samples (median over the windows of sample_noise)."""
    return float(np.median([sample_noise(w.t[fresh(w.y)], w.y[fresh(w.y)]) for w in prep.windows]))


def smooth(prep) -> bool:
    """Part 1 of the criterion (module docstring): the recording's own samples (not a ramp's
    averaged trend), on no quantisation grid, with a noise level below SMOOTH_NOISE."""
    if any(w.smooth_s for w in prep.windows) or prep.quantum >= UNQUANTISED:
        return False
    return recorded_noise(prep) < SMOOTH_NOISE


def without_stale(prep):
    """A smooth recording (`smooth`) without its stale samples (`fresh`), which no model of the
    body can follow; any other recording as it is (the same object)."""
    if not smooth(prep):
        return prep
    keep = [fresh(w.y) for w in prep.windows]
    dropped = sum(int(np.sum(~k)) for k in keep)
    if not dropped:
        return prep
    windows = [replace(w, t=w.t[k], y=w.y[k]) for w, k in zip(prep.windows, keep)]
    notes = prep.notes + [f"{dropped} samples that repeat the one before exactly were left out (a smooth "
                          "estimate logged faster than it is updated: the repeat is an earlier value)"]
    return replace(prep, windows=windows, notes=notes)


def _start(selector, values: dict) -> dict:
    """The best of the grid of lags, each with the release instants moved earlier by the lag (a
    lagged recording's swings run late by about tau: the baseline without lag fitted that)."""
    eng = selector.engine
    cands = []
    for tau in LAG_STARTS:
        v = dict(values, **{LAG_KEY: tau})
        for w in selector.prep.windows:
            key = f"ts@{w.index}"
            if key in v:
                _, lo, hi = eng.info[key]
                v[key] = float(np.clip(v[key] - tau, lo, hi))
        cands.append(v)
    wins = [w.index for w in selector.prep.windows]
    outs = eng.predict([(v, w) for v in cands for w in wins])
    costs = [sum(float(np.sum((outs[i * len(wins) + j][0] - eng.windows[w].y) ** 2)) for j, w in enumerate(wins))
             for i in range(len(cands))]
    return cands[int(np.argmin(costs))]


def _with_lag(selector, model: Scored, where: str):
    """`model` (the baseline, or the selection's final model) refitted with the sensor's lag free
    and scored against itself; returns it when the lag is supported (criterion part 2), else
    None.  The prep's notes say which, and why."""
    eng, prep = selector.engine, selector.prep
    eng.sensor, eng.sensor_free = {LAG_KEY: 0.0}, [LAG_KEY]
    lagged = Scored(effects=model.effects, full=selector.full_problem(model.effects, _start(selector, model.values)))
    selector.cross_validate([lagged], cofit=True)
    selector.score(lagged, model)
    lo, hi = selector.ci95(lagged)[LAG_KEY]
    tau = lagged.values[LAG_KEY]
    said = (f"the signal is smooth (noise {recorded_noise(prep):.2g} {prep.unit}, below {SMOOTH_NOISE:g}: an "
            f"estimator's or a filter's output); a first-order sensor lag fitted with {where} gives tau = "
            f"{tau * 1e3:.4g} ms (95% {lo * 1e3:.4g} to {hi * 1e3:.4g} ms), delta BIC {lagged.delta_bic:.1f}")
    if lagged.delta_bic < -selector.s.bic_min and lo > LAG_BOUNDS[0] and tau < LAG_AT_BOUND * LAG_BOUNDS[1]:
        prep.notes.append(said + f": kept as {LAG_KEY} inside the baseline (the sensor's dynamics, not physics)")
        eng.sensor = {LAG_KEY: tau}         # every later fit starts from it (or holds it)
        selector.log(f"sensor lag: {tau * 1e3:.4g} ms kept (dBIC {lagged.delta_bic:.1f})")
        return lagged
    prep.notes.append(said + ": not supported, no lag fitted")
    eng.sensor, eng.sensor_free = {}, []
    return None


def fit_sensor_lag(selector, base: Scored) -> Scored:
    """Step 1 (the baseline): the baseline with the sensor's lag fitted in it when the recording
    calls for it (module docstring), else `base` unchanged.  `selector`: the
    roboball.diagnose.select.Selector whose engine, problems and keep-rule statistics are used;
    a lag already set on its engine (by `run_with_sensor_lag`) is kept as it is."""
    if selector.engine.sensor or not smooth(selector.prep):
        return base
    return _with_lag(selector, base, "the baseline") or base


def _prefix(selector, d, k: int) -> Scored:
    """The model of the selection's first `k` effects (in the order they were kept), refitted
    from the final model's values (without the sensor's lag)."""
    effects = tuple(d.chosen[:k])
    if effects == tuple(d.final.effects):
        return d.final
    values = {key: v for key, v in d.final.values.items()
              if "." not in key or key.split(".")[0] in effects}
    sc = Scored(effects=effects, full=selector.full_problem(effects, values))
    selector.engine.fit([sc.full], max_iter=selector.s.fit_iter)
    return sc


def run_with_sensor_lag(selector):
    """The selection (`selector.run()`), and step 2: where the recording is smooth but the baseline
    missed too much for the lag to show (a shell baseline without dissipation), the lag is tried
    on the models of the first one, two, ... effects kept (a later effect may be the one standing
    in for the lag: a cubic stiffness, on a long swing); when it is supported, the selection runs
    again with the lag inside the baseline from the start, so that no effect stands in for it:
    held at that value in the baseline, fitted from it in every model with effects (module
    docstring).  Returns the Diagnosis."""
    d = selector.run()
    if selector.engine.sensor or not d.chosen or not smooth(selector.prep):
        return d
    for k in range(1, len(d.chosen) + 1):
        if _with_lag(selector, _prefix(selector, d, k), "the first effects found (" + ", ".join(d.chosen[:k]) + ")"):
            break
    else:
        return d
    again = type(selector)(selector.prep, model=selector.model, settings=selector.s, log=selector.log)
    again.engine.sensor = dict(selector.engine.sensor)
    again.engine.sensor_free = list(selector.engine.sensor_free)
    again.baseline_holds_sensor = True
    return again.run()
