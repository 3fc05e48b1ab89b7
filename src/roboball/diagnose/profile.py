"""Profile-likelihood intervals of the magnitudes whose cost is rough: a joint's breakaway.

Why: the 95% intervals of roboball.diagnose.keep.KeepRule.ci95 are Wald intervals, the curvature
of the cost at the optimum the fit ended in.  A breakaway held in the creep band (a joint's
stiction, `restarts.rough`) acts only while the joint nearly sticks, and its cost is rough at the
scale of a stick event: the finite differences see a steep, narrow optimum where the cost over
the parameter's range is flat.  On the real steer-stand log the breakaway came out at 6.64 N m
with a Wald interval of [6.62, 6.65], while the same model refitted with it held anywhere from
0.13 to 20 N m fits within the 95% likelihood ratio (docs/diagnosis.md, Known limits).

The interval of such a magnitude is therefore the profile likelihood's.  The final model is
refitted with the magnitude held at each value of a grid (factors of the estimate around it, and a
geometric grid over the parameter's range up to its bound), every fit in one batch, and scored by
the likelihood ratio of keep.profile_excludes_zero,

    LR(x) = (RSS(x) - RSS_min) / (s^2 n / n_eff),

s^2 and n_eff as the Wald interval's (the residual's autocorrelation inflates the noise), RSS_min
the lowest of the estimate's and the held fits'.  The interval is the hull of the estimate and the
grid values with LR <= chi^2_1(0.95), each end moved towards the next value outside by linear
interpolation of LR; below the grid, zero is the fit without the effect.  A hull that reaches the
grid's last value reaches the parameter's bound: the data bound the magnitude from below only.
A held fit of a rough cost may end in a poorer local optimum than the profile's, so its RSS is an
upper bound of the profile's: the interval is at least as wide as the truth's.
"""
from __future__ import annotations

import math

import numpy as np

from roboball.diagnose.restarts import rough
from roboball.metrics import inflated_variance
from roboball.physics import effects as fx

Q95 = 3.841458820694124       # chi-square quantile, 1 degree of freedom, 95%
FACTORS = (0.5, 0.7, 0.85, 0.95, 1.05, 1.2, 1.4, 2.0)    # around the estimate
SPAN = 8                      # geometric grid from a tenth of the typical size to the bound


def rough_magnitudes(model, effects) -> list:
    """Keys of the magnitudes of `effects` whose cost is rough (a joint's breakaway: `rough`)."""
    return [f"stiction.{fx.LIBRARY['stiction'].params[0].name}"] if rough(model, effects) else []


def grid(x: float, lo: float, hi: float, typical: float) -> list:
    """Held values for the magnitude estimated at `x` within its bounds (lo, hi]: `FACTORS` of `x`
    and `SPAN` values from a tenth of `typical` to `hi`, the estimate itself left out."""
    near = [x * f for f in FACTORS]
    span = np.geomspace(max(0.1 * typical, 1e-9), hi, SPAN).tolist()
    return sorted({float(min(max(v, lo), hi)) for v in near + span if v > 0.0 and v != x})


def interval(points: list, x_hat: float, q: float = Q95) -> tuple:
    """The profile's interval from `points` [(value, LR)] (the estimate `x_hat` among them):
    (low, high, whether the high end is the last point's, i.e. the data do not bound it there)."""
    pts = sorted(points)
    xs = [x for x, _ in pts]
    inside = [i for i, (x, lr) in enumerate(pts) if lr <= q or x == x_hat]
    a, b = min(inside), max(inside)

    def towards(i, j):      # from the point inside, i, towards the one outside, j
        (xi, li), (xj, lj) = pts[i], pts[j]
        if not (lj > q > li):
            return xi
        return xi + (xj - xi) * (q - li) / (lj - li)
    low = towards(a, a - 1) if a > 0 else xs[0]
    high = towards(b, b + 1) if b < len(pts) - 1 else xs[-1]
    return low, high, b == len(pts) - 1


def profile(selector, sc, key: str) -> dict:
    """The profile of magnitude `key` of the fitted model `sc`: the held values, their RMS and LR,
    LR at zero (the fit without the effect, where known) and the interval (module docstring)."""
    effect, name = key.split(".")
    par = next(p for p in fx.LIBRARY[effect].params if p.name == name)
    x_hat = float(sc.values[key])
    xs = grid(x_hat, par.lo, par.hi, par.typical)
    probs = []
    for x in xs:
        p = selector.full_problem(sc.effects, {**sc.values, key: x})
        p.free = [k for k in p.free if k != key]
        probs.append(p)
    selector.engine.fit(probs, max_iter=selector.s.fit_iter)
    n, k = sc.full.n, sc.full.k
    scale = inflated_variance(sc.full.rss, n, k, sc.rho1)
    rss = [p.rss if math.isfinite(p.rss) else math.inf for p in probs]
    without = selector.fit_of(sc.key - {effect})
    rss_zero = without.full.rss if without is not None and without.full.n == n else None
    ref = min([sc.full.rss] + rss)
    points = [(x, (r - ref) / scale) for x, r in zip(xs, rss)] + [(x_hat, (sc.full.rss - ref) / scale)]
    if rss_zero is not None:
        points.append((0.0, (rss_zero - ref) / scale))
    low, high, open_high = interval(points, x_hat)
    best = min(zip(rss, xs))
    return {"values": xs, "rmse": [math.sqrt(r / n) for r in rss], "lr": [(r - ref) / scale for r in rss],
            "lr_estimate": (sc.full.rss - ref) / scale, "lr_zero": None if rss_zero is None else (rss_zero - ref) / scale,
            "q": Q95, "interval": [low, high], "bound": par.hi, "to_bound": bool(open_high and high >= par.hi),
            "lowest": {"value": best[1], "rmse": math.sqrt(best[0] / n)} if best[0] < sc.full.rss else None}


def profiled_ci95(selector, sc) -> tuple:
    """(`sc`'s 95% intervals with those of its rough magnitudes from their profiles, {key: profile})."""
    ci = selector.ci95(sc)
    profiles = {key: profile(selector, sc, key) for key in rough_magnitudes(selector.model, sc.effects)}
    for key, prof in profiles.items():
        ci[key] = tuple(prof["interval"])
    return ci, profiles
