"""The ramp's single release: the start of motion of the drive rate, found by a hinge fit of a
constant followed by a linear/quadratic rise (roboball.ingest.releases)."""
from __future__ import annotations

import numpy as np

from roboball.ingest.releases.hinge import hinge_fit
from roboball.ingest.releases.record import Release
from roboball.ingest.releases.signal import PreparedSignal

__all__ = ["exit_from_rate", "ramp_release"]

DROP = 0.1          # share of the rate reached: a fall onto the floor drops the campaign's runs 18-19% in 0.1-0.2 s
DROP_S = 0.25       # s: how soon after the rate's highest value the drop comes (the floor's impact, not a slow loss)


def ramp_release(sig: PreparedSignal, ramp_exit_s: float | None) -> list[Release]:
    tu, ys = sig.tu, sig.ys
    n0 = max(int(round(0.3 / sig.dt)), 3)
    y0 = float(np.median(ys[:n0]))
    dev = np.abs(ys - y0)
    peak = float(np.max(dev))
    thr = max(10.0 * sig.sigma, 0.05 * peak)
    if peak <= max(20.0 * sig.sigma, 2 * sig.hysteresis):
        return []
    k = int(np.nonzero(dev > thr)[0][0])
    # Rest before motion: back from k to where the signal is within 3 sigma of y0.
    quiet = np.nonzero(dev[:k] <= max(3.0 * sig.sigma, sig.q))[0]
    k_q = int(quiet[-1]) if quiet.size else 0
    t_lo = tu[k_q] - 0.2
    t_hi = tu[k]
    t_a = max(tu[0], t_lo - 0.5)
    t_b = min(tu[-1], t_hi + 0.3)
    sel = (sig.tk >= t_a) & (sig.tk <= t_b)
    t_r, coef = hinge_fit(sig.tk[sel], sig.yk[sel], max(t_lo, t_a + 0.02), t_hi, (1, 2), pre_slope=False)
    if ramp_exit_s is None:
        ramp_exit_s = exit_from_rate(sig, float(t_r))
    t_end = float(sig.tk[-1]) if ramp_exit_s is None else float(min(max(ramp_exit_s, t_r), sig.tk[-1]))
    return [
        Release(
            t_release_s=float(t_r),
            t_end_s=t_end,
            i_release=-1,
            i_end=-1,
            y_release=float(coef[0]) if coef is not None else y0,
            y_rest=y0,
            held_from_s=float(tu[0]),
            noise=sig.sigma,
            kind="ramp",
        )
    ]


def exit_from_rate(sig: PreparedSignal, t_r: float) -> float | None:
    """Where the robot left the ramp, read from the drive rate when the recording does not say
    (`ramp_exit_s`): rolling off the ramp's end, the shell meets the floor and its rate drops at
    once and falls on, where a descent on the ramp rises or levels off and a pendulum's wobble
    comes back.  The instant of the highest rate before a drop of more than DROP of it (and 10
    noise levels) within DROP_S, when the rate then stays below the highest value less half the
    drop to the end of the record; None when the record holds no such fall."""
    after = sig.tu >= t_r
    t, y = sig.tu[after], sig.ys[after]
    if t.size < 3:
        return None
    top = np.maximum.accumulate(y)
    i = np.arange(y.size)
    at_top = np.maximum.accumulate(np.where(y >= top, i, 0))        # where each running maximum was reached
    drop = np.maximum(DROP * np.abs(top), 10.0 * sig.sigma)
    hit = np.nonzero((top - y > drop) & (i - at_top <= max(int(round(DROP_S / sig.dt)), 1)))[0]
    if not hit.size:
        return None
    j = int(hit[0])
    if np.any(y[j:] > top[j] - 0.5 * drop[j]):
        return None
    return float(t[at_top[j]])
