"""Hydroelastic calibration (issue 25): `hydro_modulus` (Pa) and the Hunt-Crossley dissipation
(s/m) at one pressure, fitted to the recorded shell releases' `zeta` and `omega_n` by simulation
error, as the authors fitted theirs by Nelder-Mead against real logs.

Drake's hydroelastic shell does not depend on the pressure once its modulus and dissipation are
given (the pressure enters the paper's model only through eq. 10-11), so one grid of Drake
shell_rock runs over (ln modulus, ln dissipation) serves every pressure:

1. surrogate: ln zeta and ln omega_n of the grid's runs, each a least-squares cubic surface in
   (ln modulus, ln dissipation) (`Surrogate`);
2. inversion: the parameters whose surrogate values match the target, by bounded least squares
   of log errors (~ relative errors) inside the grid (`invert`);
3. Drake in the loop: Drake is run at the estimate with the pressure's own releases; the
   difference between Drake and the surrogate there is a local bias, the bias-corrected
   surrogate is inverted again, and the best Drake evaluation is kept (`calibrate`).  The
   reported zeta and omega_n are therefore Drake's at the reported parameters;
4. intervals: draws of the recorded target (the mean over releases, Student-t with its standard
   error) through the bias-corrected inverse (`intervals`).

The evaluator is any function (modulus, dissipation) -> (zeta, omega_n); the pipeline passes one
that runs Drake (roboball.pipeline.hydro), the tests a synthetic one.  No Drake here.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import pandas as pd
from scipy.optimize import least_squares, lsq_linear

from roboball.errors import RoboballError
from roboball.metrics import t_quantile

Evaluator = Callable[[float, float], tuple[float, float]]
# The damped-sine fit bounds zeta at 0.95 (roboball.identify.shell.damped_sine): a run at or
# near it did not oscillate, and its numbers are the bound, not the shell.
ZETA_MAX = 0.9


def _features(x, y) -> np.ndarray:
    """Full cubic in (x, y): 10 columns."""
    x, y = np.atleast_1d(np.asarray(x, float)), np.atleast_1d(np.asarray(y, float))
    return np.stack([np.ones_like(x), x, y, x * x, x * y, y * y, x ** 3, x * x * y, x * y * y, y ** 3], axis=1)


@dataclass
class Surrogate:
    """ln zeta and ln omega_n as cubic surfaces in (ln modulus, ln dissipation), fitted to a grid of
    Drake runs; `bounds` is the grid's box in (ln modulus, ln dissipation); `rms` the surfaces'
    RMS residual at the grid points (log units ~ relative)."""

    coef_zeta: np.ndarray
    coef_omega: np.ndarray
    bounds: tuple[np.ndarray, np.ndarray]
    rms: tuple[float, float]
    n_points: int

    @classmethod
    def fit(cls, grid: pd.DataFrame) -> "Surrogate":
        """From a grid table (hydro_modulus_pa, hydro_dissipation_s_m, zeta, omega_n_rad_s); runs
        whose decay could not be extracted (NaN: a shell that sank) or whose damped-sine fit
        stopped at its bound (zeta >= ZETA_MAX: overdamped, no oscillation to fit) are left out."""
        ok = grid[np.isfinite(grid.zeta) & np.isfinite(grid.omega_n_rad_s) & (grid.zeta > 0)
                  & (grid.zeta < ZETA_MAX)]
        if len(ok) < 12:
            raise RoboballError(f"hydroelastic grid: {len(ok)} of {len(grid)} runs gave a decay; a cubic "
                                "surface needs at least 12 (widen or move the grid in config shell.hydro_fit)")
        x, y = np.log(ok.hydro_modulus_pa.to_numpy()), np.log(ok.hydro_dissipation_s_m.to_numpy())
        a = _features(x, y)
        lz, lo = np.log(ok.zeta.to_numpy()), np.log(ok.omega_n_rad_s.to_numpy())
        cz = np.linalg.lstsq(a, lz, rcond=None)[0]
        co = np.linalg.lstsq(a, lo, rcond=None)[0]
        rms = (float(np.sqrt(np.mean((a @ cz - lz) ** 2))), float(np.sqrt(np.mean((a @ co - lo) ** 2))))
        # the box of the runs that worked: the surfaces are not trusted outside it
        bounds = (np.array([x.min(), y.min()]), np.array([x.max(), y.max()]))
        return cls(cz, co, bounds, rms, len(ok))

    def log_values(self, theta) -> np.ndarray:
        """(ln zeta, ln omega_n) at theta = (ln modulus, ln dissipation)."""
        a = _features(theta[0], theta[1])
        return np.array([(a @ self.coef_zeta)[0], (a @ self.coef_omega)[0]])

    def jacobian(self, theta, h: float = 1e-4) -> np.ndarray:
        """d(ln zeta, ln omega_n) / d(ln modulus, ln dissipation): the sensitivities that say how
        well the data fix each parameter."""
        theta = np.asarray(theta, float)
        cols = [(self.log_values(theta + h * e) - self.log_values(theta - h * e)) / (2 * h) for e in np.eye(2)]
        return np.stack(cols, axis=1)


@dataclass
class Target:
    """The recorded shell at one pressure: means over its releases and their standard errors
    (release-to-release scatter and each release's own error), with n - 1 degrees of freedom."""

    zeta: float
    zeta_se: float
    omega_n: float
    omega_n_se: float
    n: int

    @classmethod
    def of(cls, points: pd.DataFrame) -> "Target":
        """From decay rows (zeta, zeta_se, omega_n_rad_s, omega_n_se_rad_s) of one pressure."""
        pts = points[np.isfinite(points.zeta) & np.isfinite(points.omega_n_rad_s)]
        n = len(pts)
        if n == 0:
            raise RoboballError("hydroelastic calibration: no release with a damping ratio at this pressure")

        def mean_se(v, se):
            own = float(np.sqrt(np.nanmean(np.asarray(se, float) ** 2) / n))
            scatter = float(np.std(v, ddof=1) / math.sqrt(n)) if n > 1 else 0.0
            return float(np.mean(v)), math.hypot(own, scatter)

        z, zse = mean_se(pts.zeta.to_numpy(), pts.zeta_se.to_numpy())
        w, wse = mean_se(pts.omega_n_rad_s.to_numpy(), pts.omega_n_se_rad_s.to_numpy())
        return cls(z, zse, w, wse, n)

    def log_values(self) -> np.ndarray:
        return np.log([self.zeta, self.omega_n])

    def draws(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """n draws of (zeta, omega_n): Student-t with n_releases - 1 degrees of freedom (normal
        for a single release) scaled by the standard errors."""
        t = rng.standard_t(self.n - 1, size=(n, 2)) if self.n > 1 else rng.standard_normal((n, 2))
        return np.column_stack([self.zeta + self.zeta_se * t[:, 0], self.omega_n + self.omega_n_se * t[:, 1]])


def invert(sur: Surrogate, log_target: np.ndarray, bias=(0.0, 0.0), start=None, bounds=None) -> np.ndarray:
    """theta = (ln modulus, ln dissipation) inside the grid (or `bounds`) whose bias-corrected
    surrogate values are closest to `log_target` (ln zeta, ln omega_n), in log (relative) error."""
    lo, hi = bounds if bounds is not None else sur.bounds
    bias = np.asarray(bias, float)

    def resid(theta):
        return sur.log_values(theta) + bias - log_target

    if start is None:     # the best of a coarse scan: the surfaces need not be convex
        xs = np.linspace(lo[0], hi[0], 15)
        ys = np.linspace(lo[1], hi[1], 15)
        cands = [np.array([x, y]) for x in xs for y in ys]
        start = min(cands, key=lambda c: float(np.sum(resid(c) ** 2)))
    start = np.clip(start, lo + 1e-9, hi - 1e-9)
    return least_squares(resid, start, bounds=(lo, hi), xtol=1e-10, ftol=1e-12).x


@dataclass
class Evaluation:
    """One evaluator run: parameters (Pa, s/m) and the zeta, omega_n it gave."""

    modulus: float
    dissipation: float
    zeta: float
    omega_n: float

    def error(self, target: Target) -> float:
        """The larger relative error of zeta and omega_n against the target."""
        return max(abs(self.zeta / target.zeta - 1), abs(self.omega_n / target.omega_n - 1))


@dataclass
class Calibration:
    """The result at one pressure: the best evaluated point, the bias of the surrogate there,
    every evaluation on the way."""

    best: Evaluation
    bias: np.ndarray
    evaluations: list = field(default_factory=list)
    failed: list = field(default_factory=list)      # runs that gave no decay (the shell sank)
    bounds: tuple | None = None                     # the box in (ln modulus, ln dissipation) it was kept in


# A run that sank raises the floor of the modulus to just above it (ln units).
FLOOR_STEP = 0.02
# A first run that sank is retried this much stiffer (ln units: x1.16).
RETRY_STIFFER = 0.15


def calibrate(sur: Surrogate, target: Target, evaluate: Evaluator, tol: float = 0.01,
              max_evals: int = 3) -> Calibration:
    """Invert the surrogate, run the evaluator (Drake) there, then take Newton steps on Drake's
    own log errors (Broyden: the surrogate's Jacobian to start, updated by each run's secant),
    kept inside the grid, until both errors are within `tol`, `max_evals` runs are spent, or the
    next step would change zeta and omega_n by less than a tenth of `tol`.
    A run that gives no decay (Drake's softest shells sink through the ground) raises the
    modulus floor above it; the next run is taken halfway back to the last good one (or, before
    any, stiffer).  The best run is reported, with the bias of the surrogate there and the box
    the fit was kept in."""
    lo, hi = (b.copy() for b in sur.bounds)
    goal = target.log_values()
    theta = invert(sur, goal)
    jac = sur.jacobian(theta)
    evals, thetas, values, failed = [], [], [], []
    for _ in range(max_evals):
        e = Evaluation(float(math.exp(theta[0])), float(math.exp(theta[1])), *evaluate(*np.exp(theta)))
        if not (np.isfinite(e.zeta) and np.isfinite(e.omega_n) and e.zeta > 0):
            failed.append(e)
            lo[0] = max(lo[0], min(theta[0] + FLOOR_STEP, hi[0]))
            theta = 0.5 * (theta + thetas[-1]) if thetas else theta + np.array([RETRY_STIFFER, 0.0])
            theta = np.clip(theta, lo, hi)
            continue
        g = np.log([e.zeta, e.omega_n])
        if thetas:                                  # Broyden's secant update of the Jacobian
            step, dg = theta - thetas[-1], g - values[-1]
            if step @ step > 1e-14:
                jac = jac + np.outer(dg - jac @ step, step) / (step @ step)
        evals.append(e)
        thetas.append(theta.copy())
        values.append(g)
        if e.error(target) <= tol:
            break
        # the Newton step solved inside the box: with the modulus pinned at an edge the
        # dissipation still moves to match what it can (a clipped free step would not)
        step = lsq_linear(jac, goal - g, bounds=(lo - theta - 1e-12, hi - theta + 1e-12)).x
        if np.max(np.abs(jac @ step)) < tol / 10:
            # the step would move zeta and omega_n by under a tenth of the tolerance: no run can
            # come closer by what the fit asks (with the modulus pinned at the grid's softest
            # edge, the campaign's last runs moved zeta by 0.004-0.09%, a Drake run of every
            # release each)
            break
        theta = np.clip(theta + step, lo, hi)
        if np.allclose(theta, thetas[-1], atol=1e-9):
            break                                   # pinned at the box's edge: no run can do better
    if not evals:
        raise RoboballError(f"hydroelastic calibration: no run gave a decay ({len(failed)} runs from modulus "
                            f"{failed[0].modulus:.3g} Pa: a shell too soft to hold the robot sinks through the "
                            "ground): move the grid (config shell.hydro_fit)")
    k = min(range(len(evals)), key=lambda i: evals[i].error(target))
    return Calibration(evals[k], values[k] - sur.log_values(thetas[k]), evals, failed, (lo, hi))


def intervals(sur: Surrogate, target: Target, cal: Calibration, draws: int = 400, seed: int = 0,
              level: float = 0.95) -> dict:
    """Intervals of modulus and dissipation: draws of the recorded target through the surrogate's
    inverse (corrected by the bias Drake showed at the fit), as shifts from the inverse of the
    recorded mean, added to the fitted values.  Inverses stay in the box the fit was kept in
    (the grid, above any modulus at which Drake's shell sank); `at_bound` says when the fit, or
    the inverse of the recorded mean, sits on an edge of it: there the interval is one-sided."""
    rng = np.random.default_rng(seed)
    box = cal.bounds if cal.bounds is not None else sur.bounds
    theta0 = np.log([cal.best.modulus, cal.best.dissipation])
    centre = invert(sur, target.log_values(), cal.bias, start=theta0, bounds=box)
    out = []
    for z, w in target.draws(draws, rng):
        if z <= 0 or w <= 0:
            continue
        out.append(invert(sur, np.log([z, w]), cal.bias, start=centre, bounds=box) - centre)
    th = np.exp(np.clip(theta0 + np.array(out), box[0], box[1]))
    q = (50 * (1 - level), 50 * (1 + level))
    lo, hi = box
    # the fit, or the inverse of the recorded mean (a target no shell in the box reaches), on an edge
    edge = np.array([(np.abs(t - lo) < 1e-3) | (np.abs(t - hi) < 1e-3) for t in (theta0, centre)])
    return {"modulus_low": float(np.percentile(th[:, 0], q[0])), "modulus_high": float(np.percentile(th[:, 0], q[1])),
            "dissipation_low": float(np.percentile(th[:, 1], q[0])),
            "dissipation_high": float(np.percentile(th[:, 1], q[1])),
            "at_bound": bool(edge.any())}


def calibration_row(p_kpa: float, sur: Surrogate, target: Target, cal: Calibration, iv: dict) -> dict:
    """The results row of one pressure (SI units, a unit in every column name)."""
    jac = sur.jacobian(np.log([cal.best.modulus, cal.best.dissipation]))
    b = cal.best
    return {
        "pressure_kpa": p_kpa,
        "hydro_modulus_pa": b.modulus, "hydro_modulus_ci95_low_pa": iv["modulus_low"],
        "hydro_modulus_ci95_high_pa": iv["modulus_high"],
        "hydro_dissipation_s_m": b.dissipation, "hydro_dissipation_ci95_low_s_m": iv["dissipation_low"],
        "hydro_dissipation_ci95_high_s_m": iv["dissipation_high"],
        "zeta_recorded": target.zeta, "zeta_recorded_se": target.zeta_se,
        "omega_n_recorded_rad_s": target.omega_n, "omega_n_recorded_se_rad_s": target.omega_n_se,
        "n_releases": target.n,
        "zeta_drake": b.zeta, "omega_n_drake_rad_s": b.omega_n,
        "zeta_error_percent": 100 * (b.zeta / target.zeta - 1),
        "omega_n_error_percent": 100 * (b.omega_n / target.omega_n - 1),
        "at_grid_bound": iv["at_bound"], "drake_evaluations": len(cal.evaluations) + len(cal.failed),
        "drake_failed_runs": len(cal.failed),
        # elasticities of the surrogate at the fit: how strongly each output follows each parameter
        "dlnzeta_dlnmodulus": float(jac[0, 0]), "dlnzeta_dlndissipation": float(jac[0, 1]),
        "dlnomega_n_dlnmodulus": float(jac[1, 0]), "dlnomega_n_dlndissipation": float(jac[1, 1]),
        "surrogate_rms_lnzeta": sur.rms[0], "surrogate_rms_lnomega_n": sur.rms[1],
    }


def volume_law(fits: pd.DataFrame, weight_n: float) -> dict:
    """The power law V(p) = V_ref (p / p_ref)^k through the contact volumes f_n / modulus (eq. 10)
    of the calibrated moduli: weighted least squares of ln V on ln p, each pressure weighted by
    its modulus interval (standard error ~ the interval's log width / 3.92, combined with Drake's
    own scatter in omega_n through its elasticity when the table has them), p_ref the geometric
    mean pressure; 95% intervals from Student's t with n - 2 degrees of freedom."""
    from roboball.physics.shell import volume_of_modulus

    f = fits.sort_values("pressure_kpa")
    n = len(f)
    if n == 0:
        raise RoboballError("contact-volume law: no calibrated modulus")
    p = f.pressure_kpa.to_numpy() * 1e3
    lnv = np.log(volume_of_modulus(weight_n, f.hydro_modulus_pa.to_numpy()))
    if n == 1:                  # one pressure: its volume, no law through it (exponent unknown)
        nan = float("nan")
        return {"v_ref_m3": float(np.exp(lnv[0])), "v_ref_ci95_low_m3": nan, "v_ref_ci95_high_m3": nan,
                "p_ref_pa": float(p[0]), "exponent": nan, "exponent_ci95_low": nan, "exponent_ci95_high": nan,
                "n_pressures": 1, "dof": -1}
    se = np.log(f.hydro_modulus_ci95_high_pa / f.hydro_modulus_ci95_low_pa).to_numpy() / 3.92
    if {"surrogate_rms_lnomega_n", "dlnomega_n_dlnmodulus"} <= set(f.columns):
        # Drake's own scatter in omega_n (the surrogate's residual: release size, mesh) through the
        # elasticity: a modulus pinned at the grid's edge has a zero-width interval, not a certain value
        drake = (f.surrogate_rms_lnomega_n / f.dlnomega_n_dlnmodulus.abs().clip(lower=1e-3)).to_numpy()
        se = np.hypot(se, drake)
    se = np.maximum(se, 1e-3)
    p_ref = float(np.exp(np.mean(np.log(p))))
    a = np.column_stack([np.ones(n), np.log(p / p_ref)])
    w = 1.0 / se
    coef, *_ = np.linalg.lstsq(a * w[:, None], lnv * w, rcond=None)
    dof = n - 2
    res = (lnv - a @ coef) * w
    s2 = float(res @ res / dof) if dof > 0 else 1.0
    cov = s2 * np.linalg.inv((a * w[:, None]).T @ (a * w[:, None]))
    q = t_quantile(0.975, max(dof, 1))
    k, k_se = float(coef[1]), float(math.sqrt(cov[1, 1]))
    v_ref, lnv_se = float(math.exp(coef[0])), float(math.sqrt(cov[0, 0]))
    return {"v_ref_m3": v_ref, "v_ref_ci95_low_m3": v_ref * math.exp(-q * lnv_se),
            "v_ref_ci95_high_m3": v_ref * math.exp(q * lnv_se), "p_ref_pa": p_ref,
            "exponent": k, "exponent_ci95_low": k - q * k_se, "exponent_ci95_high": k + q * k_se,
            "n_pressures": n, "dof": dof}


def acceptance_failures(table: pd.DataFrame, limit_percent: float = 10.0) -> list[str]:
    """Issue 25's acceptance 2 on a calibration table: at every pressure Drake's zeta and omega_n
    at the fitted values within `limit_percent` of the recorded ones (recomputed from the values,
    not read from the error columns), and finite 95% intervals that hold the fitted values.
    Returns what fails, one line each (empty: it holds)."""
    out = []
    for r in table.itertuples():
        for name, sim, rec in (("zeta", r.zeta_drake, r.zeta_recorded),
                               ("omega_n", r.omega_n_drake_rad_s, r.omega_n_recorded_rad_s)):
            err = 100 * (sim / rec - 1)
            if not abs(err) <= limit_percent:
                out.append(f"{r.pressure_kpa:g} kPa: {name} {sim:.4g} vs recorded {rec:.4g} ({err:+.1f}%)")
        for name, unit in (("hydro_modulus", "pa"), ("hydro_dissipation", "s_m")):
            v, lo, hi = (getattr(r, f"{name}_{unit}"), getattr(r, f"{name}_ci95_low_{unit}"),
                         getattr(r, f"{name}_ci95_high_{unit}"))
            if not (np.isfinite([v, lo, hi]).all() and 0 < lo <= v * (1 + 1e-9) and v <= hi * (1 + 1e-9)):
                out.append(f"{r.pressure_kpa:g} kPa: {name} {v:.4g} outside its interval [{lo:.4g}, {hi:.4g}]")
    return out
