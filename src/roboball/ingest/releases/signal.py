"""A signal cleaned for event detection (steps 1-2 of roboball.ingest.releases): duplicate stamps
dropped, resampled onto a uniform grid, smoothed, its noise level and quantisation step estimated,
and its turning points found with a noise hysteresis."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import lstsq
from scipy.ndimage import convolve1d, median_filter

__all__ = ["PreparedSignal", "prepare_signal", "savgol_filter", "zigzag"]


def savgol_filter(x, window_length: int, polyorder: int, deriv: int = 0, delta: float = 1.0) -> np.ndarray:
    """SciPy's `scipy.signal.savgol_filter` of a 1-D signal in its default `mode="interp"`, the
    same operations in the same order, so the same bits (tests/ingest/test_savgol.py).  Importing
    `scipy.signal` costs about 0.7 s of CPU (its functions' docstrings are rewritten at import),
    paid by every ingest and diagnosis job for this one filter."""
    x = np.asarray(x, dtype=np.float64)
    if not 0 <= polyorder < window_length <= x.shape[0] or window_length % 2 == 0:
        raise ValueError(f"savgol_filter: need 0 <= polyorder < window_length <= len(x) and an odd "
                         f"window (polyorder {polyorder}, window {window_length}, {x.shape[0]} samples)")
    half = window_length // 2
    # scipy.signal.savgol_coeffs(use="conv"): least squares on the reversed Vandermonde rows
    t = np.flip(np.arange(-half, window_length - half, dtype=np.float64))
    A = t ** np.arange(polyorder + 1, dtype=np.float64).reshape(-1, 1)
    if deriv > polyorder:
        coeffs = np.zeros(window_length)
    else:
        y = np.zeros(polyorder + 1)
        y[deriv] = math.factorial(deriv) / (delta ** deriv)
        coeffs = lstsq(A, y, cond=np.finfo(np.float64).eps * max(A.shape))[0]
    out = convolve1d(x, coeffs, mode="constant")
    # the ends: the polynomial fitted to the first and last windows (scipy's _fit_edges_polyfit)
    n = x.shape[0]
    for start, lo, hi in ((0, 0, half), (n - window_length, n - half, n)):
        out[lo:hi] = _edge_values(x[start:start + window_length], polyorder, deriv, delta,
                                  np.arange(lo - start, hi - start, dtype=np.float64))
    return out


def _edge_values(xe, polyorder, deriv, delta, at):
    """scipy.signal._polyutils.polyfit (scaled Vandermonde, SciPy's lstsq), its derivative and
    Horner's evaluation, as `savgol_filter` does at the ends."""
    s = np.arange(0, xe.shape[0], dtype=np.float64)
    powers = np.flip(np.arange(polyorder + 1, dtype=np.float64))
    lhs = s[:, None] ** powers[None, :]
    scale = np.sqrt(np.sum(lhs * lhs, axis=0))
    lhs /= scale
    c = lstsq(lhs, xe.reshape(-1, 1), cond=s.shape[0] * np.finfo(np.float64).eps)[0]
    c = (c.T / scale).T
    if deriv:
        n = c.shape[0]
        if n <= deriv:
            c = np.zeros_like(c[:1])
        else:
            c = np.array(c[:-deriv], copy=True)
            for k in range(deriv):
                c *= np.arange(n - k - 1, deriv - k - 1, -1, dtype=c.dtype).reshape(n - deriv, 1)
    v = np.zeros_like(at.reshape(-1, 1))
    for j in range(c.shape[0]):
        v = v * at.reshape(-1, 1) + c[j]
    return (v / (delta ** deriv)).ravel()


@dataclass
class PreparedSignal:
    """A signal cleaned for event detection: raw samples without duplicate stamps (tk, yk,
    with `index` mapping back to the caller's arrays), a uniform grid (tu, yu), the
    smoothed signal ys, the noise level sigma and the quantisation step q (0 if none)."""

    tk: np.ndarray
    yk: np.ndarray
    index: np.ndarray
    tu: np.ndarray
    yu: np.ndarray
    ys: np.ndarray
    vs: np.ndarray
    dt: float
    sigma: float
    sigma_v: float
    q: float

    @property
    def hysteresis(self) -> float:
        return max(5.0 * self.sigma, 2.0 * self.q)


def _odd(n: float, minimum: int) -> int:
    n = max(int(round(n)), minimum)
    return n if n % 2 == 1 else n + 1


def _quantum(y: np.ndarray) -> float:
    """The quantisation step of a logged signal, or 0 when the values are not on a grid."""
    d = np.abs(np.diff(y))
    scale = max(float(np.max(np.abs(y))), 1e-12)
    nz = d[d > 1e-9 * scale]
    if nz.size < 10:
        return 0.0
    q = float(np.min(nz))
    if q <= 0:
        return 0.0
    # On a grid every step is (nearly) an integer multiple of q.
    ratio = nz / q
    multiples = np.unique(np.round(ratio))
    # On a grid every step is (nearly) an integer multiple of q, and a moving signal takes
    # steps of several sizes (a uniformly sampled straight line takes only one).
    if np.mean(np.abs(ratio - np.round(ratio)) < 0.05) > 0.95 and len(multiples) >= 3:
        return q
    return 0.0


def prepare_signal(t, y, grid_dt: float | None = None) -> PreparedSignal:
    """Drop non-finite samples and duplicate stamps, resample onto a uniform grid, smooth,
    and estimate the noise level (see roboball.ingest.releases)."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if t.shape != y.shape or t.ndim != 1:
        raise ValueError("t and y must be 1-D arrays of equal length")
    finite = np.isfinite(t) & np.isfinite(y)
    idx = np.nonzero(finite)[0]
    tk, yk = t[idx], y[idx]
    order = np.argsort(tk, kind="stable")
    tk, yk, idx = tk[order], yk[order], idx[order]
    keep = np.ones(len(tk), dtype=bool)
    keep[1:] = np.diff(tk) > 0
    tk, yk, idx = tk[keep], yk[keep], idx[keep]
    if len(tk) < 3:
        raise ValueError("need at least 3 distinct time stamps")
    span = tk[-1] - tk[0]
    if grid_dt is None:
        grid_dt = float(np.median(np.diff(tk)))
        grid_dt = max(grid_dt, span / 200_000.0)
    n = int(math.floor(span / grid_dt)) + 1
    tu = tk[0] + grid_dt * np.arange(n)
    yu = np.interp(tu, tk, yk)
    win_s = _odd(0.06 / grid_dt, 5)
    ys = savgol_filter(yu, win_s, 2) if n > win_s else yu.copy()
    # Noise: robust spread of the raw samples about a local cubic fit (0.1 s windows),
    # measured on the raw samples because interpolation onto the grid averages noise away.
    win_n = _odd(0.10 / grid_dt, 7)
    if n > win_n:
        smooth = savgol_filter(yu, win_n, 3)
        resid = yk - np.interp(tk, tu, smooth)
        sigma = 1.4826 * float(np.median(np.abs(resid - np.median(resid))))
    else:
        sigma = float(np.std(yk))
    q = _quantum(yk)
    scale = max(float(np.ptp(yk)), 1e-12)
    sigma = max(sigma, q / math.sqrt(12.0), 1e-9 * scale)
    # Velocity: Savitzky-Golay derivative over ~0.15 s, then a running median of 0.1 s so a
    # single noisy sample cannot interrupt a hold.  The derivative's noise is that of a
    # least-squares slope over the window: sigma / (dt sqrt(sum k^2)).
    win_v = _odd(0.15 / grid_dt, 5)
    if n > win_v:
        vs = savgol_filter(yu, win_v, 2, deriv=1, delta=grid_dt)
        vs = median_filter(vs, size=_odd(0.10 / grid_dt, 3), mode="nearest")
    else:
        vs = np.gradient(yu, grid_dt)
    half = win_v // 2
    sigma_v = sigma / (grid_dt * math.sqrt(half * (half + 1) * (2 * half + 1) / 3.0))
    return PreparedSignal(tk=tk, yk=yk, index=idx, tu=tu, yu=yu, ys=ys, vs=vs, dt=grid_dt,
                          sigma=sigma, sigma_v=sigma_v, q=q)


def zigzag(y: np.ndarray, h: float) -> np.ndarray:
    """Indices of the alternating turning points of `y`: a maximum is confirmed when the
    signal has since fallen by more than `h`, a minimum when it has since risen by more than
    `h` (hysteresis, so noise smaller than `h` makes no turning points)."""
    y = np.asarray(y, dtype=float)
    n = len(y)
    if n == 0:
        return np.array([], dtype=int)
    ext: list[int] = []
    imax = imin = 0
    direction = 0
    for i in range(1, n):
        v = y[i]
        if direction == 0:
            if v > y[imax]:
                imax = i
            if v < y[imin]:
                imin = i
            if y[imax] - v > h:
                ext.append(imax)
                direction = -1
                imin = i
            elif v - y[imin] > h:
                ext.append(imin)
                direction = 1
                imax = i
        elif direction < 0:
            if v < y[imin]:
                imin = i
            elif v - y[imin] > h:
                ext.append(imin)
                direction = 1
                imax = i
        else:
            if v > y[imax]:
                imax = i
            elif y[imax] - v > h:
                ext.append(imax)
                direction = -1
                imin = i
    # The last excursion counts too if it left the previous turning point by more than h.
    if direction < 0 and ext and y[ext[-1]] - y[imin] > h:
        ext.append(imin)
    elif direction > 0 and ext and y[imax] - y[ext[-1]] > h:
        ext.append(imax)
    return np.asarray(ext, dtype=int)
