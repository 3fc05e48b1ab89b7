"""The ramp's single release: the start of motion of the drive rate, found by a hinge fit of a
constant followed by a linear/quadratic rise (roboball.ingest.releases)."""
from __future__ import annotations

import numpy as np

from roboball.ingest.releases.hinge import hinge_fit
from roboball.ingest.releases.record import Release
from roboball.ingest.releases.signal import PreparedSignal

__all__ = ["ramp_release"]


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
