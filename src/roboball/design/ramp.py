"""A ramp diagnosis's experiments: the ramp's angle.

A descent's candidates differ in the speeds it reaches: a breakaway that fades with speed
(`stiction` with its width fitted) acts early, a rolling resistance at every speed, a viscous
loss grows with speed and a quadratic drag faster.  The rig sets the speeds by the ramp's angle
(its length is the user's: a longer ramp is another rig), so each candidate is simulated, from
rest at the release as the diagnosis runs it, on ramps of `ANGLES_DEG` and the user's angle,
seen through the recording's own average (roboball.diagnose.data.Window.observe) and counted
until the first candidate has rolled the user's ramp (the rolled angle of the user's runs: the
recording ends where the robot leaves the ramp).  An angle is feasible when the shell rolls off
its release for every candidate: where gravity alone asks more friction than the ground's cone
gives (mu N), it slides from the start, and the rate the recording holds is no longer the
rolling the models describe.

Refitted separation (as roboball.design.refit for the other kinds): each candidate B is fitted to
the user's runs together with the run candidate A predicts on that ramp, each run on its own ramp
(roboball.reduced.ramp.RampModel.window_values), and to the user's runs alone; the rise of its
residual per new sample, in noise levels, the smaller of both directions.  A parameter's two ends
keep that parameter (freed, B would simply become A).
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from roboball.design.experiments import SEED, Grid, predict, user_timing
from roboball.design.rank import SETTLES, scores
from roboball.diagnose.data import Prepared, Window
from roboball.diagnose.fit import Engine, Problem, effect_keys
from roboball.physics.mathns import scalar
from roboball.reduced import ramp_equations as eq

ANGLES_DEG = tuple(range(4, 31, 2))    # deg: the ramps considered besides the user's
LONGEST = 3.0           # the simulated run, in the user's run's durations (a shallow ramp takes longer)
SHORTLIST = 4           # runs refitted: the user's angle and the best three by the expected gap
MAX_ITER, RTOL = 40, 1e-6


def ramp_length(prep: Prepared) -> float:
    """The rolled angle (rad) of the user's runs from release to their ends: the ramp's length
    over the rolling radius (median over runs)."""
    return float(np.median([np.trapezoid(w.y, w.t - w.t0) for w in prep.windows]))


def angles(user_deg: float) -> np.ndarray:
    return np.array(sorted(set(float(a) for a in ANGLES_DEG) | {round(float(user_deg), 6)}))


def rolls_off(model) -> bool:
    """Whether the shell rolls (not slides) off its release: at rest no effect or friction acts,
    so the friction rolling needs is gravity's alone (roboball.reduced.ramp_equations)."""
    k = eq.constants(model)
    m = scalar()
    cba, sba, rhs_s, rhs_b = eq.terms(0.0, 0.0, 0.0, k, m)
    *_, f_req, normal = eq.rolling(cba, sba, rhs_s, rhs_b, 0.0, 0.0, k)
    return not eq.exceeds_cone(f_req, normal, k, m)


def _synthetic(prep: Prepared, t: np.ndarray) -> Prepared:
    """A run like the user's first (its sampling, its average), from the release at t = 0."""
    w0 = prep.windows[0]
    win = Window(index=0, t0=0.0, t=t.copy(), y=np.zeros_like(t), q0=0.0, release=w0.release, start="release",
                 smooth_s=w0.smooth_s)
    return Prepared(recording=prep.recording, kind=prep.kind, signal=prep.signal, unit=prep.unit, windows=[win],
                    noise=prep.noise, quantum=prep.quantum)


def grid(src, choice) -> Grid:
    """Every candidate of `choice` predicted on each ramp (module docstring); `Grid.releases` holds
    the angles (deg), `moving` the samples before the first candidate leaves the ramp."""
    dt, dur = user_timing(src.prep)
    t = np.arange(0.0, LONGEST * dur + 0.5 * dt, dt)
    synth = _synthetic(src.prep, t)
    degs = angles(src.setup["ramp_angle_deg"])
    length = ramp_length(src.prep)
    W, N = len(degs), len(t)
    central = {c.label: np.empty((W, N)) for c in choice.candidates}
    var = {c.label: np.empty((W, N)) for c in choice.candidates}
    feasible = np.ones(W, bool)
    on_ramp = np.ones((W, N), bool)
    for i, a in enumerate(degs):
        # the release's rolling asks gravity's friction alone: the same for every candidate
        feasible[i] = rolls_off(choice.candidates[0].model("ramp", ramp_angle_deg=a))
        for cand in choice.candidates:
            model = cand.model("ramp", ramp_angle_deg=a)
            y, v, _ = predict(cand, "ramp", synth, None, np.random.default_rng(SEED), model=model)
            central[cand.label][i], var[cand.label][i] = y[0], v[0]
            feasible[i] &= bool(np.all(np.isfinite(y[0])))
            rolled = np.concatenate([[0.0], np.cumsum(0.5 * (y[0][1:] + y[0][:-1]) * np.diff(t))])
            on_ramp[i] &= rolled <= length
    # a sample counts while every candidate is still on the ramp (the first to leave ends the run)
    moving = np.cumprod(on_ramp, axis=1).astype(bool)
    runaway = {c.label: np.zeros(W, bool) for c in choice.candidates}
    return Grid("", degs, t, central, var, feasible, moving, runaway)


