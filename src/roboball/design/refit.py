"""The expected gap with the candidates refitted: what diagnosing the user's recording and the
new one together would show.

The ranking (roboball.design.rank) compares the candidates at the values fitted to the user's
log; diagnosed together with a new recording, each candidate is refitted to both, and a
difference its parameters can absorb (a slightly larger Coulomb friction that stops the swing
where the other candidate's does) is no evidence.  So for the shortlisted experiments each
candidate B is fitted, by the diagnosis's own Levenberg-Marquardt (roboball.diagnose.fit), to the
user's log together with the recording candidate A predicts (noise-free, its release state
free as in a diagnosis), and to the user's log alone from the same start.  The rise of B's
residual sum of squares is the gap the new recording adds when A is true:

    refit separation = sqrt((RSS_B(user + new) - RSS_B(user)) / n_new) / sigma

in the log's noise levels, the smaller of the two directions (A true, B true).
"""
from __future__ import annotations

import numpy as np

from roboball.diagnose.data import Prepared, Window
from roboball.diagnose.fit import Engine, Problem, effect_keys
from roboball.diagnose.sensor import LAG_KEY

MAX_ITER = 40
# the user's log holds most of the residual: the fit's usual relative stopping tolerance (1e-3)
# stops it before the new window's share has moved, so it is tightened here
RTOL = 1e-6


def _joint(src, g, truth: str, ws: list, durations: list) -> Prepared:
    """The user's windows, then one window per shortlisted release holding what `truth` predicts."""
    prep = src.prep
    wins = list(prep.windows)
    for w, d in zip(ws, durations):
        keep = g.t <= d + 1e-9
        t = g.t[keep]
        wins.append(Window(index=len(wins), t0=0.0, t=t.copy(), y=g.central[truth][w][keep].copy(),
                           q0=float(g.releases[w]), release=prep.windows[0].release, start="release"))
    return Prepared(recording=prep.recording, kind=prep.kind, signal=prep.signal, unit=prep.unit, windows=wins,
                    noise=prep.noise, quantum=prep.quantum)


def _problems(engine: Engine, cand, prep: Prepared, n_user: int, masks_new: list) -> list:
    model = engine.model
    values = dict(cand.values)
    for w in prep.windows[n_user:]:
        values[f"q0@{w.index}"] = w.q0
        values[f"ts@{w.index}"] = 0.0
    # the pendulum's release state: a new window's starts at rest on its joint, and so does a user
    # window's where the candidate was fitted with the joint locked (an effect's candidates simulated
    # with the pendulum free, roboball.design.plan.steer_settings); it is fitted either way
    for w in prep.windows:
        for h in model.hidden_release:
            key = f"{h.name}@{w.index}"
            if w.index >= n_user or key not in values:
                values[key] = model.steer_rest if h.name == "steer_angle" else 0.0
    held = {k: engine.defaults[k] for k in effect_keys(cand.effects) if k in model.held_params}
    values.update(held)
    sensor = [LAG_KEY] if LAG_KEY in values else []
    # the breakaway is held: it acts only in the creep band, at rest, which the new window does
    # not count (experiments.moving), and at the size a stand's log gives it (5 N m on the
    # real one) its finite-difference slope leaves Levenberg-Marquardt no step
    base = [b.name for b in model.base_params] + sensor + [k for k in effect_keys(cand.effects, model.held_params)
                                                          if not k.startswith("stiction.")]
    user = {w.index: np.ones(w.n, bool) for w in prep.windows[:n_user]}
    probs = [Problem(effects=tuple(cand.effects), values=dict(values), masks=dict(user),
                     free=base + engine.release_keys(list(user)))]
    for j, m in enumerate(masks_new):
        idx = n_user + j
        masks = {**user, idx: m}
        probs.append(Problem(effects=tuple(cand.effects), values=dict(values), masks=masks,
                             free=base + engine.release_keys(list(masks))))
    return probs


def refit_gaps(src, choice, g, shortlist: list) -> list:
    """For each shortlisted experiment (a dict with `release_rad` of one release and `settle_s`),
    the refit separation of the closest pair (module docstring), in noise levels."""
    ws = [int(np.argmin(np.abs(g.releases - r["release_rad"][0]))) for r in shortlist]
    durations = [r["settle_s"] for r in shortlist]
    masks_new = [g.moving[w][g.t <= d + 1e-9] for w, d in zip(ws, durations)]
    n_user = len(src.prep.windows)
    best = [np.inf] * len(shortlist)
    labels = {c.label: c for c in choice.candidates}
    for truth in labels:
        prep = _joint(src, g, truth, ws, durations)
        for other, cand in labels.items():
            if other == truth:
                continue
            model = cand.model(src.kind, g.steer_joint or None)
            engine = Engine(model, prep)
            if LAG_KEY in cand.values:
                engine.sensor = {LAG_KEY: cand.values[LAG_KEY]}
            probs = _problems(engine, cand, prep, n_user, masks_new)
            engine.fit(probs, max_iter=MAX_ITER, rtol=RTOL, max_rejects=8)
            for j, p in enumerate(probs[1:]):
                rise = max(p.rss - probs[0].rss, 0.0)
                sep = float(np.sqrt(rise / max(masks_new[j].sum(), 1)) / src.noise)
                best[j] = min(best[j], sep)
    return best
