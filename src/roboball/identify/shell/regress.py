"""Pressure regressions of the shell's damping ratio and natural frequency (paper Fig. 10).

The paper fits an exponential to the damping ratio and a line to the natural frequency
of the locked-steer shell tests over inflation pressure:

    zeta(p)    = a exp(b p)        (p in kPa)
    omega_n(p) = c + d p

and injects the result into the model as C_inject(p) and K_inject(p) (eq. 7-8).  Here both
are fitted by weighted least squares (nonlinear Gauss-Newton/trust-region for the
exponential, exact for the line).  The weights are taken as *relative*: the covariance is
scaled by the reduced chi-square.  95% intervals use the Student-t quantile with n - 2 degrees
of freedom; confidence and prediction bands come from the same covariance by the delta method.

A decay table's releases (`fit_regressions`) are weighted by 1 / (se^2 + tau^2), not 1 / se^2.
Repeated releases at one pressure can scatter far more than their fits' standard errors say:
a membrane shell's damping depends on the release amplitude, and a small release is fitted
more tightly *and* damps more (docs/modelling.md).  Weighted by 1 / se^2 alone, the curve
follows the small releases and passes above two of the three releases at every pressure.  tau,
the scatter between releases that their errors do not explain, is the Paule-Mandel estimate of
meta-analysis (the generalised chi-square equals its degrees of freedom; DerSimonian & Kacker
2007), so a release counts by its total error and the curve estimates the mean over the
releases recorded.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np
import pandas as pd
from scipy.optimize import brentq, least_squares

from roboball.errors import RoboballError
from roboball.metrics import chi2_quantile, t_quantile

__all__ = [
    "RegressionFit",
    "Regressions",
    "fit_zeta_exp",
    "fit_omega_linear",
    "fit_regressions",
    "regression_table",
]


@dataclass
class RegressionFit:
    """A fitted curve y = f(x; theta) with its covariance.

    `names`/`units` label the parameters; `cov` is scaled by the reduced chi-square `s2`
    (so it reflects the actual scatter); `dof` = n - k; `sigma_scale` is the typical
    per-point standard error of the data (1 when unweighted), used for prediction bands.
    """

    label: str
    names: tuple[str, ...]
    units: tuple[str, ...]
    params: np.ndarray
    cov: np.ndarray
    dof: int
    s2: float
    sigma_scale: float
    x: np.ndarray
    y: np.ndarray
    se: np.ndarray | None
    model: Callable[[np.ndarray, np.ndarray], np.ndarray] = field(repr=False)
    gradient: Callable[[np.ndarray, np.ndarray], np.ndarray] = field(repr=False)
    response: tuple[str, str] = ("y", "1")    # the fitted quantity's name and unit
    tau: float = 0.0    # scatter between releases beyond their errors (the value's unit); in `se`
    tau_ci: tuple[float, float] | None = None    # its 95% Q-profile interval, when it was estimated

    def predict(self, x) -> np.ndarray:
        return self.model(np.asarray(x, dtype=float), self.params)

    def t_quantile(self, level: float = 0.95) -> float:
        return t_quantile(0.5 + level / 2.0, max(self.dof, 1))

    def value(self, name: str) -> float:
        return float(self.params[self.names.index(name)])

    def stderr(self, name: str) -> float:
        i = self.names.index(name)
        return float(math.sqrt(max(self.cov[i, i], 0.0)))

    def ci(self, name: str, level: float = 0.95) -> tuple[float, float]:
        """Two-sided interval on one parameter: value +- t_{dof} se."""
        v, se = self.value(name), self.stderr(name)
        q = self.t_quantile(level)
        return v - q * se, v + q * se

    def band(self, x, level: float = 0.95, kind: str = "confidence") -> tuple[np.ndarray, np.ndarray]:
        """Pointwise band at x.  kind="confidence": where the mean curve lies; kind=
        "prediction": where a new measurement falls (adds the residual variance)."""
        x = np.asarray(x, dtype=float)
        G = self.gradient(x, self.params)  # shape (len(x), k)
        var = np.einsum("ij,jk,ik->i", G, self.cov, G)
        if kind == "prediction":
            var = var + self.s2 * self.sigma_scale ** 2
        elif kind != "confidence":
            raise ValueError("kind must be 'confidence' or 'prediction'")
        half = self.t_quantile(level) * np.sqrt(np.maximum(var, 0.0))
        yhat = self.predict(x)
        return yhat - half, yhat + half

    def rows(self, level: float = 0.95) -> list[dict]:
        out = []
        for name, unit in zip(self.names, self.units):
            lo, hi = self.ci(name, level)
            out.append({"name": name, "value": self.value(name), "se": self.stderr(name),
                        "ci95_low": lo, "ci95_high": hi, "unit": unit,
                        "n_points": len(self.x), "dof": self.dof})
        if self.tau_ci is not None:      # the scatter the weights carry, with its own interval
            name, unit = self.response
            out.append({"name": f"{name}_tau", "value": self.tau, "se": float("nan"),
                        "ci95_low": self.tau_ci[0], "ci95_high": self.tau_ci[1], "unit": unit,
                        "n_points": len(self.x), "dof": self.dof})
        return out


def _clean(x, y, se, what: str):
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if x.shape != y.shape or x.ndim != 1:
        raise RoboballError(f"{what}: pressures and values must be 1-D and of equal length")
    ok = np.isfinite(x) & np.isfinite(y)
    w = None
    if se is not None:
        se = np.asarray(se, dtype=float)
        if se.shape != x.shape:
            raise RoboballError(f"{what}: standard errors must match the values in length")
        ok &= np.isfinite(se) & (se > 0)
    x, y = x[ok], y[ok]
    if se is not None:
        w = se[ok]
    if len(x) < 3 or len(np.unique(x)) < 2:
        raise RoboballError(
            f"{what}: need at least 3 points at 2 or more pressures to fit 2 parameters "
            f"(got {len(x)} points at {len(np.unique(x))} pressures)"
        )
    return x, y, w


def _finish(label, names, units, model, gradient, x, y, se, theta, response) -> RegressionFit:
    sig = se if se is not None else np.ones_like(y)
    G = gradient(x, theta) / sig[:, None]
    r = (y - model(x, theta)) / sig
    dof = len(x) - len(theta)
    s2 = float(r @ r) / dof if dof > 0 else float("nan")
    try:
        cov = np.linalg.inv(G.T @ G) * s2
    except np.linalg.LinAlgError:
        cov = np.full((len(theta), len(theta)), np.nan)
    scale = float(np.sqrt(np.mean(sig ** 2)))
    return RegressionFit(label=label, names=names, units=units, params=np.asarray(theta, dtype=float),
                         cov=cov, dof=dof, s2=s2, sigma_scale=scale, x=x, y=y, se=se,
                         model=model, gradient=gradient, response=response)


def _exp_model(x, th):
    return th[0] * np.exp(th[1] * x)


def _exp_grad(x, th):
    e = np.exp(th[1] * np.asarray(x, dtype=float))
    return np.column_stack([e, th[0] * np.asarray(x, dtype=float) * e])


def _lin_model(x, th):
    return th[0] + th[1] * np.asarray(x, dtype=float)


def _lin_grad(x, th):
    x = np.asarray(x, dtype=float)
    return np.column_stack([np.ones_like(x), x])


def fit_zeta_exp(p_kpa: Sequence[float], zeta: Sequence[float], zeta_se: Sequence[float] | None = None) -> RegressionFit:
    """Fit zeta(p) = a exp(b p) by (weighted) nonlinear least squares.

    Starts from the (weighted) straight line through ln(zeta); parameters `zeta_a` (1) and
    `zeta_b` (1/kPa)."""
    x, y, se = _clean(p_kpa, zeta, zeta_se, "zeta(p) regression")
    if np.any(y <= 0):
        raise RoboballError("zeta(p) regression: damping ratios must be positive for an exponential fit")
    sig = se if se is not None else np.ones_like(y)
    # ln zeta has standard error se / zeta.
    wl = (y / sig) ** 2
    b0, ln_a0 = np.polyfit(x, np.log(y), 1, w=np.sqrt(wl))
    th0 = np.array([math.exp(ln_a0), b0])

    res = least_squares(lambda th: (_exp_model(x, th) - y) / sig, th0,
                        jac=lambda th: _exp_grad(x, th) / sig[:, None],
                        method="lm", xtol=1e-14, ftol=1e-14, gtol=1e-14, max_nfev=10_000)
    return _finish("zeta(p) = a exp(b p)", ("zeta_a", "zeta_b"), ("1", "1/kPa"),
                   _exp_model, _exp_grad, x, y, se, res.x, ("zeta", "1"))


def fit_omega_linear(p_kpa: Sequence[float], omega: Sequence[float], se: Sequence[float] | None = None) -> RegressionFit:
    """Fit omega_n(p) = c + d p by (weighted) linear least squares; parameters
    `omega_n_c` (rad/s) and `omega_n_d` (rad/s/kPa)."""
    x, y, w = _clean(p_kpa, omega, se, "omega_n(p) regression")
    sig = w if w is not None else np.ones_like(y)
    A = np.column_stack([np.ones_like(x), x]) / sig[:, None]
    theta, *_ = np.linalg.lstsq(A, y / sig, rcond=None)
    return _finish("omega_n(p) = c + d p", ("omega_n_c", "omega_n_d"), ("rad/s", "rad/s/kPa"),
                   _lin_model, _lin_grad, x, y, w, theta, ("omega_n", "rad/s"))


@dataclass
class Regressions:
    """Both pressure regressions of a decay table, with their band evaluators."""

    zeta: RegressionFit
    omega_n: RegressionFit

    def table(self, level: float = 0.95) -> pd.DataFrame:
        return pd.DataFrame(self.zeta.rows(level) + self.omega_n.rows(level),
                            columns=["name", "value", "se", "ci95_low", "ci95_high", "unit", "n_points", "dof"])

    def zeta_band(self, p_kpa, level: float = 0.95, kind: str = "confidence"):
        return self.zeta.band(p_kpa, level, kind)

    def omega_n_band(self, p_kpa, level: float = 0.95, kind: str = "confidence"):
        return self.omega_n.band(p_kpa, level, kind)


def _solve_tau2(fit: Callable[..., RegressionFit], p_kpa, y, se, target: float) -> float:
    """The tau^2 >= 0 at which `fit(p_kpa, y, sqrt(se^2 + tau^2))` leaves the generalised
    chi-square Q = `target` (0 when Q is already at or below it with no scatter).  Q falls from
    its unweighted-by-tau value toward 0 as tau grows, so one root brackets it."""

    def excess(tau2: float) -> float:
        s = np.sqrt(se ** 2 + tau2)
        f = fit(p_kpa, y, s)
        r = (y - f.predict(p_kpa)) / s
        return float(r @ r) - target

    if excess(0.0) <= 0.0:
        return 0.0
    top = float(np.var(y)) + float(np.max(se)) ** 2
    while excess(top) > 0.0:      # falls to -target as tau grows: the bracket is found
        top *= 4.0
    return brentq(excess, 0.0, top, xtol=1e-14 * top, rtol=1e-12)


def between_release_sd(fit: Callable[..., RegressionFit], p_kpa, y, se) -> float:
    """Paule-Mandel tau: the scatter between releases that their standard errors `se` do not
    explain, the tau >= 0 at which `fit(p_kpa, y, sqrt(se^2 + tau^2))` leaves a chi-square equal
    to its degrees of freedom (0 when the errors explain the scatter)."""
    p_kpa, y, se = _clean(p_kpa, y, se, "between-release scatter")      # the rows `fit` keeps
    return math.sqrt(_solve_tau2(fit, p_kpa, y, se, float(len(y) - 2)))


def between_release_sd_interval(fit: Callable[..., RegressionFit], p_kpa, y, se,
                                level: float = 0.95) -> tuple[float, float]:
    """Q-profile interval on tau (Viechtbauer 2007): the taus whose generalised chi-square lies
    between the chi-square distribution's (1 -+ level) / 2 quantiles on n - 2 degrees of freedom.

    Args:
        fit: `fit_zeta_exp` or `fit_omega_linear`.
        p_kpa, y, se: the releases' pressures, values and standard errors.
        level: coverage of the interval.

    Returns:
        (low, high) of tau, in the values' unit; low is 0 when the releases are consistent with no scatter.
    """
    p_kpa, y, se = _clean(p_kpa, y, se, "between-release scatter")
    dof = len(y) - 2
    hi_q, lo_q = chi2_quantile([0.5 + level / 2.0, 0.5 - level / 2.0], dof)
    return (math.sqrt(_solve_tau2(fit, p_kpa, y, se, float(hi_q))),
            math.sqrt(_solve_tau2(fit, p_kpa, y, se, float(lo_q))))


def _heterogeneous(fit: Callable[..., RegressionFit], p_kpa, y, se) -> RegressionFit:
    """`fit` weighted by each release's total error sqrt(se^2 + tau^2) (the module's note)."""
    if se is None:
        return fit(p_kpa, y, None)
    tau = between_release_sd(fit, p_kpa, y, se)
    out = fit(p_kpa, y, np.sqrt(np.asarray(se, dtype=float) ** 2 + tau ** 2))
    out.tau = tau
    out.tau_ci = between_release_sd_interval(fit, p_kpa, y, se)
    return out


def fit_regressions(decay_df: pd.DataFrame, weighted: bool = True) -> Regressions:
    """Fit zeta(p) and omega_n(p) to a decay table (columns pressure_kpa, zeta, zeta_se,
    omega_n_rad_s, omega_n_se_rad_s; see roboball.identify.shell.decay.decay_table).  Rows without a
    pressure are ignored.  `weighted`: weight each release by its total error, its standard
    error and the scatter between releases (`between_release_sd`); else all alike."""
    need = ["pressure_kpa", "zeta", "omega_n_rad_s"]
    missing = [c for c in need if c not in decay_df.columns]
    if missing:
        raise RoboballError(f"decay table: missing column(s) {', '.join(missing)}")
    df = decay_df[np.isfinite(decay_df["pressure_kpa"].astype(float))]
    def weights(col: str):
        if not weighted or col not in df:
            return None
        w = df[col].to_numpy(float)
        # All or nothing: one missing error makes the whole fit unweighted.
        return w if np.all(np.isfinite(w) & (w > 0)) else None

    zse = weights("zeta_se")
    wse = weights("omega_n_se_rad_s")
    p = df["pressure_kpa"].to_numpy(float)
    return Regressions(
        zeta=_heterogeneous(fit_zeta_exp, p, df["zeta"].to_numpy(float), zse),
        omega_n=_heterogeneous(fit_omega_linear, p, df["omega_n_rad_s"].to_numpy(float), wse),
    )


def regression_table(decay_df: pd.DataFrame, weighted: bool = True, level: float = 0.95) -> pd.DataFrame:
    """One row per regression parameter (zeta_a, zeta_b, omega_n_c, omega_n_d): name,
    value, se, ci95_low, ci95_high, unit, n_points, dof; when weighted, also each regression's
    scatter between releases (zeta_tau, omega_n_tau: se empty, Q-profile interval).  The band evaluators are on
    :func:`fit_regressions`' result."""
    return fit_regressions(decay_df, weighted=weighted).table(level)
