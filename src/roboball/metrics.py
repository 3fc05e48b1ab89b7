"""Scores shared by the stages: the paper's point mean error (eq. 12) and its companions, the
information criterion and effective sample size the diagnosis selects by, and the burn-in and
autocorrelation time that say whether an MCMC chain has converged.  Plain functions of arrays,
imported by identification, simulation, diagnosis and reports alike."""
from __future__ import annotations

import math

import numpy as np

# Eq. 12 leaves out the first instants after release, where the measured speed is near zero
# and the ratio is undefined.
SPEED_FLOOR_RAD_S = 0.5


# ---- quantiles of Student's t and chi-square --------------------------------------------------
# scipy.stats costs about a second of import in every job that reads it; its t and chi2 ppf are
# these special functions (times scale 1, plus loc 0), so the values are the same to the bit
# (tests/metrics/test_quantiles.py).
def t_quantile(p: float, dof: float) -> float:
    """The p-quantile of Student's t with `dof` degrees of freedom (scipy.stats.t.ppf)."""
    from scipy.special import stdtrit

    return float(stdtrit(float(dof), p))


def chi2_quantile(p, dof: float) -> np.ndarray:
    """The p-quantiles (array) of chi-square with `dof` degrees of freedom (scipy.stats.chi2.ppf):
    NaN where dof <= 0, as there."""
    from scipy.special import gammaincinv

    p = np.asarray(p, dtype=float)
    if not dof > 0:
        return np.full(p.shape, np.nan)
    return 2 * gammaincinv(np.asarray(dof, dtype=float) / 2, p)


# ---- ramp descents: eq. 12 ------------------------------------------------------------------
def relative_errors(w_measured, w_sim, floor: float) -> np.ndarray:
    """Eq. 12's samples, (w_s - w_e) / w_e, at the samples whose measured speed reaches `floor`
    (the first instants after release, where w_e ~ 0 and the ratio is undefined, are left out)."""
    w_e = np.asarray(w_measured, float)
    w_s = np.asarray(w_sim, float)
    ok = np.abs(w_e) >= floor
    return (w_s[ok] - w_e[ok]) / w_e[ok]


def pme(w_measured, w_sim, floor: float = SPEED_FLOOR_RAD_S) -> float:
    """Point mean error (eq. 12) in percent, over-predicting models positive.

    The paper's text says "simulated subtracted from measured, such that overestimated models
    are positive"; the two halves disagree in sign, and we keep the stated intent: a simulation
    faster than the robot gives a positive PME:
        PME = 100/N sum (w_s - w_e) / w_e.
    Samples where the measured speed is below `floor` (the first instants after release,
    where w_e ~ 0) are left out, since the ratio is undefined there."""
    rel = relative_errors(w_measured, w_sim, floor)
    return float(100.0 * np.mean(rel)) if rel.size else float("nan")


def speed_errors(w_measured, w_sim, floor: float = SPEED_FLOOR_RAD_S) -> dict:
    """Eq. 12's PME and two errors that cannot cancel, for one descent:
    * `pme_percent`: eq. 12, the signed mean (`pme`);
    * `mape_percent`: the mean ABSOLUTE point error, 100/N sum |w_s - w_e| / |w_e| over the same
      samples.  Eq. 12 lets a model that runs fast early and slow late score near zero; this
      one does not;
    * `rmse_rad_s`: the RMS of w_s - w_e over the whole scored window (no floor), the quantity
      the diagnosis fits."""
    rel = relative_errors(w_measured, w_sim, floor)
    w_e = np.asarray(w_measured, float)
    w_s = np.asarray(w_sim, float)
    nan = float("nan")
    return {"pme_percent": float(100.0 * np.mean(rel)) if rel.size else nan,
            "mape_percent": float(100.0 * np.mean(np.abs(rel))) if rel.size else nan,
            "rmse_rad_s": float(np.sqrt(np.mean((w_s - w_e) ** 2))) if w_e.size else nan}


