"""Locate the mismatch: where in time and in which regime the baseline's residual sits.

Every sample of every release window is classified from the RECORDING (smoothed), not from a
model, into regimes that point at different physics:

| regime | samples | physics it points at |
|---|---|---|
| high_speed | speed above 60% of the release's peak speed | drag, viscous losses |
| low_speed | speed below 15% of the peak | dry friction, stiction |
| reversal | within 8% of a half period of a turning point | dry friction, backlash |
| large_amplitude | swing amplitude above 50% of the release's | nonlinear stiffness, drag |
| small_amplitude | swing amplitude below 20% of the release's | dry friction, backlash |
| near_stop | last swings: amplitude below 5% of the release's, still moving | dry friction |
| rest_offset | the body has come to rest | centre of mass offset, dry friction |
| late_decay | last third of the free response's moving time | damping law |
| release | first 0.3 s after the release (windows that start at the let-go only) | release state, hand |
| ramp_exit | last 0.3 s before the robot leaves the ramp | contact change at the exit |

(ramp runs: speed regimes on the drive rate's own size, `release` and `ramp_exit`.)  Regimes
overlap; each reports its share of the squared residual and its share of the samples, so a
regime holding 60% of the residual in 10% of the samples stands out (concentration 6).

Time windows: each release's window is cut into pieces of about one swing period (ramp: 0.25
s); the pieces with the largest shares of the squared residual, merged when adjacent, are the
`located` entries of diagnosis.json, each labelled with its most concentrated regime.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import maximum_filter1d

from roboball.diagnose.data import Prepared
from roboball.ingest.releases.signal import savgol_filter

REGIMES = ("high_speed", "low_speed", "reversal", "large_amplitude", "small_amplitude", "near_stop",
           "rest_offset", "late_decay", "release", "ramp_exit")


@dataclass
class Located:
    """Regime table and time windows of one residual."""

    regimes: list          # dicts: regime, share_of_residual, share_of_samples, concentration
    windows: list          # dicts: start_s, end_s, signal, regime, share_of_residual
    labels: dict           # window index -> {regime: boolean mask}


def _smooth(t, y):
    """Smoothed values and rates of irregular samples (uniform grid, Savitzky-Golay)."""
    dt = max(float(np.median(np.diff(t))), 1e-4) if len(t) > 1 else 0.01
    tu = np.arange(t[0], t[-1] + 0.5 * dt, dt)
    yu = np.interp(tu, t, y)
    n = max(5, int(round(0.08 / dt)) | 1)
    if len(yu) > n:
        ys = savgol_filter(yu, n, 2)
        vs = savgol_filter(yu, n, 2, deriv=1, delta=dt)
    else:
        ys, vs = yu, np.gradient(yu, dt)
    return np.interp(t, tu, ys), np.interp(t, tu, vs), dt


def classify(prep: Prepared) -> dict:
    """window index -> {regime: mask over the window's samples}."""
    out = {}
    for w in prep.windows:
        t, y = w.t, w.y
        ys, vs, dt = _smooth(t, y)
        n = len(t)
        after = t >= w.t0
        speed = np.abs(vs)
        vpk = max(float(np.max(speed[after])) if after.any() else 0.0, 1e-12)
        lab = {r: np.zeros(n, bool) for r in REGIMES}
        lab["high_speed"] = after & (speed > 0.6 * vpk)
        lab["low_speed"] = after & (speed < 0.15 * vpk)
        if w.start == "release":       # (a window fitted from its first turning point has no let-go)
            lab["release"] = (t >= w.t0 - 0.05) & (t < w.t0 + 0.3)
        if prep.kind == "ramp":
            lab["ramp_exit"] = t > t[-1] - 0.3
        else:
            rest = float(np.median(ys[-max(5, n // 20):]))
            amp0 = max(abs(w.q0 - rest), 1e-9)
            half = w.release.half_period_s if np.isfinite(w.release.half_period_s) else 0.6
            # Swing amplitude: the largest deviation from rest within one period around t.
            k = max(3, int(round(2.0 * half / max(np.median(np.diff(t)), 1e-4))) | 1)
            env = maximum_filter1d(np.abs(ys - rest), size=k, mode="nearest")
            lab["large_amplitude"] = after & (env > 0.5 * amp0)
            lab["small_amplitude"] = after & (env < 0.2 * amp0)
            still = after & (env < max(0.01 * amp0, 6.0 * prep.noise))
            lab["rest_offset"] = still
            lab["near_stop"] = after & (env < 0.05 * amp0) & ~still
            # Turning points: sign changes of the smoothed rate while moving.
            sgn = np.sign(vs)
            turn = np.nonzero((sgn[1:] * sgn[:-1] < 0) & ~still[1:])[0] + 1
            rev = np.zeros(n, bool)
            for i in turn:
                rev |= np.abs(t - t[i]) < 0.08 * half
            lab["reversal"] = after & rev & ~still
            moving = np.nonzero(after & ~still)[0]
            if moving.size:
                t_a, t_b = t[moving[0]], t[moving[-1]]
                lab["late_decay"] = after & (t >= t_b - (t_b - t_a) / 3.0) & (t <= t_b)
        out[w.index] = lab
    return out


def locate(prep: Prepared, pred: dict, labels: dict | None = None, max_windows: int = 6,
           cover: float = 0.8) -> Located:
    """Regime shares and the time windows holding most of the squared residual of `pred`."""
    labels = labels or classify(prep)
    res = {w.index: pred[w.index] - w.y for w in prep.windows}
    total = sum(float(np.sum(r * r)) for r in res.values())
    n_all = sum(len(r) for r in res.values())
    regimes = _regime_shares(res, labels, total, n_all)
    pieces = [piece for w in prep.windows for piece in _pieces(prep, w, res[w.index], labels[w.index])]
    merged = _merged(pieces, _largest(pieces, total, cover, max_windows))
    windows = [dict(start_s=round(m["start_s"], 3), end_s=round(m["end_s"], 3), signal=prep.signal,
                    regime=m["regime"], share_of_residual=(m["_sq"] / total if total > 0 else 0.0))
               for m in merged[:max_windows]]
    return Located(regimes=regimes, windows=windows, labels=labels)


def _regime_shares(res: dict, labels: dict, total: float, n_all: int) -> list:
    """The regime table: each regime's share of the squared residual and of the samples."""
    regimes = []
    for reg in REGIMES:
        sq = sum(float(np.sum(res[i][labels[i][reg]] ** 2)) for i in res)
        cnt = sum(int(np.sum(labels[i][reg])) for i in res)
        if cnt == 0:
            continue
        share = sq / total if total > 0 else 0.0
        frac = cnt / n_all
        regimes.append(dict(regime=reg, share_of_residual=share, share_of_samples=frac,
                            concentration=share / frac if frac > 0 else 0.0))
    return regimes


def _pieces(prep: Prepared, w, r: np.ndarray, lab: dict) -> list:
    """Window `w` cut into pieces of about one swing period (ramp: 0.25 s), each with its
    squared residual (`r`: the window's residual) and its most concentrated regime."""
    if prep.kind == "ramp":
        length = 0.25
    else:
        half = w.release.half_period_s if np.isfinite(w.release.half_period_s) else 0.6
        length = 2.0 * half
    pieces = []
    edges = np.arange(w.t[0], w.t[-1] + length, length)
    for a, b in zip(edges[:-1], edges[1:]):
        m = (w.t >= a) & (w.t < b)
        if not m.any():
            continue
        sq = float(np.sum(r[m] ** 2))
        best, best_c = "late_decay", -1.0
        for reg in REGIMES:
            lm = lab[reg] & m
            if lm.sum() < max(3, 0.2 * m.sum()):
                continue
            conc = (float(np.sum(r[lm] ** 2)) / max(sq, 1e-300)) / (lm.sum() / m.sum())
            if conc > best_c:
                best, best_c = reg, conc
        pieces.append(dict(window=w.index, start_s=float(w.t[m][0]), end_s=float(w.t[m][-1]), sq=sq, regime=best))
    return pieces


def _largest(pieces: list, total: float, cover: float, max_windows: int) -> list:
    """Indices (in order) of the pieces with the largest squared residual, until they hold
    `cover` of `total` or 3 * max_windows were taken."""
    order = sorted(range(len(pieces)), key=lambda i: -pieces[i]["sq"])
    chosen, acc = [], 0.0
    for i in order:
        if acc >= cover * total or len(chosen) >= 3 * max_windows:
            break
        chosen.append(i)
        acc += pieces[i]["sq"]
    chosen.sort()
    return chosen


def _merged(pieces: list, chosen: list) -> list:
    """The chosen pieces, adjacent ones of a window merged (labelled with the regime of their
    largest piece), largest squared residual first."""
    merged = []
    for i in chosen:
        p = pieces[i]
        if merged and merged[-1]["_last"] == i - 1 and merged[-1]["_w"] == p["window"]:
            m = merged[-1]
            m["end_s"] = p["end_s"]
            m["_sq"] += p["sq"]
            m["_last"] = i
            if p["sq"] > m["_top"]:
                m["_top"], m["regime"] = p["sq"], p["regime"]
        else:
            merged.append(dict(start_s=p["start_s"], end_s=p["end_s"], regime=p["regime"], _sq=p["sq"],
                               _last=i, _w=p["window"], _top=p["sq"]))
    merged.sort(key=lambda m: -m["_sq"])
    return merged
