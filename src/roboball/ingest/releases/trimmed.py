"""Trimmed logs: a record that starts at (or a few samples after) the let-go, with no hold before
it, has its release at its first sample (recordings.md, Releases; step 3 of
roboball.ingest.releases).

Such a record shows no hold to find: its first sample is already on the way to rest.  What tells
it from a record cut anywhere in a free oscillation is where the cut lies in the swing.  Released
from rest at offset A, the body is at A cos(phi) with speed A omega sin(phi) at the phase
phi = omega tau after the let-go, so the start's speed over its distance from rest times omega is
tan(phi): small a few samples after the let-go, large for a record cut later in the half swing
(damping changes this little so early in the swing, unlike a comparison with the swing's peak
speed).  A record cut after the rest crossing starts on the far side of rest from where it
swings next, which the swing checks (roboball.ingest.releases.oscillation) already refuse.  The
start's speed is measured on the raw samples: the smoothed velocity's Savitzky-Golay window is
cut off at the record's first sample and extrapolates there.
"""
from __future__ import annotations

import numpy as np

from roboball.ingest.releases.signal import PreparedSignal

__all__ = ["starts_released"]

START_S = 0.05            # s: the first turning point lies this close to the first sample, and the
#                           start's speed is the slope of the raw samples over this long (>= 3 samples)
MAX_TAN_PHASE = 1.0       # tan of the latest phase after the let-go a record may start at: within
#                           an eighth of a period (45 deg)
MIN_SHARE = 0.25          # the start's offset from rest, as a fraction of the record's range: a
#                           record that starts while a hand holds the body has the hand's tremor
#                           swing about the hold (a few mrad in the real shell log), no release


def starts_released(sig: PreparedSignal, k0: int, k1: int, offset: float, omega: float) -> bool:
    """Does the record start at (or a few samples after) the release whose first half swing runs
    from grid index `k0` (its first turning point) to `k1`, `offset` from rest, swinging at
    `omega` rad/s?

    True when the turning point is at the record's start (within START_S), the offset is one of
    the record's main motions (MIN_SHARE of its range), and the body starts from there towards
    rest (or still), at a phase of its swing no later than MAX_TAN_PHASE allows.  The offset, the decaying swings after it and the first half swing's length are
    checked by the caller, as for any release."""
    tu, tk, yk = sig.tu, sig.tk, sig.yk
    if k1 <= k0 or tu[k0] - tu[0] > START_S or abs(offset) < MIN_SHARE * float(np.ptp(sig.ys)):
        return False
    n = max(int(np.searchsorted(tk, tk[0] + START_S, side="right")), 3)
    if n > len(tk):
        return False
    slope = float(np.polyfit(tk[:n] - tk[0], yk[:n], 1)[0])
    towards_rest = -slope * np.sign(offset) >= -4.0 * sig.sigma_v
    return bool(towards_rest and abs(slope) <= MAX_TAN_PHASE * abs(offset) * omega)
