"""A sensor's own dynamics: the first-order lag of an estimator or filter, applied to predictions.

A recording may be an estimator's output rather than a raw sensor's (the real robot's dynamic
log: smooth, noise ~3e-5 rad where its encoders quantise at 1 mrad).  An estimator that smooths
also delays: to a first order it reads x with tau x' = u - x for the true coordinate u, a lag
of tau seconds.  That is not physics, so the diagnosis does not name it as missing: where the
recording calls for it (roboball.diagnose.sensor_fit) the lag's time constant `sensor_lag_s` is
fitted inside the baseline, and EVERY prediction compared with the recording passes through
the same operator, `lag_grid` (the reduced model's in every fit and held-out fold, in
roboball.diagnose.fit; the Drake runs' through `sensed`), before a window's own one
(Window.observe: a ramp's boxcar).  The lag acts before the
averaging because the estimator ran on the robot, the averaging on the recording.

The operator.  It acts on the model's own output, on its time grid from the model's start
(value and rate at every step, so a cubic Hermite between steps: the reduced model's own
interpolant), before the output is read at the recording's samples.  On each step the lag of a
cubic p has the particular solution p - tau p' + tau^2 p'' - tau^3 p''', so x(k + 1) =
x_p(k + 1) + exp(-dt / tau) (x(k) - x_p(k)) is exact, for any tau / dt; the recursion runs as a
compiled filter (one per distinct lag of a batch).  Its rate is x' = (u - x) / tau.

Where the filter starts.  A window that starts at a release starts on a hold: the filter has
settled on the held value, x = u.  A window that starts at the first turning point of a free
swing (roboball.diagnose.data) starts mid-motion: the filter's state there is the lag of the
swing BEFORE the turning point, which the model does not simulate.  A free swing is nearly
symmetric about its turning point (exactly without damping), so the motion before it is the
mirror image of the motion after it: x(0) = (backward lag of the prediction)(0) - 2 (odd
part), with the odd part of the mirror taken from its Taylor terms tau u' + tau^3 u''' + tau^5
u^(5) at the turning point.  This is exact to all even orders of the swing and to the fifth odd
one (the filter's steady state on a damped swing, within 0.01 mrad for a 40 ms lag), where
starting at x = u would leave a transient of about A (omega tau)^2 / 2 (14 mrad for a 0.4 rad
swing at 5.4 rad/s through a 40 ms lag) that the fit would take for physics.

Only a lag, no scale.  A scale error of the sensor would change how the period depends on the
(recorded) amplitude, exactly as a stiffness that grows with amplitude does: from one
experiment the two cannot be told apart, so a scale is not fitted (nor reported as physics).
"""
from __future__ import annotations

import numpy as np

LAG_KEY = "sensor_lag_s"
LAG_TYPICAL = 0.01         # s: size of the fit's finite-difference and step scaling
LAG_BOUNDS = (0.0, 0.25)   # s: an estimator slower than a quarter second would hide the swing itself
MIRROR_SPAN = 12.0         # time constants of the prediction the backward lag reads at a turning point
ODD_SPAN = 6.0            # time constants of the rate the odd part at a turning point is read from


def lag_of(values: dict) -> float:
    """The fitted lag in `values` (0: none)."""
    return float(values.get(LAG_KEY, 0.0))


def _hermite_terms(dt: float, u0, u1, d0, d1):
    """Second derivatives at both ends and the constant third derivative of the cubic Hermite
    through (u0, d0) and (u1, d1) over a step dt."""
    slope = (u1 - u0) / dt
    c2 = (3.0 * slope - 2.0 * d0 - d1) / dt
    c3 = (d0 + d1 - 2.0 * slope) / (dt * dt)
    return 2.0 * c2, 2.0 * c2 + 6.0 * c3 * dt, 6.0 * c3


def _recursion(Y, Yd, dt: float, tau, sign: float):
    """Terms of x(k+1) = a x(k) + b(k) on every step of the grid for the causal lag (sign -1), or
    of z(k) = a z(k+1) + b(k) for the backward one (sign +1: tau z' = z - u): the decay a (B,)
    and b (n, B), from the particular solutions p + sign tau p' + tau^2 p'' + sign tau^3 p''' of
    each step's cubic at its two ends."""
    acc0, acc1, jerk = _hermite_terms(dt, Y[:-1], Y[1:], Yd[:-1], Yd[1:])
    t2, t3 = tau * tau, tau * tau * tau
    start = Y[:-1] + sign * tau * Yd[:-1] + t2 * acc0 + sign * t3 * jerk
    end = Y[1:] + sign * tau * Yd[1:] + t2 * acc1 + sign * t3 * jerk
    a = np.exp(-dt / tau)
    return a, (end - a * start if sign < 0 else start - a * end)


