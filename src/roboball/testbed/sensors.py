"""Sensor and hand realism: irregular sampling with gaps and duplicated stamps, noise,
quantisation, and the hand-held phases (move, hold, let go) before each release."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

ANGLE_SUFFIX = "_rad"
RATE_SUFFIX = "_rad_s"


def sample_times(t0: float, t1: float, cfg: dict, rng: np.random.Generator) -> np.ndarray:
    """Irregular stamps at 80-100 Hz with occasional dropouts and exact duplicates."""
    lo, hi = cfg["rate_hz"]
    out = []
    t = t0
    while t <= t1:
        out.append(t)
        if rng.random() < cfg["duplicate_probability"]:
            out.append(t)
        step = 1.0 / rng.uniform(lo, hi)
        if rng.random() < cfg["gap_probability"]:
            step += rng.uniform(*cfg["gap_s"])
        t += step
    return np.asarray(out)


def measure(dense: pd.DataFrame, cfg: dict, rng: np.random.Generator, stamp_digits: int = 4) -> pd.DataFrame:
    """Sample dense noiseless signals (1 kHz) as the robot's sensors would (stamps rounded to
    `stamp_digits` decimals of a second: the campaign's loggers keep 0.1 ms, the real dynamic
    log's nanoseconds)."""
    t_dense = dense.time_s.to_numpy()
    ts = sample_times(t_dense[0], t_dense[-1], cfg, rng)
    cols = {"time_s": np.round(ts, stamp_digits)}
    for name in dense.columns:
        if name == "time_s":
            continue
        y = np.interp(ts, t_dense, dense[name].to_numpy())
        if name.endswith(RATE_SUFFIX):
            y = y + rng.normal(0.0, cfg["rate_noise_rad_s"], len(ts))
            q = cfg["rate_quantum_rad_s"]
        else:
            y = y + rng.normal(0.0, cfg["angle_noise_rad"], len(ts))
            q = cfg["angle_quantum_rad"]
        cols[name] = np.round(y / q) * q
    return pd.DataFrame(cols)


def min_jerk(a: float, b: float, n: int) -> np.ndarray:
    s = np.linspace(0.0, 1.0, n)
    return a + (b - a) * (10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5)


def hand_phase(start: float, target: float, cfg: dict, rng: np.random.Generator, rate_hz: float = 1000.0):
    """A hand moves the body from `start` to `target`, then holds it with a small tremor.

    Returns (angle array at rate_hz, the angle at the moment of letting go)."""
    n_move = int(rng.uniform(*cfg["move_s"]) * rate_hz)
    n_hold = int(rng.uniform(*cfg["hold_s"]) * rate_hz)
    move = min_jerk(start, target, n_move)
    # Tremor: low-pass filtered noise (about 2 Hz), zero at the start of the hold.
    white = rng.normal(0.0, 1.0, n_hold + 400)
    kernel = np.hanning(201)
    trem = np.convolve(white, kernel / kernel.sum(), mode="same")[200:200 + n_hold]
    trem = cfg["tremor_rad"] * trem / (np.std(trem) + 1e-12)
    trem -= trem[0]
    hold = target + trem
    return np.concatenate([move, hold]), float(hold[-1])


def estimator_lag(dense: pd.DataFrame, lag_s: float) -> pd.DataFrame:
    """The dense signals as an estimator that lags by `lag_s` seconds reports them: a first-order
    low-pass tau x' = u - x on every signal column, settled on the first value.  Exact for the
    dense samples joined by straight lines (the test bed's own discretisation, independent of
    the diagnosis's operator)."""
    from scipy.signal import lfilter, lfiltic

    out = dense.copy()
    if not lag_s:
        return out
    h = float(np.median(np.diff(dense.time_s.to_numpy())))
    a = math.exp(-h / lag_s)
    r = lag_s / h * (1.0 - a)
    b = [1.0 - r, r - a]        # x_k+1 = a x_k + (1 - r) u_k+1 + (r - a) u_k
    for name in dense.columns:
        if name == "time_s":
            continue
        u = dense[name].to_numpy(dtype=float)
        out[name] = lfilter(b, [1.0, -a], u, zi=lfiltic(b, [1.0, -a], [u[0]], [u[0]]))[0]
    return out


def estimator_sensors(cfg: dict, angle_noise_rad: float = 3e-5) -> dict:
    """Sensor settings of an estimator's output: smooth (noise `angle_noise_rad`, like the real
    robot's dynamic log's 3e-5 rad; rates ten times that per second) and not quantised (a float
    estimate: a 1e-7 step only keeps the logger's rounding)."""
    return dict(cfg, angle_noise_rad=angle_noise_rad, angle_quantum_rad=1e-7,
                rate_noise_rad_s=10.0 * angle_noise_rad, rate_quantum_rad_s=1e-6)
