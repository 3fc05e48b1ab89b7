"""Where a free oscillation comes to rest: the level it settles at, or the level extrapolated from
the decay of its turning points (step 3 of roboball.ingest.releases)."""
from __future__ import annotations

import numpy as np
from scipy.ndimage import maximum_filter1d, minimum_filter1d

from roboball.ingest.releases.signal import PreparedSignal

__all__ = ["rest_estimate", "settled_level"]


def rest_estimate(ext_vals: np.ndarray) -> float:
    """Rest level of a decaying oscillation from its turning points E_k.

    Successive turning points lie on opposite sides of rest R with E_{k+1} - R =
    -r (E_k - R), r being the decay ratio per half cycle (the median ratio of successive
    peak-to-peak swings), so every pair gives R = (E_{k+1} + r E_k) / (1 + r); the median
    over all pairs is robust to noise and to a changing ratio (dry friction)."""
    e = np.asarray(ext_vals, dtype=float)
    if len(e) < 2:
        return float(e[-1])
    p2p = np.abs(np.diff(e))
    if len(p2p) >= 2 and np.all(p2p[:-1] > 0):
        r = float(np.median(p2p[1:] / p2p[:-1]))
        r = min(max(r, 0.05), 1.0)
    else:
        r = 1.0
    return float(np.median((e[1:] + r * e[:-1]) / (1.0 + r)))


def settled_level(sig: PreparedSignal, k_from: int, half_period: float, lo: float, hi: float) -> float | None:
    """Level at which the body comes to rest after grid index `k_from`: the mean of the
    first still stretch (0.5 s with a spread of at most 3 hysteresis steps, averaged over up
    to 3 s) that starts within 1.5 half periods, if that level lies in [lo, hi]; else None."""
    ys, h = sig.ys, sig.hysteresis
    settle_n = max(int(round(0.5 / sig.dt)), 1)
    tail = ys[k_from:k_from + int(1.5 * half_period / sig.dt) + 2 * settle_n + int(3.0 / sig.dt)]
    if len(tail) <= settle_n:
        return None
    half_w = settle_n // 2
    spread = (maximum_filter1d(tail, settle_n, mode="nearest")
              - minimum_filter1d(tail, settle_n, mode="nearest"))[half_w:len(tail) - half_w]
    still = np.nonzero(spread <= 3 * h)[0]
    if not still.size or still[0] * sig.dt > 1.5 * half_period:
        return None
    i0 = int(still[0])
    moving = np.nonzero(spread[i0:] > 3 * h)[0]
    i1 = i0 + (int(moving[0]) if moving.size else len(spread) - i0) + settle_n - 1
    i1 = min(i1, i0 + int(3.0 / sig.dt), len(tail))
    level = float(np.mean(tail[i0:i1]))
    return level if lo <= level <= hi else None
