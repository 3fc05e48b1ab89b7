"""The result of a friction fit: posterior summaries, fit statistics and chain diagnostics.

Reported per parameter: median, 95% interval, MAP, least-squares value, mean, sd, integrated
autocorrelation time and effective sample size n_walkers x n_after_burn / tau.  Fit
statistics: residual RMS, log-likelihood at the MAP sample and its maximum, BIC (k ln N -
2 ln L_max, k counting law parameters, sigma and release angles) and WAIC from posterior draws.

Reported with the law: the stand's calibration (``delta_i``, ``rest_offset``) when it was
fitted, and each release's angle and instant shift.  A Majd fit samples its stiction peak
(``h_peak``, ``v_peak``) in place of sigma and omega_c (:mod:`roboball.physics.friction`);
those are reported too, derived from each sample (``"derived"``: no prior, no identifiability
of their own).

Identifiability.  Some Majd parameters are poorly constrained by swing decays: with n = 1 the
sigma terms of eq. 3 cancel exactly (the law does not depend on sigma), and near n = 1 only
sigma (n - 1) is identified, hence the sampled peak.  Nothing is fixed behind the user's
back: such parameters are sampled under their prior, and each is reported with
``identifiability`` = posterior 95% width / prior 95% width (log scale for positive
parameters); above 0.5 it is flagged ``weakly_identified`` and listed in ``notes`` (its
interval then mostly restates the prior).
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from roboball.identify.friction.priors import STAND_UNITS, Prior
from roboball.identify.friction.problem import FrictionProblem
from roboball.identify.friction.segments import JOINT_OF_KIND
from roboball.physics import friction

WEAK_IDENTIFIABILITY = 0.5
INTEGRATION = "RK4 + implicit stiction step (roboball.reduced.planar, compiled loop roboball.reduced.kernel)"


def _natural(problem: FrictionProblem, U: np.ndarray) -> np.ndarray:
    """Sampling coordinates -> natural units (law and stand parameters, the noise level; the
    release states unchanged)."""
    Z = np.array(U, dtype=float, copy=True)
    for i, p in enumerate(problem.priors):
        Z[..., i] = p.theta(Z[..., i])
    Z[..., problem.n_phys] = np.exp(Z[..., problem.n_phys])
    return Z


def _waic(problem: FrictionProblem, U: np.ndarray) -> float:
    """WAIC (deviance scale) from posterior draws U (one batched simulation)."""
    r = problem.residuals(problem.to_lsq(U))
    sigma = np.exp(U[:, problem.n_phys])[:, None]
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
    entry["unit"] = {**friction.UNITS, **STAND_UNITS}.get(name, "rad")
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
                U_map: np.ndarray) -> tuple[dict, dict, list]:
    """(law and stand parameters and the noise level by name, sampled release states by kind
    ("angles", "shifts"), notes)."""
    nat = _natural(problem, flat)
    map_nat = _natural(problem, U_map)
    x_lsq = lsq["x"]
    k = problem.n_phys
    lsq_nat = np.concatenate([[p.theta(x_lsq[i]) for i, p in enumerate(problem.priors)], [lsq["sigma_hat"]],
                              x_lsq[k:]])
    n_after = post["chain"].shape[0] - post["burn"]
    params, releases, notes = {}, {"angles": [], "shifts": []}, []
    all_priors = problem.priors + [problem.noise_prior]
    for j, name in enumerate(problem.names):
        entry = _entry(nat[:, j], map_nat[j], lsq_nat[j], post["tau"][j], post["n_walkers"], n_after)
        if j < k + 1:
            notes += _prior_checks(entry, name, all_priors[j], flat[:, j])
            params[name] = entry
        else:
            entry["unit"] = "s" if name.startswith("release_shift") else "rad"
            entry["source"] = "posterior (marginalised)"
            releases["shifts" if name.startswith("release_shift") else "angles"].append(entry)
    for name, col in _derived(problem, flat).items():
        ref = [_derived(problem, U[None, :])[name][0] for U in (U_map, _sampling_point(problem, lsq))]
        params[name] = _entry(col, ref[0], ref[1], np.nan, 0, 0)
        params[name].update(unit=friction.UNITS[name], derived="from the sampled stiction peak "
                            "(roboball.physics.friction.majd_from_peak)", identifiability=None, weakly_identified=False)
    return params, releases, notes


def _derived(problem: FrictionProblem, U: np.ndarray) -> dict:
    """The law's own parameters that the fit does not sample (Majd's sigma and omega_c), per row
    of sampling coordinates U."""
    params = problem.law_params(U[:, :problem.n_phys])
    return {name: np.broadcast_to(params[name], (U.shape[0],)) for name in friction.PARAMS[problem.law]
            if name not in problem.law_names and name not in problem.fixed}


def _sampling_point(problem: FrictionProblem, lsq: dict) -> np.ndarray:
    """The least-squares optimum in sampling coordinates (its release states as they are)."""
    x = lsq["x"]
    return np.concatenate([x[:problem.n_phys], [np.log(lsq["sigma_hat"])], x[problem.n_phys:]])


def _conditioned_releases(problem: FrictionProblem, lsq: dict) -> dict:
    """The release states a conditional posterior held at their least-squares values."""
    sd = np.sqrt(np.clip(np.diag(lsq["cov"])[problem.n_phys:], 0, None))
    out = {"angles": [], "shifts": []}
    for name, q, e in zip(problem.release_names, problem.release_fixed, sd):
        shift = name.startswith("release_shift")
        out["shifts" if shift else "angles"].append(
            {"median": float(q), "ci95_low": float(q - 1.96 * e), "ci95_high": float(q + 1.96 * e),
             "map": float(q), "lsq": float(q), "unit": "s" if shift else "rad",
             "source": "least squares (Laplace interval); the posterior is conditioned on it"})
    return out


def _fit_statistics(problem: FrictionProblem, lsq: dict, flat: np.ndarray, U_map: np.ndarray, seed: int,
                    n_waic_draws: int) -> dict:
    """Residual RMS, log-likelihoods, BIC and WAIC (two batched simulations)."""
    r_map = problem.residuals(problem.to_lsq(U_map[None, :]))[0]
    ll_map = float(problem.log_likelihood(U_map[None, :], r_map[None, :])[0])
    N = problem.N
    ll_max_lsq = -0.5 * N * (math.log(2 * math.pi * lsq["sigma_hat"] ** 2) + 1.0)
    ll_max = max(ll_max_lsq, ll_map)
    k_bic = problem.n_phys + 1 + len(problem.release_names)   # law and stand, noise level, release states
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
    """Law and stand parameters (and Majd's derived sigma and omega_c) and the noise level after
    burn-in, thinned by half the slowest tau."""
    tau = post["tau"]
    thin = max(1, int(np.nanmax(tau) // 2)) if np.any(np.isfinite(tau)) else 1
    kept = post["chain"][post["burn"]::thin].reshape(-1, problem.ndim)
    nat = _natural(problem, kept)[:, :problem.n_phys + 1]
    df = pd.DataFrame(nat, columns=problem.phys_names + ["noise_rad"])
    for name, col in _derived(problem, kept).items():
        df.insert(problem.n_law, name, col)
    return df


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
        and the flat posterior samples (law and stand parameters and ``noise_rad``).
    """
    burn = post["burn"]
    flat = post["chain"][burn:].reshape(-1, problem.ndim)
    flat_lp = post["log_prob"][burn:].reshape(-1)
    U_map = flat[int(np.argmax(flat_lp))]
    params, releases, notes = _parameters(problem, lsq, post, flat, U_map)
    if not problem.releases_sampled:
        releases = _conditioned_releases(problem, lsq)
    if problem.law == "majd" and "n" in params and "h_peak" in params and params["n"]["ci95_low"] < 1.1:
        notes.append("majd: n reaches 1 within the 95% interval; at n = 1 the sigma terms of eq. 3 cancel, "
                     "so sigma itself is not identified there (its interval is open upwards); the sampled "
                     "stiction peak (h_peak, v_peak) is")
    fit_stats = _fit_statistics(problem, lsq, flat, U_map, seed, n_waic_draws)
    conv = _convergence(problem, post)
    if not post["converged"]:
        notes.append(f"NOT CONVERGED: the chain stopped at max_steps = {post['max_steps']} with "
                     f"{conv['chain_over_tau']:.1f} autocorrelation times after burn-in "
                     f"(required {post['autocorr_multiple']:g})")
    res = {"kind": problem.kind, "joint": JOINT_OF_KIND.get(problem.kind, problem.kind), "law": problem.law,
           "parameters": params, "fixed": {k_: float(v) for k_, v in problem.fixed.items()},
           "stand_calibrated": bool(problem.stand_names),
           "release_angles": releases["angles"], "release_shifts_s": releases["shifts"],
           "release_times_s": [float(s.t_release) for s in problem.segments],
           "fit": fit_stats, "convergence": conv,
           "integration": {"method": INTEGRATION, "dt_s": problem.dt, "step_error_rad": step_error},
           "angles_sampled": problem.releases_sampled, "chain": post["chain_path"],
           "seed": int(seed), "notes": notes}
    return res, _samples(problem, post)
