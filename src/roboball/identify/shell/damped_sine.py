"""The damped oscillator's free response as a fitting model, and its least-squares fit.

    y(t) = rest + A exp(-zeta omega_n tau) cos(omega_d tau + phase),   tau = t - t0,
    omega_n = omega_d / sqrt(1 - zeta^2).

Standard errors come from the Jacobian at the solution, cov = s^2 (J^T J)^-1 with the residual
variance s^2, inflated by sqrt((1 + rho1) / (1 - rho1)) for residuals with lag-1
autocorrelation rho1 > 0 (model error such as dry friction makes residuals smooth and the
independent-noise errors would be far too small).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy.optimize import least_squares

__all__ = ["damped_sine", "DampedSineFit", "fit_damped_sine"]


def damped_sine(tau, rest: float, amplitude: float, zeta: float, omega_d: float, phase: float) -> np.ndarray:
    """rest + amplitude exp(-zeta omega_n tau) cos(omega_d tau + phase)."""
    tau = np.asarray(tau, dtype=float)
    decay = zeta * omega_d / math.sqrt(1.0 - zeta * zeta)
    return rest + amplitude * np.exp(-decay * tau) * np.cos(omega_d * tau + phase)


@dataclass
class DampedSineFit:
    """Least-squares fit of :func:`damped_sine`; parameter order
    (rest, amplitude, zeta, omega_d, phase).  `cov` is already inflated for residual
    autocorrelation."""

    t0: float
    params: np.ndarray
    cov: np.ndarray
    rmse: float
    n: int
    rho1: float
    inflation: float
    success: bool
    message: str = ""

    names = ("rest", "amplitude", "zeta", "omega_d", "phase")

    def __call__(self, t) -> np.ndarray:
        return damped_sine(np.asarray(t, dtype=float) - self.t0, *self.params)

    def value(self, name: str) -> float:
        return float(self.params[self.names.index(name)])

    def se(self, name: str) -> float:
        i = self.names.index(name)
        v = self.cov[i, i]
        return float(math.sqrt(v)) if np.isfinite(v) and v >= 0 else float("nan")

    @property
    def zeta(self) -> float:
        return self.value("zeta")

    @property
    def omega_d(self) -> float:
        return self.value("omega_d")

    @property
    def omega_n(self) -> float:
        z = self.zeta
        return self.omega_d / math.sqrt(1.0 - z * z)

    @property
    def omega_n_se(self) -> float:
        """Delta method: omega_n = omega_d / sqrt(1 - zeta^2)."""
        z, wd = self.zeta, self.omega_d
        g = np.zeros(5)
        g[2] = wd * z / (1.0 - z * z) ** 1.5
        g[3] = 1.0 / math.sqrt(1.0 - z * z)
        v = float(g @ self.cov @ g)
        return math.sqrt(v) if v >= 0 and np.isfinite(v) else float("nan")

    @property
    def decay_rate(self) -> float:
        """zeta omega_n (1/s): the envelope's exponential rate."""
        return self.zeta * self.omega_n

    def envelope(self, t) -> np.ndarray:
        tau = np.asarray(t, dtype=float) - self.t0
        return abs(self.value("amplitude")) * np.exp(-self.decay_rate * tau)


def _residual_lag1(r: np.ndarray) -> float:
    if len(r) < 3:
        return 0.0
    r = r - r.mean()
    den = float(r @ r)
    if den <= 0:
        return 0.0
    return float(r[:-1] @ r[1:]) / den


def fit_damped_sine(t, y, t0: float, p0: Sequence[float], max_zeta: float = 0.95) -> DampedSineFit:
    """Fit rest + A exp(-zeta omega_n (t - t0)) cos(omega_d (t - t0) + phase) to (t, y)
    starting from p0 = (rest, A, zeta, omega_d, phase); analytic Jacobian, trust-region
    least squares with zeta in [0, max_zeta] and omega_d > 0."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    tau = t - t0

    def parts(p):
        rest, amp, zeta, wd, ph = p
        sq = math.sqrt(1.0 - zeta * zeta)
        sig = zeta * wd / sq
        e = np.exp(-sig * tau)
        arg = wd * tau + ph
        c, s = np.cos(arg), np.sin(arg)
        return rest, amp, zeta, wd, sq, sig, e, c, s

    def fun(p):
        rest, amp, _, _, _, _, e, c, _ = parts(p)
        return rest + amp * e * c - y

    def jac(p):
        rest, amp, zeta, wd, sq, sig, e, c, s = parts(p)
        dsig_dz = wd / sq ** 3
        dsig_dw = zeta / sq
        J = np.empty((len(tau), 5))
        J[:, 0] = 1.0
        J[:, 1] = e * c
        J[:, 2] = -amp * e * c * tau * dsig_dz
        J[:, 3] = amp * e * (-tau * dsig_dw * c - tau * s)
        J[:, 4] = -amp * e * s
        return J

    p0 = np.array(p0, dtype=float)
    p0[2] = min(max(p0[2], 1e-4), max_zeta - 1e-3)
    p0[3] = max(p0[3], 1e-3)
    lower = [-np.inf, -np.inf, 0.0, 1e-6, -np.inf]
    upper = [np.inf, np.inf, max_zeta, np.inf, np.inf]
    res = least_squares(fun, p0, jac=jac, bounds=(lower, upper), x_scale="jac", method="trf",
                        xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=2000)
    p = res.x.copy()
    # Canonical form: positive amplitude, phase in (-pi, pi].
    if p[1] < 0:
        p[1] = -p[1]
        p[4] += math.pi
    p[4] = math.atan2(math.sin(p[4]), math.cos(p[4]))
    r = fun(p)
    return _with_errors(float(t0), p, r, jac(p), bool(res.success), str(res.message))


def _with_errors(t0: float, p: np.ndarray, r: np.ndarray, J: np.ndarray, success: bool, message: str) -> DampedSineFit:
    """The fit at `p` with residuals `r` and Jacobian `J`: covariance s^2 (J^T J)^-1 inflated
    for the residuals' lag-1 autocorrelation (see roboball.identify.shell.decay)."""
    n = len(r)
    dof = max(n - 5, 1)
    s2 = float(r @ r) / dof
    try:
        cov = np.linalg.inv(J.T @ J) * s2
    except np.linalg.LinAlgError:
        cov = np.full((5, 5), np.nan)
    rho = _residual_lag1(r)
    rho_c = min(max(rho, 0.0), 0.99)
    infl = math.sqrt((1.0 + rho_c) / (1.0 - rho_c))
    cov = cov * infl ** 2
    return DampedSineFit(t0=t0, params=p, cov=cov, rmse=float(math.sqrt(float(r @ r) / n)),
                         n=n, rho1=rho, inflation=infl, success=success, message=message)
