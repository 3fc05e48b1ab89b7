"""Synthetic logs with hand releases, for tests, demos and method checks.

A cheap stand-in for the test bed's simulated campaign: each release is the exact free
response of a damped oscillator, preceded by a hand that moves the body and holds it, and
the record is then "logged" with the real loggers' faults (irregular sampling, gaps,
duplicated stamps, noise, quantisation).  The truth (release instants, damping, frequency)
comes back with the log, so the release finder and the decay fit can be scored against it.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["free_response", "synthetic_release_log"]


def free_response(tau, offset: float, zeta: float, omega_n: float) -> np.ndarray:
    """Free response of a damped oscillator released from rest at `offset` from rest:
    offset * exp(-zeta omega_n tau) (cos omega_d tau + zeta omega_n / omega_d sin omega_d tau)."""
    tau = np.asarray(tau, dtype=float)
    wd = omega_n * math.sqrt(1.0 - zeta ** 2)
    a = zeta * omega_n
    return offset * np.exp(-a * tau) * (np.cos(wd * tau) + a / wd * np.sin(wd * tau))


def synthetic_release_log(
    releases: list[dict],
    *,
    rest: float = 0.0,
    rate_hz: tuple[float, float] = (80.0, 100.0),
    gap_probability: float = 0.01,
    max_gap_s: float = 0.05,
    duplicate_probability: float = 0.003,
    noise: float = 0.0005,
    quantum: float = 0.001,
    lead_s: float = 2.0,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray, list[dict]]:
    """A logged signal with hand releases, built the way the real tests were done.

    For each entry of `releases` (keys: offset, zeta, omega_n; optional move_s, hold_s,
    free_s, hold_drift): a hand moves the body from where it is to rest + offset (smooth
    cosine ramp over move_s), holds it (hold_s, optionally drifting by hold_drift), lets
    go, and the free damped response runs for free_s (default: until the amplitude has
    decayed to the noise, plus 1 s).  The record is then "logged" like the real loggers:
    irregular sampling between `rate_hz`, occasional gaps up to `max_gap_s`, duplicated
    stamps, Gaussian noise and quantisation.  Returns (t, y, truth) where truth holds each
    release's t_release_s, t_end_s, zeta, omega_n, omega_d, offset and rest.
    """
    rng = np.random.default_rng(seed)
    pieces, truth, t_total = _motion(releases, rest, noise, lead_s)
    stamps, ys = _logged(pieces, t_total, rng, rate_hz, gap_probability, max_gap_s,
                         duplicate_probability, noise, quantum)
    return stamps, ys, truth


def _motion(releases: list[dict], rest: float, noise: float,
            lead_s: float) -> tuple[list[tuple[float, float, object]], list[dict], float]:
    """The noiseless motion as pieces (t0, t1, f(t)): rest for `lead_s`, then per release a
    hand's move, its hold and the free response; then 1 s more at the last level.  Returns
    (pieces, truth, total duration)."""
    pieces: list[tuple[float, float, object]] = []  # (t0, t1, f(t))
    truth: list[dict] = []
    t_now = 0.0
    y_now = rest
    pieces.append((0.0, lead_s, lambda tt, y0=y_now: np.full_like(tt, y0)))
    t_now = lead_s
    for spec in releases:
        offset = float(spec["offset"])
        zeta = float(spec["zeta"])
        wn = float(spec["omega_n"])
        move_s = float(spec.get("move_s", 1.2))
        hold_s = float(spec.get("hold_s", 0.8))
        drift = float(spec.get("hold_drift", 0.0))
        target = rest + offset
        y_start = y_now
        t0 = t_now
        pieces.append((t0, t0 + move_s, lambda tt, t0=t0, a=y_start, b=target - drift, d=move_s:
                       a + (b - a) * 0.5 * (1 - np.cos(np.pi * (tt - t0) / d))))
        t_now += move_s
        t1 = t_now
        pieces.append((t1, t1 + hold_s, lambda tt, t1=t1, b=target - drift, dr=drift, d=hold_s:
                       b + dr * (tt - t1) / d))
        t_now += hold_s
        t_rel = t_now
        decay = zeta * wn
        free_s = spec.get("free_s")
        if free_s is None:
            free_s = math.log(max(abs(offset) / max(noise, 1e-6), 2.0)) / decay + 1.0
        free_s = float(free_s)
        pieces.append((t_rel, t_rel + free_s, lambda tt, tr=t_rel, o=offset, z=zeta, w=wn:
                       rest + free_response(tt - tr, o, z, w)))
        t_now += free_s
        y_now = rest + float(free_response(np.array([free_s]), offset, zeta, wn)[0])
        truth.append(dict(t_release_s=t_rel, t_end_s=t_now, zeta=zeta, omega_n=wn,
                          omega_d=wn * math.sqrt(1 - zeta ** 2), offset=offset, rest=rest))
    t_total = t_now + 1.0
    pieces.append((t_now, t_total, lambda tt, y0=y_now: np.full_like(tt, y0)))
    return pieces, truth, t_total


def _logged(pieces, t_total: float, rng: np.random.Generator, rate_hz: tuple[float, float],
            gap_probability: float, max_gap_s: float, duplicate_probability: float, noise: float,
            quantum: float) -> tuple[np.ndarray, np.ndarray]:
    """Sample the pieces the way the loggers do: irregular stamps with gaps, noise,
    quantisation, duplicated stamps.  Returns (stamps, values)."""
    # Irregular sampling with gaps.
    n_max = int(t_total * rate_hz[1] * 1.1) + 10
    dts = 1.0 / rng.uniform(rate_hz[0], rate_hz[1], n_max)
    gaps = rng.random(n_max) < gap_probability
    dts[gaps] = rng.uniform(0.6 * max_gap_s, max_gap_s, int(gaps.sum()))
    ts = np.cumsum(dts)
    ts = ts[ts < t_total]
    ys = np.empty_like(ts)
    for (a, b, f) in pieces:
        m = (ts >= a) & (ts < b)
        if m.any():
            ys[m] = f(ts[m])
    ys = ys + rng.normal(0.0, noise, ts.shape) if noise > 0 else ys
    if quantum > 0:
        ys = np.round(ys / quantum) * quantum
    stamps = ts.copy()
    dup = np.nonzero(rng.random(len(ts)) < duplicate_probability)[0]
    dup = dup[dup > 0]
    stamps[dup] = stamps[dup - 1]
    return stamps, ys