def pme_table(summary):
    """Eq. 12 per contact model and pressure over the ramp runs of `summary` (a DataFrame with
    one row per run: contact, pressure_kpa, pme_percent): the mean, the run range and the run
    count; the friction-posterior range (min of pme_draw_low, max of pme_draw_high) and the means
    of the errors that cannot cancel (mape_percent, rmse_rad_s) where the runs carry them.  One
    table for Figs. 13/14 and for `roboball report --params`."""
    keys = ["contact", "pressure_kpa"]
    g = summary.groupby(keys)
    out = g.agg(pme_mean_percent=("pme_percent", "mean"), pme_min_percent=("pme_percent", "min"),
                pme_max_percent=("pme_percent", "max"), runs=("pme_percent", "size")).reset_index()
    if "pme_draw_low" in summary:
        post = g.agg(pme_post_low_percent=("pme_draw_low", "min"),
                     pme_post_high_percent=("pme_draw_high", "max")).reset_index()
        out = out.merge(post, on=keys, how="left")
    if {"mape_percent", "rmse_rad_s"} <= set(summary.columns):
        errs = g.agg(mape_mean_percent=("mape_percent", "mean"), rmse_mean_rad_s=("rmse_rad_s", "mean")).reset_index()
        out = out.merge(errs, on=keys, how="left")
    return out


# ---- model selection: BIC with correlated residuals -----------------------------------------
def lag1(residuals: dict) -> float:
    """Lag-1 autocorrelation of residuals (one array per release), pooled within releases."""
    num = den = 0.0
    for r in residuals.values():
        r = r - np.mean(r)
        num += float(np.sum(r[1:] * r[:-1]))
        den += float(np.sum(r * r))
    return num / den if den > 0 else 0.0


def n_eff(n: int, rho: float) -> float:
    """Effective number of independent samples of an AR(1) residual with lag-1 correlation rho."""
    rho = min(max(rho, 0.0), 0.995)
    return max(n * (1.0 - rho) / (1.0 + rho), 10.0)


def inflated_variance(rss: float, n: int, k: int, rho: float) -> float:
    """The noise variance per effectively independent sample of a fit (RSS over n - k, times
    n / n_eff): the unit of its likelihood ratios (roboball.diagnose.keep, .profile)."""
    return rss / max(n - k, 1) * n / n_eff(n, rho)


def residual_tau_int(r: np.ndarray) -> float:
    """Integrated autocorrelation time (samples) of a residual series, its autocorrelation summed
    to the first zero crossing: how many samples one independent sample is worth."""
    r = r - r.mean()
    acf = np.correlate(r, r, "full")[len(r) - 1:] / (r @ r)
    cut = np.argmax(acf < 0) or len(acf)
    return float(max(1.0, 1.0 + 2.0 * acf[1:cut].sum()))


def bic(rss: float, n: int, k: int, neff: float) -> float:
    """Bayesian information criterion of a least-squares fit (k parameters, n samples counted
    as `neff` independent ones)."""
    return neff * math.log(max(rss, 1e-300) / n) + k * math.log(neff)


# ---- MCMC convergence ------------------------------------------------------------------------
def burn_and_tau(chain: np.ndarray) -> tuple[int, np.ndarray]:
    """Burn-in (5 tau from the second half, at most half the chain) and the integrated
    autocorrelation time tau after it, per coordinate (chain: steps x walkers x ndim)."""
    import emcee

    n = chain.shape[0]
    # A coordinate that has not moved yet (all walkers stuck, a very short chain) gives NaN:
    # count it as correlated over the whole chain, i.e. not converged, rather than crash.
    tau_half = np.nan_to_num(emcee.autocorr.integrated_time(chain[n // 2:], tol=0), nan=float(n))
    burn = int(min(n // 2, math.ceil(5 * np.max(tau_half))))
    tau = np.nan_to_num(emcee.autocorr.integrated_time(chain[burn:], tol=0), nan=float(n))
    return burn, tau
