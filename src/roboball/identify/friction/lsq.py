"""Least squares of a friction law, the stand's calibration and the release states on all
releases at once.

scipy ``least_squares`` (trust-region reflective within the prior bounds) on the stacked
residuals y_sim - y.  Positive law parameters are fitted as their logarithms (positivity, and
the scales differ by decades).  The Jacobian is a central difference computed in the same
batched simulation as the residual (every perturbed parameter set is one more batch row,
nearly free), so each iteration costs one integration.  Starts: the priors' ``start`` values
and the best of a batch of prior draws.
"""
from __future__ import annotations

import math

import numpy as np

from roboball.identify.friction.problem import FrictionProblem


def _fd_steps(problem: FrictionProblem) -> np.ndarray:
    """Difference steps: 1e-4 in a logarithm, 1e-5 in rad, s or kg m^2."""
    return np.concatenate([[1e-5 if p.linear else 1e-4 for p in problem.priors],
                           np.full(problem.release_data.size, 1e-5)])


def _starts(problem: FrictionProblem, rng: np.random.Generator, lo: np.ndarray, hi: np.ndarray,
            n_candidates: int, n_starts: int) -> list[np.ndarray]:
    """The priors' start, plus the best prior draws that already beat it (a start in the wrong
    basin), all candidates scored in one batched evaluation; most fits need one run."""
    x_start = np.clip(problem.start_point(), lo + 1e-9, hi - 1e-9)
    cand = np.tile(problem.release_data, (n_candidates, 1))
    cand = np.concatenate([np.column_stack([p.sample_u(rng, n_candidates) for p in problem.priors])
                           if problem.n_phys else np.zeros((n_candidates, 0)), cand], axis=1)
    allc = np.vstack([x_start[None, :], cand])
    r = problem.residuals(allc)
    cost = np.where(np.all(np.isfinite(r), axis=1), 0.5 * np.sum(r * r, axis=1), np.inf)
    better = [int(i) for i in np.argsort(cost) if i != 0 and cost[i] < cost[0]]
    return [allc[0]] + [allc[i] for i in better[:max(n_starts, 1) - 1]]


def _residuals_and_jacobian(problem: FrictionProblem, eps: np.ndarray):
    """evaluate(x) -> (residuals, central-difference Jacobian), one batched simulation for
    both, the last point cached (scipy asks for the residual and the Jacobian separately)."""
    n = eps.size
    cache: dict = {}

    def evaluate(x):
        key = x.tobytes()
        if key not in cache:
            X = np.vstack([x] + [x + eps[j] * e for j, e in enumerate(np.eye(n))]
                          + [x - eps[j] * e for j, e in enumerate(np.eye(n))])
            R = problem.residuals(X)
            f = R[0]
            J = ((R[1:n + 1] - R[n + 1:]) / (2 * eps[:, None])).T
            bad = ~np.isfinite(f)
            if bad.any():
                f = np.where(bad, 1e3, f)
            cache.clear()
            cache[key] = (f, np.nan_to_num(J, nan=0.0, posinf=0.0, neginf=0.0))
        return cache[key]

    return evaluate


def _laplace_cov(problem: FrictionProblem, J: np.ndarray, sigma_hat: float) -> np.ndarray:
    """Laplace covariance with the priors' curvature as a floor (weakly identified directions
    are bounded by the prior instead of by a singular J^T J)."""
    prior_prec = []
    for p in problem.priors:
        a, b = p.interval95_u()
        prior_prec.append(1.0 / max(((b - a) / 3.92) ** 2, 1e-12))
    prior_prec += [1.0 / (problem.half_width / 2) ** 2] * problem.S
    if problem.shifts_fitted:
        prior_prec += [1.0 / (problem.shift_half_width / 2) ** 2] * problem.S
    H = J.T @ J / max(sigma_hat, 1e-12) ** 2 + np.diag(prior_prec)
    return np.linalg.pinv(H)


def least_squares_fit(problem: FrictionProblem, seed: int = 0, n_candidates: int = 64, n_starts: int = 2,
                      max_nfev: int = 200) -> dict:
    """Least-squares fit of the law's and the stand's parameters and the release states (see the
    module docstring).

    Args:
        problem: the fit problem (its step size ``dt`` is used).
        seed: seeds the prior draws that compete with the priors' start.
        n_candidates: prior draws scored as starts.
        n_starts: least-squares runs at most (the priors' start and the best draws beating it).
        max_nfev: evaluations per run.

    Returns:
        A dict: ``x`` (LSQ coordinates), ``cost`` (sum of squares / 2), ``rms``, ``sigma_hat``
        (residual RMS, the noise level's ML estimate), ``jac`` (N x n at x), ``cov`` (Laplace
        covariance of x, prior-regularised), ``nfev``, ``success``, ``message``, ``starts``.
    """
    from scipy.optimize import least_squares

    rng = np.random.default_rng(seed)
    lo, hi = problem.lsq_bounds()
    eps = _fd_steps(problem)
    starts = _starts(problem, rng, lo, hi, n_candidates, n_starts)
    evaluate = _residuals_and_jacobian(problem, eps)

    best = None
    for x0 in starts:
        x0 = np.clip(x0, lo + 1e-9, hi - 1e-9)
        res = least_squares(lambda x: evaluate(x)[0], x0, jac=lambda x: evaluate(x)[1], bounds=(lo, hi),
                            method="trf", x_scale="jac", max_nfev=max_nfev, xtol=1e-10, ftol=1e-10)
        if best is None or res.cost < best.cost:
            best = res
    f, J = evaluate(best.x)
    N = f.size
    sigma_hat = math.sqrt(2 * best.cost / N)
    cov = _laplace_cov(problem, J, sigma_hat)
    return {"x": best.x, "cost": float(best.cost), "rms": sigma_hat, "sigma_hat": sigma_hat, "jac": J,
            "cov": cov, "nfev": int(best.nfev), "success": bool(best.success), "message": str(best.message),
            "starts": len(starts)}
