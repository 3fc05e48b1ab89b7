"""Hinge fits: the precise instant where motion starts (step 5 of roboball.ingest.releases, and
the ramp's start of motion)."""
from __future__ import annotations

import numpy as np

__all__ = ["hinge_fit"]


def hinge_fit(t: np.ndarray, y: np.ndarray, t_lo: float, t_hi: float, powers: tuple[int, ...],
               pre_slope: bool) -> tuple[float, np.ndarray]:
    """Least-squares hinge: y = c0 [+ c1 tau] + sum_k c_k max(tau, 0)^p_k, tau = t - t_r.
    Scans t_r over [t_lo, t_hi] (fine grid, then a local parabola) and returns
    (t_r, coefficients)."""
    if len(t) < 6 or t_hi <= t_lo:
        return 0.5 * (t_lo + t_hi), np.array([float(np.mean(y)) if len(y) else 0.0])
    span = max(t[-1] - t[0], 1e-9)
    step = min(0.002, (t_hi - t_lo) / 20.0)
    grid = np.arange(t_lo, t_hi + 0.5 * step, step)
    best = (np.inf, None, None)
    sses = np.empty(len(grid))
    for g, tr in enumerate(grid):
        tau = (t - tr) / span
        taup = np.maximum(tau, 0.0)
        cols = [np.ones_like(tau)]
        if pre_slope:
            cols.append(tau)
        cols += [taup ** p for p in powers]
        A = np.column_stack(cols)
        coef, *_ = np.linalg.lstsq(A, y, rcond=None)
        r = y - A @ coef
        sse = float(r @ r)
        sses[g] = sse
        if sse < best[0]:
            best = (sse, tr, coef)
    g = int(np.argmin(sses))
    tr = best[1]
    if 0 < g < len(grid) - 1:
        s0, s1, s2 = sses[g - 1], sses[g], sses[g + 1]
        den = s0 - 2 * s1 + s2
        if den > 0:
            tr = grid[g] + 0.5 * step * (s0 - s2) / den
    return float(tr), best[2]
