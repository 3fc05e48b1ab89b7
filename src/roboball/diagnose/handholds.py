"""The diagnosis's fallback release finder: the ends of a hand's holds (roboball.diagnose.data
uses it where roboball.ingest.releases finds no release followed by a decaying oscillation)."""
from __future__ import annotations

import numpy as np

from roboball.ingest.releases.record import Release
from roboball.ingest.releases.signal import prepare_signal

__all__ = ["hold_releases"]

TREMOR_GAP_S = 0.5      # s: the longest tremor excursion a hand hold is joined across
TREMOR_SHARE = 0.1      # of the record's range: how far a hand's tremor may take the body from its hold


def hold_releases(t, y, kind: str) -> list:
    """Fallback release finder: the ends of hand holds away from rest.

    roboball.ingest.releases accepts a release only when a DECAYING oscillation follows; a recording
    of an undamped body (a shell with no dissipation, exactly what the shell baseline is)
    has holds but no decay.  Here a release is the end of a stretch of at least 0.4 s in which
    the smoothed speed stays below 5% of the record's peak speed (and five noise levels),
    held more than 20 noise levels and 5% of the record's range away from its median."""
    try:
        sig = prepare_signal(t, y)
    except ValueError:
        return []
    tu, ys = sig.tu, sig.ys
    level = float(np.median(ys))
    span = float(np.ptp(ys))
    n_min = int(round(0.4 / sig.dt))
    runs = _through_tremor(_still_runs(sig), ys, int(round(TREMOR_GAP_S / sig.dt)),
                           max(5.0 * sig.sigma, TREMOR_SHARE * span))
    holds = []
    for a, b in runs:
        hold = float(np.median(ys[a:b]))
        if b - a >= n_min and b < len(ys) - n_min and abs(hold - level) > max(20.0 * sig.sigma, 0.05 * span):
            holds.append((a, b, hold))
    tol = 5.0 * sig.sigma
    pauses = [(a, b) for a, b in runs if b - a >= n_min]
    holds = _hands_holds(holds, ys, pauses, tol)
    out = []
    for i, (a, b, hold) in enumerate(holds):
        k_end = holds[i + 1][0] if i + 1 < len(holds) else len(ys) - 1
        seg = ys[b:k_end]
        rest = float(np.median(seg)) if len(seg) else level
        zc = _crossings(tu[b:k_end], seg - rest, 3.0 * sig.sigma)
        half = float(np.median(np.diff(zc))) if len(zc) > 2 else float("nan")
        if len(zc) <= 2:                # under 1.5 swings the segment's median is not the rest
            rest = _sat_at(ys, pauses, a, tol, rest)
        out.append(Release(t_release_s=float(tu[b - 1]), t_end_s=float(tu[k_end]), i_release=-1, i_end=-1,
                           y_release=hold, y_rest=rest, held_from_s=float(tu[a]), half_period_s=half,
                           noise=sig.sigma, kind=kind))
    return out


def _still_runs(sig) -> list:
    """The stretches [a, b) of the prepared signal slower than 5% of its peak speed (and five
    noise levels of the speed)."""
    vs = np.abs(sig.vs)
    peak = float(np.max(vs)) if len(vs) else 0.0
    still = vs < max(0.05 * peak, 5.0 * sig.sigma_v)
    runs, k = [], 0
    while k < len(still):
        if still[k]:
            j = k
            while j < len(still) and still[j]:
                j += 1
            runs.append((k, j))
            k = j
        else:
            k += 1
    return runs


def _hands_holds(holds: list, ys, pauses: list, tol: float) -> list:
    """The holds a hand lets the body go from.  In a short record the median is no rest: the
    stillness before the hand's first move then passes for a hold.  A hold whose body goes
    straight (no reversal, no pause) into the next hold was the start of a hand's move, not a
    release.  (A body that creeps to rest and is then moved on pauses there.)  And after the hold
    the hand lets go from, a body with its pendulum free and heavily damped creeps to rest in
    steps (the shell pauses at each of the pendulum's swings, 0.3-0.5 s, against the hand's hold
    of 0.8-1.5 s), which passed for further holds in the chain: the last step was taken for the
    release and the hand's hold for the start of its move.  So in a chain of holds each going
    straight into the next, the longest after the chain's first is the hand's, and the others
    are no holds."""
    def into_next(i: int) -> bool:
        b, a2 = holds[i][1], holds[i + 1][0]
        return _straight(ys[b:a2 + 1], tol) and not any(b < p and q < a2 for p, q in pauses)

    chosen, i = [], 0
    while i < len(holds):
        j = i
        while j + 1 < len(holds) and into_next(j):
            j += 1
        chosen.append(max(range(i + 1, j + 1), key=lambda m: holds[m][1] - holds[m][0]) if j > i else i)
        i = j + 1
    return [holds[m] for m in chosen]


def _crossings(t: np.ndarray, d: np.ndarray, band: float) -> np.ndarray:
    """The instants at which d changes sign, each counted once it is more than `band` past zero
    on the other side: a sample on the level itself (the median of an odd count is one) or noise
    about it made two crossings of one (the proposed 0.6 rad release of the design's closed loop,
    one swing in its window, then read as 1.5 swings about the swing's median)."""
    side = np.where(d > band, 1, np.where(d < -band, -1, 0))
    k = np.nonzero(side)[0]
    if len(k) < 2:
        return t[:0]
    flips = k[1:][np.diff(side[k]) != 0]
    return t[flips]


def _through_tremor(runs: list, ys, max_gap: int, band: float) -> list:
    """Still stretches [a, b) joined across the hand's tremor: a hand holds a body with a tremor
    of a few mrad at about 2 Hz, faster, after a small release, than 5% of the record's peak
    speed, which splits its hold into short still stretches.  Two stretches at most `max_gap`
    samples apart are one when the body stays within `band` of their joint median in between."""
    out = []
    for a, b in runs:
        if out and a - out[-1][1] <= max_gap:
            a0 = out[-1][0]
            if float(np.max(np.abs(ys[a0:b] - np.median(ys[a0:b])))) <= band:
                out[-1] = (a0, b)
                continue
        out.append((a, b))
    return out


def _sat_at(ys, pauses, a: int, tolerance: float, otherwise: float) -> float:
    """Where the body sat still before the hand's move (or moves, hold to hold) that ended in the
    hold starting at sample `a`: the level of the earliest pause in that straight chain; else
    `otherwise`."""
    level, end = otherwise, a
    for a2, b2 in reversed([p for p in pauses if p[1] <= a]):
        if not _straight(ys[b2:end + 1], tolerance):
            break
        level, end = float(np.median(ys[a2:b2])), a2
    return level


def _straight(y: np.ndarray, tolerance: float) -> bool:
    """True when y goes one way only: no step back against its net direction (nor past its end)
    of more than `tolerance`."""
    if len(y) < 2:
        return True
    u = y * (1.0 if y[-1] >= y[0] else -1.0)
    return float(np.max(np.maximum.accumulate(u) - u)) <= tolerance and float(np.max(u) - u[-1]) <= tolerance