def _by_lag(tau, a, b, x0, reverse: bool):
    """Run the recursion x(k+1) = a x(k) + b(k) from x0 (or backward) for every column, one
    compiled filter per distinct lag in the batch."""
    from scipy.signal import lfilter

    out = np.empty_like(b)
    bb = b[::-1] if reverse else b
    for value in np.unique(tau):
        cols = np.nonzero(tau == value)[0]
        ak = float(a[cols[0]])
        out[:, cols] = lfilter([1.0], [1.0, -ak], bb[:, cols], axis=0, zi=ak * x0[None, cols])[0]
    return out[::-1] if reverse else out


def _mid_swing(Y, Yd, dt: float, tau):
    """The filter's state at a swing's turning point, where the model starts (module docstring):
    the backward lag of the motion after it, less twice the odd part of its mirror image."""
    m = min(int(np.ceil(MIRROR_SPAN * float(np.max(tau)) / dt)) + 1, Y.shape[0])
    a, b = _recursion(Y[:m], Yd[:m], dt, tau, +1.0)
    z0 = _by_lag(tau, a, b, Y[m - 1], reverse=True)[0]
    d1, d3, d5 = _odd_derivatives(Yd, dt, float(np.max(tau)))
    return z0 - 2.0 * (tau * d1 + tau ** 3 * d3 + tau ** 5 * d5)


def _odd_derivatives(Yd, dt: float, tau: float):
    """u', u''' and u^(5) at the start, from a least-squares polynomial (degree 6) through the
    rate over the first ODD_SPAN time constants (at least ten steps): a step's own cubic, or
    any polynomial through a few steps, amplifies the integrator's O(dt^2) wiggles by dt^-3
    and dt^-5."""
    n = min(max(int(np.ceil(ODD_SPAN * tau / dt)), 10) + 1, Yd.shape[0])
    x = np.arange(n) / (n - 1)
    coef = np.linalg.lstsq(np.vander(x, 7, increasing=True), Yd[:n], rcond=None)[0]
    span = (n - 1) * dt
    return coef[0], 2.0 * coef[2] / span ** 2, 24.0 * coef[4] / span ** 4


def lag_grid(Y, Yd, dt: float, tau, swinging) -> tuple[np.ndarray, np.ndarray]:
    """A model's output Y and its rate Yd on its own time grid (n + 1 steps of dt from the model's
    start, one column per run: shape (n + 1, B)) as a sensor lagging by `tau` ((B,) seconds; 0:
    unchanged) reports them: x with tau x' = u - x, exact for the cubic Hermite between steps,
    and its rate (u - x) / tau.  The filter starts settled on the start value (a hold), or in
    the columns where `swinging` ((B,) bool) mid-swing at a turning point (module docstring)."""
    tau = np.asarray(tau, dtype=float)
    lagged = np.nonzero(tau > 0)[0]
    if lagged.size == 0 or Y.shape[0] < 4:
        return Y, Yd
    X, Xd = Y.copy(), Yd.copy()
    Yl, Ydl, tl = Y[:, lagged], Yd[:, lagged], tau[lagged]
    with np.errstate(all="ignore"):     # a diverged run stays off (the fit rejects it)
        x0 = np.where(np.asarray(swinging, bool)[lagged], _mid_swing(Yl, Ydl, dt, tl), Yl[0])
        a, b = _recursion(Yl, Ydl, dt, tl, -1.0)
        Xl = np.empty_like(Yl)
        Xl[0] = x0
        Xl[1:] = _by_lag(tl, a, b, x0, reverse=False)
        X[:, lagged] = Xl
        Xd[:, lagged] = (Yl - Xl) / tl
    return X, Xd


def sensed(window, tau_s, t_sim, y_sim, values: dict) -> np.ndarray:
    """A simulation's output (`y_sim` at the evenly spaced times `t_sim` from the model's start:
    a Drake run) at the window's samples (`tau_s`, seconds since the model's start; before it
    the first value), as the sensor with the lag in `values` reports it."""
    tau = lag_of(values)
    if tau:
        dt = float(t_sim[1] - t_sim[0])
        y_sim = lag_grid(y_sim[:, None], np.gradient(y_sim, dt)[:, None], dt, np.array([tau]),
                         np.array([window.start == "turning point"]))[0][:, 0]
    return np.interp(tau_s, t_sim, y_sim, left=y_sim[0])
