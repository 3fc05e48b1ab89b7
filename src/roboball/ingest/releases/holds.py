"""Hand holds: stretches where the body is held still, told apart from the turning points of a
free swing by how long they stay slow (step 3 of roboball.ingest.releases)."""
from __future__ import annotations

import math

import numpy as np

from roboball.ingest.releases.signal import PreparedSignal

__all__ = ["velocity_threshold", "hold_around", "long_enough", "is_hold", "holds_inside_swings"]


def velocity_threshold(sig: PreparedSignal, amplitude: float, omega: float, frac: float) -> float:
    """Speed below which the body counts as held: a fraction of the free swing's peak speed
    (amplitude * omega), but at least 4x the noise of the smoothed velocity."""
    return max(frac * abs(amplitude) * omega, 4.0 * sig.sigma_v)


def hold_around(sig: PreparedSignal, k_from: int, k_to: int, k_floor: int, v_thr: float) -> tuple[int, int]:
    """The hold that ends where the body starts its swing towards the turning point at
    `k_to`: returns grid indices (s, c) of the last stretch with |velocity| <= v_thr before
    the fastest point of that swing, searching forward from `k_from` and back to `k_floor`."""
    vs = sig.vs
    k_fast = k_from + int(np.argmax(np.abs(vs[k_from:k_to + 1])))
    slow = np.nonzero(np.abs(vs[k_from:k_fast + 1]) <= v_thr)[0]
    if not slow.size:
        return k_from, k_from  # never slow: no hold
    c = k_from + int(slow[-1])
    fast_before = np.nonzero(np.abs(vs[k_floor:c + 1]) > v_thr)[0]
    s = k_floor + (int(fast_before[-1]) + 1 if fast_before.size else 0)
    return min(s, c), c


def long_enough(held: float, v_thr: float, amplitude: float, omega: float, min_hold_s: float) -> bool:
    """A free swing of `amplitude` and `omega` is slower than v_thr for only
    2 asin(v_thr / (A omega)) / omega around a turning point; a hold must last clearly longer."""
    x = min(v_thr / max(abs(amplitude) * omega, 1e-300), 1.0)
    t_free = 2.0 * math.asin(x) / omega
    return held >= max(min_hold_s, 2.5 * t_free)


def is_hold(sig: PreparedSignal, ext: np.ndarray, m: int, omega: float, amplitude: float,
             min_hold_s: float, hold_speed: float) -> bool:
    """Is turning point m held still (slow for longer than `min_hold_s` and than the turning
    point of a free swing of `omega` and `amplitude` could be)?"""
    k_prev = ext[m - 1] if m > 0 else 0
    k_next = ext[m + 1] if m + 1 < len(ext) else len(sig.ys) - 1
    v_thr = velocity_threshold(sig, amplitude, omega, hold_speed)
    s, c = hold_around(sig, ext[m], k_next, k_prev, v_thr)
    return long_enough(sig.tu[c] - sig.tu[s], v_thr, amplitude, omega, min_hold_s)


def holds_inside_swings(sig: PreparedSignal, ext: np.ndarray, min_hold_s: float,
                         hold_speed: float) -> tuple[np.ndarray, set]:
    """`ext` with the holds that lie inside a monotone stretch added as pairs of turning points
    (the hold's first and middle still sample), and the positions in the result of those
    holds' first samples: a motion ends there, and no release starts there.  A hand that
    catches a swing near its extreme, lowers the body towards rest, holds it there and lets go
    makes no turning point at that hold: the release swing goes on the way the hand moved.
    A free swing is slow only at its turning points, so a still stretch (slower than
    `hold_speed` of the stretch's peak speed, and than 4 noise levels of the velocity, for at
    least `min_hold_s`) with fast motion on both sides, each moving the body by more than 4
    hysteresis steps, is a hold."""
    vs, dt = sig.vs, sig.dt
    n_hold = max(int(math.ceil(min_hold_s / dt)), 2)
    out: list[int] = []
    starts: set = set()
    for a, b in zip(ext[:-1], ext[1:]):
        out.append(int(a))
        if b - a < n_hold + 2:
            continue
        v = np.abs(vs[a:b + 1])
        thr = max(hold_speed * float(np.max(v)), 4.0 * sig.sigma_v)
        fast = np.nonzero(v > thr)[0]
        if fast.size < 2:
            continue
        gaps = np.diff(fast)
        g = int(np.argmax(gaps))
        if gaps[g] - 1 >= n_hold:                 # the longest still stretch, fast on both sides
            first, last_still = int(a + fast[g] + 1), int(a + fast[g + 1] - 1)
            # A hand's move into the hold and a release swing out of it: both travel clearly
            # further than the noise (a body at rest jitters through tiny monotone stretches).
            moves = (abs(sig.ys[first] - sig.ys[a]), abs(sig.ys[b] - sig.ys[last_still]))
            if min(moves) < 4.0 * sig.hysteresis:
                continue
            starts.add(len(out))
            out += [first, (first + last_still) // 2]   # a release's search for its hold starts inside it
    if len(ext):
        out.append(int(ext[-1]))
    return np.asarray(out, dtype=int), starts
