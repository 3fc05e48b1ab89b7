"""Restarts of the fits whose cost is rough: a joint's breakaway.

A stiction held in the creep band (a joint's: `stiction.v_s` in the model's held parameters) acts
only while the joint nearly sticks, so each stick event's end moves by whole steps as the
parameters change and the cost is rough at that scale.  Levenberg-Marquardt then stops where the
finite differences find no descent, and which optimum a Coulomb friction + stiction fit ends in
follows the path to it, down to the recording's last bits: moving every sample by a part in 10^12
sent such fits of the blind benchmark 1-4 half-widths of their 95% intervals away
(benchmarks/diagnose_last_bits.py), and from starts a little way off a fit stuck at 0.0041 rad RMS
reached the noise level, 0.0006 rad (docs/diagnosis.md, Known limits).

So before such a model is judged, it is refitted from a fixed design of starts around its
screening fit, the dry friction scaled (the breakaway x0.5 and x1.25, the Coulomb friction x0.9
and x1.1) and the joint's viscous coefficient x1 and x1.2, besides its own values, and the lowest
cost found is kept.  Models without such a breakaway (every shell and ramp model: their
breakaway's width is fitted, and smooth) are not touched.
"""
from __future__ import annotations

import itertools
import math

import numpy as np

# (parameter, factors) of the design; a parameter the model lacks is left as it is
DESIGN = (("stiction.tau_s", (0.5, 1.25)), ("coulomb_friction.tau_c", (0.9, 1.1)), ("viscous_c", (1.0, 1.2)))


def rough(model, effects) -> bool:
    """Whether a model with `effects` holds a breakaway in the creep band (a joint's stiction)."""
    return "stiction" in effects and "stiction.v_s" in model.held_params


def starts(values: dict, info: dict) -> list:
    """The design's starts around `values` (each factor of each parameter it has, within the
    parameter's bounds `info[key] = (typical, lo, hi)`), then `values` themselves."""
    keys = [(k, f) for k, f in DESIGN if k in values]
    out = []
    for factors in itertools.product(*(f for _, f in keys)):
        v = dict(values)
        for (k, _), x in zip(keys, factors):
            _, lo, hi = info[k]
            v[k] = float(np.clip(values[k] * x, lo, hi))
        out.append(v)
    return out + [dict(values)]


def restart_rough_fits(selector, models: list) -> None:
    """Refit every model of `models` that `rough` from `starts` (one batched fit) and keep its
    lowest cost: `Scored.full` is replaced where a start ends lower than the model's fit."""
    todo = [sc for sc in models if rough(selector.model, sc.effects)]
    if not todo:
        return
    trials = [(sc, selector.full_problem(sc.effects, v)) for sc in todo
              for v in starts(sc.values, selector.engine.info)]
    selector.engine.fit([p for _, p in trials], max_iter=selector.s.fit_iter)
    for sc in todo:
        fits = [p for s, p in trials if s is sc and math.isfinite(p.rss)]
        best = min(fits, key=lambda p: p.rss, default=None)
        if best is not None and best.rss < sc.full.rss:
            selector.log(f"   {'+'.join(sc.effects)} restarted: rms {sc.rmse:.4g} -> "
                         f"{math.sqrt(best.rss / max(best.n, 1)):.4g}")
            sc.full = best