def experiments(src, choice, g: Grid) -> list:
    """One run per feasible ramp angle, best (largest expected gap) first."""
    dt, _ = user_timing(src.prep)
    sc = scores(g, src.noise, float(g.t[-1]), factors=(1.0,))
    user = float(src.setup["ramp_angle_deg"])
    unit = src.prep.unit_key
    rows = []
    for w in np.nonzero(g.feasible)[0]:
        gap, sq, n = float(sc.gap[0, w]), float(sc.sq[0, w]), int(sc.n[0, w])
        rms = (sq / n) ** 0.5
        sep = (gap / n) ** 0.5
        rows.append({"kind": "ramp", "ramp_angle_deg": float(g.releases[w]), "users_angle": bool(g.releases[w] == round(user, 6)),
                     "recording_s": round(float(g.t[n - 1]), 3), "sample_interval_s": round(dt, 6),
                     "pressure_kpa": src.prep.recording.pressure_kpa,
                     "choice": choice.name, "candidates": [c.label for c in choice.candidates],
                     "closest_pair": list(sc.pair[0][w]), "separation": round(sep, 4), "refitted": False,
                     "separation_predicted": round(sep, 4), "separation_fixed_params": round(rms / src.noise, 4),
                     f"rms_difference_{unit}": round(rms, 6), "separation_vs_residual": round(rms / src.residual, 4),
                     "expected_chi2_gap": round(gap, 2), "settles": sep >= SETTLES})
    rows.sort(key=lambda r: -r["expected_chi2_gap"])
    return rows


def refit(src, choice, g: Grid, rows: list) -> list:
    """`rows` with the shortlist (the user's angle, then the best by the gap) refitted (module
    docstring): refitted first, by that separation, then the rest by the gap."""
    short = [r for r in rows if r["users_angle"]][:1]
    short += [r for r in rows if not r["users_angle"]][:SHORTLIST - len(short)]
    for r in short:
        sep = refit_gap(src, choice, g, int(np.argmin(np.abs(g.releases - r["ramp_angle_deg"]))))
        r.update(refitted=True, separation=round(sep, 4), settles=sep >= SETTLES,
                 separation_vs_residual=round(sep * src.noise / src.residual, 4))
    done = sorted((r for r in rows if r["refitted"]), key=lambda r: -r["separation"])
    return done + [r for r in rows if not r["refitted"]]


def refit_gap(src, choice, g: Grid, w: int) -> float:
    """The smaller over both directions of the rise of B's residual when the run A predicts on
    ramp w (its samples on the ramp) joins the user's runs, in noise levels per new sample."""
    mask = g.moving[w]
    n = max(int(mask.sum()), 1)
    best = math.inf
    for a in choice.candidates:
        prep = _joint(src, g, a.label, w)
        user = {x.index: np.ones(x.n, bool) for x in src.prep.windows}
        for b in choice.candidates:
            if b is a:
                continue
            model = b.model("ramp")
            engine = Engine(model, prep)
            # a parameter's two ends (the same effects) keep it: freed, B would simply become A
            free = [k for k in effect_keys(b.effects, model.held_params)
                    if not (a.effects == b.effects and a.values.get(k) != b.values.get(k))]
            probs = [Problem(effects=tuple(b.effects), values=dict(b.values), free=free, masks=m)
                     for m in (dict(user), {**user, len(user): mask})]
            engine.fit(probs, max_iter=MAX_ITER, rtol=RTOL, max_rejects=8)
            best = min(best, math.sqrt(max(probs[1].rss - probs[0].rss, 0.0) / n) / src.noise)
    return best


def _joint(src, g: Grid, truth: str, w: int) -> Prepared:
    """The user's runs, then the run `truth` predicts on ramp w, a run of its own ramp."""
    prep = src.prep
    rec = prep.recording
    rec = replace(rec, meta=dict(rec.meta, ramp_angle_deg=float(g.releases[w])))
    w0 = prep.windows[0]
    new = Window(index=len(prep.windows), t0=0.0, t=g.t.copy(), y=g.central[truth][w].copy(), q0=0.0,
                 release=w0.release, start="release", smooth_s=w0.smooth_s, source=rec)
    return Prepared(recording=prep.recording, kind=prep.kind, signal=prep.signal, unit=prep.unit,
                    windows=list(prep.windows) + [new], noise=prep.noise, quantum=prep.quantum,
                    sources=list(prep.sources))
