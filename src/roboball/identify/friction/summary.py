"""The result of a friction fit: posterior summaries, fit statistics and chain diagnostics.

Reported per parameter: median, 95% interval, MAP, least-squares value, mean, sd, integrated
autocorrelation time and effective sample size n_walkers x n_after_burn / tau.  Fit
statistics: residual RMS, log-likelihood at the MAP sample and its maximum, BIC (k ln N -
2 ln L_max, k counting law parameters, sigma and release angles) and WAIC from posterior draws.

Identifiability.  Some Majd parameters are poorly constrained by swing decays: with n = 1 the
sigma terms of eq. 3 cancel exactly (the law does not depend on sigma), and near n = 1 only
sigma (n - 1) is identified.  Nothing is fixed behind the user's back: such parameters are
sampled under their prior, and each is reported with ``identifiability`` = posterior 95% width
/ prior 95% width (log scale for positive parameters); above 0.5 it is flagged
``weakly_identified`` and listed in ``notes`` (its interval then mostly restates the prior).
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from roboball.identify.friction.priors import Prior
from roboball.identify.friction.problem import FrictionProblem
from roboball.identify.friction.segments import JOINT_OF_KIND
from roboball.physics import friction

WEAK_IDENTIFIABILITY = 0.5
INTEGRATION = "RK4 + implicit stiction step (roboball.reduced.planar, compiled loop roboball.reduced.kernel)"


def _natural(problem: FrictionProblem, U: np.ndarray) -> np.ndarray:
    """Sampling coordinates -> natural units (law parameters, sigma; angles unchanged)."""
    Z = np.array(U, dtype=float, copy=True)
    for i, p in enumerate(problem.priors):
        Z[..., i] = p.theta(Z[..., i])
    Z[..., problem.n_law] = np.exp(Z[..., problem.n_law])
    return Z


def _waic(problem: FrictionProblem, U: np.ndarray) -> float:
    """WAIC (deviance scale) from posterior draws U (one batched simulation)."""
    r = problem.residuals(problem.to_lsq(U))
    sigma = np.exp(U[:, problem.n_law])[:, None]
    ll = -np.log(sigma) - 0.5 * (r / sigma) ** 2 - 0.5 * math.log(2 * math.pi)
    ll = ll[np.all(np.isfinite(ll), axis=1)]
    if ll.shape[0] < 2:
        return float("nan")
    m = ll.max(axis=0)
    lppd = np.sum(m + np.log(np.mean(np.exp(ll - m), axis=0)))
    p_waic = np.sum(np.var(ll, axis=0, ddof=1))
    return float(-2 * (lppd - p_waic))




def _entry(col: np.ndarray, map_value: float, lsq_value: float, tau: float, n_walkers: int, n_after: int) -> dict:
    """Posterior summary of one sampled quantity (natural units)."""
    lo, med, hi = np.percentile(col, [2.5, 50, 97.5])
    return {"median": float(med), "ci95_low": float(lo), "ci95_high": float(hi),
            "map": float(map_value), "lsq": float(lsq_value),
            "mean": float(col.mean()), "std": float(col.std()),
            "tau_steps": float(tau) if np.isfinite(tau) else None,
            "ess": float(n_walkers * n_after / tau) if np.isfinite(tau) and tau > 0 else None}


def _prior_checks(entry: dict, name: str, pr: Prior, u: np.ndarray) -> list[str]:
    """Add the prior and the identifiability ratio to `entry` (u: the posterior samples on the
    sampling coordinate); notes for a weakly identified parameter or one at a prior bound."""
    notes = []
    entry["unit"] = friction.UNITS.get(name, "rad")
    entry["prior"] = pr.describe()
    a, b = pr.interval95_u()
    ul, uh = np.percentile(u, [2.5, 97.5])
    ratio = float((uh - ul) / (b - a)) if math.isfinite(b - a) and b > a else None
    entry["identifiability"] = ratio
    entry["weakly_identified"] = bool(ratio is not None and ratio > WEAK_IDENTIFIABILITY)
    if entry["weakly_identified"]:
        notes.append(f"{name}: weakly identified (95% posterior width is {ratio:.0%} of the prior's, "
                     "log scale); its interval mostly restates the prior")
    edge = min(abs(ul - pr.u_low), abs(uh - pr.u_high)) if math.isfinite(pr.u_low) else abs(uh - pr.u_high)
    if edge < 0.02 * (b - a):
        notes.append(f"{name}: the posterior reaches a prior bound; widen the prior if the bound "
                     "is not physical")
    return notes


def _parameters(problem: FrictionProblem, lsq: dict, post: dict, flat: np.ndarray,
                U_map: np.ndarray) -> tuple[dict, list, list]:
    """(law parameters and noise level by name, sampled release angles, notes)."""
    nat = _natural(problem, flat)
    map_nat = _natural(problem, U_map)
    x_lsq = lsq["x"]
    lsq_nat = np.concatenate([[p.theta(x_lsq[i]) for i, p in enumerate(problem.priors)], [lsq["sigma_hat"]],
                              x_lsq[problem.n_law:]])
    n_after = post["chain"].shape[0] - post["burn"]
    params, angles, notes = {}, [], []
    all_priors = problem.priors + [problem.noise_prior]
    for j, name in enumerate(problem.names):
        entry = _entry(nat[:, j], map_nat[j], lsq_nat[j], post["tau"][j], post["n_walkers"], n_after)
        if j < problem.n_law + 1:
            notes += _prior_checks(entry, name, all_priors[j], flat[:, j])
            params[name] = entry
        else:
            entry["unit"] = "rad"
            entry["source"] = "posterior (marginalised)"
            angles.append(entry)
    return params, angles, notes


def _conditioned_angles(problem: FrictionProblem, lsq: dict) -> list[dict]:
    """The release angles a conditional posterior held at their least-squares values."""
    sd = np.sqrt(np.clip(np.diag(lsq["cov"])[problem.n_law:], 0, None))
    return [{"median": float(q), "ci95_low": float(q - 1.96 * e), "ci95_high": float(q + 1.96 * e),
             "map": float(q), "lsq": float(q), "unit": "rad",
             "source": "least squares (Laplace interval); the posterior is conditioned on it"}
            for q, e in zip(problem.q0_fixed, sd)]


def _fit_statistics(problem: FrictionProblem, lsq: dict, flat: np.ndarray, U_map: np.ndarray, seed: int,
                    n_waic_draws: int) -> dict:
    """Residual RMS, log-likelihoods, BIC and WAIC (two batched simulations)."""
    r_map = problem.residuals(problem.to_lsq(U_map[None, :]))[0]
    ll_map = float(problem.log_likelihood(U_map[None, :], r_map[None, :])[0])
    N = problem.N
    ll_max_lsq = -0.5 * N * (math.log(2 * math.pi * lsq["sigma_hat"] ** 2) + 1.0)
    ll_max = max(ll_max_lsq, ll_map)
    k_bic = problem.n_law + 1 + problem.S         # law parameters, noise level, release angles
    rng = np.random.default_rng([seed, 3])
    draws = flat[rng.choice(flat.shape[0], min(n_waic_draws, flat.shape[0]), replace=False)]
    return {"rmse_rad": float(np.sqrt(np.mean(r_map ** 2))), "rmse_lsq_rad": float(lsq["rms"]),
            "loglik_map": ll_map, "loglik_max": float(ll_max), "n_obs": int(N), "n_params": int(k_bic),
            "bic": float(k_bic * math.log(N) - 2 * ll_max), "waic": _waic(problem, draws),
            "lsq_success": lsq["success"], "lsq_nfev": lsq["nfev"]}


def _convergence(problem: FrictionProblem, post: dict) -> dict:
    """Chain diagnostics: length, burn-in, tau and ESS (slowest and per parameter), acceptance."""
    tau = post["tau"]
    n_after = post["chain"].shape[0] - post["burn"]
    any_tau = np.any(np.isfinite(tau))
    acc = np.asarray(post["acceptance"], dtype=float)
    ess = [post["n_walkers"] * n_after / t for t in tau if np.isfinite(t) and t > 0]
    return {"converged": post["converged"], "steps": post["n_steps"], "burn_in": post["burn"],
            "max_tau": float(np.nanmax(tau)) if any_tau else float("nan"),
            "ess_min": float(min(ess)) if ess else float("nan"),
            "acceptance_fraction": float(np.mean(post["acceptance"])),
            "acceptance_fraction_min": float(acc.min()),
            "n_walkers": post["n_walkers"], "autocorr_multiple": post["autocorr_multiple"],
            "max_steps": post["max_steps"],
            "chain_over_tau": float(n_after / np.nanmax(tau)) if any_tau else None,
            "tau_steps": {n: (float(t) if np.isfinite(t) else None) for n, t in zip(problem.names, tau)},
            "ess": {n: (float(post["n_walkers"] * n_after / t) if np.isfinite(t) and t > 0 else None)
                    for n, t in zip(problem.names, tau)},
            "resumed_from_steps": post["resumed_from"]}


def _samples(problem: FrictionProblem, post: dict) -> pd.DataFrame:
    """Law parameters and noise level after burn-in, thinned by half the slowest tau."""
    tau = post["tau"]
    thin = max(1, int(np.nanmax(tau) // 2)) if np.any(np.isfinite(tau)) else 1
    kept = post["chain"][post["burn"]::thin].reshape(-1, problem.ndim)
    return pd.DataFrame(_natural(problem, kept)[:, :problem.n_law + 1], columns=problem.law_names + ["noise_rad"])


def summarize(problem: FrictionProblem, lsq: dict, post: dict, seed: int = 0, n_waic_draws: int = 200,
              step_error: float | None = None) -> tuple[dict, pd.DataFrame]:
    """The fit's result and its posterior samples.

    Args:
        problem, lsq, post: the fit problem, its least squares and its chain
            (:func:`~roboball.identify.friction.sampler.sample_posterior`).
        seed: seeds the posterior draws of the WAIC.
        step_error: the integration error at the chosen step, reported with it.

    Returns:
        The JSON-serialisable result (what a fit file holds, :mod:`roboball.identify.friction.results`)
        and the flat posterior samples (law parameters and ``noise_rad``).
    """
    burn = post["burn"]
    flat = post["chain"][burn:].reshape(-1, problem.ndim)
    flat_lp = post["log_prob"][burn:].reshape(-1)
    U_map = flat[int(np.argmax(flat_lp))]
    params, angles, notes = _parameters(problem, lsq, post, flat, U_map)
    if not problem.angles_sampled:
        angles += _conditioned_angles(problem, lsq)
    if problem.law == "majd" and "n" in params and "sigma" in params and params["n"]["ci95_low"] < 1.1:
        notes.append("majd: n reaches 1 within the 95% interval; at n = 1 the sigma terms of eq. 3 cancel, "
                     "so sigma is only identified through sigma (n - 1)")
    fit_stats = _fit_statistics(problem, lsq, flat, U_map, seed, n_waic_draws)
    conv = _convergence(problem, post)
    if not post["converged"]:
        notes.append(f"NOT CONVERGED: the chain stopped at max_steps = {post['max_steps']} with "
                     f"{conv['chain_over_tau']:.1f} autocorrelation times after burn-in "
                     f"(required {post['autocorr_multiple']:g})")
    res = {"kind": problem.kind, "joint": JOINT_OF_KIND.get(problem.kind, problem.kind), "law": problem.law,
           "parameters": params, "fixed": {k_: float(v) for k_, v in problem.fixed.items()},
           "release_angles": angles, "release_times_s": [float(s.t_release) for s in problem.segments],
           "fit": fit_stats, "convergence": conv,
           "integration": {"method": INTEGRATION, "dt_s": problem.dt, "step_error_rad": step_error},
           "angles_sampled": problem.angles_sampled, "chain": post["chain_path"],
           "seed": int(seed), "notes": notes}
    return res, _samples(problem, post)
