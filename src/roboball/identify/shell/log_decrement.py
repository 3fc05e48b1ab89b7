"""The logarithmic decrement: damping from the turning points of a free response, the classic
cross-check of a fitted damping ratio (roboball.identify.shell.decay)."""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

__all__ = ["refine_extrema", "log_decrement_zeta"]


def refine_extrema(t: np.ndarray, y: np.ndarray, t_guess: Sequence[float], half_width: float) -> list[tuple[float, float]]:
    """Refine turning points: fit a parabola to the raw samples within +-half_width of
    each guessed time and return its vertex (t, y); guesses without a proper vertex in the
    window are skipped."""
    out = []
    for tg in t_guess:
        m = (t >= tg - half_width) & (t <= tg + half_width)
        if m.sum() < 5:
            continue
        tt = t[m] - tg
        a, b, c = np.polyfit(tt, y[m], 2)
        if a == 0:
            continue
        tv = -b / (2 * a)
        if abs(tv) > half_width:
            continue
        out.append((float(tg + tv), float(c - b * b / (4 * a))))
    return out


def log_decrement_zeta(extrema_values: Sequence[float]) -> float:
    """Damping ratio from successive turning points by the logarithmic decrement.

    Uses peak-to-peak swings h_k = |E_{k+1} - E_k| (independent of the rest level); for a
    viscous oscillator they shrink by exp(-delta/2) per half cycle.  delta is the slope of a
    least-squares line through ln h_k, and zeta = delta / sqrt(4 pi^2 + delta^2).
    Needs at least three turning points; returns NaN otherwise."""
    e = np.asarray(extrema_values, dtype=float)
    if len(e) < 3:
        return float("nan")
    h = np.abs(np.diff(e))
    if np.any(h <= 0):
        return float("nan")
    k = np.arange(len(h))
    slope = np.polyfit(k, np.log(h), 1)[0]
    delta = -2.0 * slope
    return float(delta / math.sqrt(4 * math.pi ** 2 + delta ** 2))
