"""The RK4 step of a friction fit, chosen at the least-squares optimum.

The largest of 5, 2.5, 1.25, 0.625, 0.3125 and 0.15625 ms whose integration error (change
against half the step) shifts no fitted parameter by more than 0.2 of its standard deviation: a
per-sample criterion is not enough, a systematic error adds up over thousands of samples.

The two smallest steps are for quiet logs.  The implicit stiction step decides at each step
whether the joint sticks, so the likelihood jumps where a parameter moves a stick from one step
to the next: on the twin's steer-stand log (0.8 mrad noise) with Coulomb + viscous friction the
log-likelihood jitters by 1.0-1.7 (sd about a quadratic over +-2 Laplace sd of mu_d, c, delta_i,
rest_offset; tests/identify/test_timestep.py) at 0.625 ms, 0.4-0.9 at 0.3125 ms and 0.23-0.64
at 0.15625 ms.  At 0.625 ms (then the smallest step, failing the tolerance: 0.52 sd) the chain
mixed at acceptance 0.14-0.16 and did not converge in 6000 steps (tau 176); at 0.15625 ms
(0.08 sd) it converged at 1200 steps (tau 7, acceptance 0.32).  The sampler's adaptation phase
runs no finer than 0.625 ms (:func:`adaptation_dt`): 1250-1400 steps (tau 8-11) in 42-55 s
alone, against 55 s for the 3000 capped steps before.

Not 10 ms: the step is judged at the optimum only, and at 10 ms the regularised stiction band
of eq. 2 (|v| < v_tol = 0.01 rad/s, slope mu_s / v_tol) is stepped over.  On the real steer log
(noise 0.05 rad, so 10 ms passed at the optimum, mu_s = 0.16 N m) the Coulomb + viscous
posterior found a spurious region at mu_s > 1.5 N m that fitted better at 10 ms than the
converged solution (residual RMS 49.0 against 49.3 mrad; 54-97 mrad at 5 ms and below) and
trapped its walkers.  At 5 ms and below the residuals agree to 0.1 mrad there.
"""
from __future__ import annotations

import numpy as np

from roboball.identify.friction.problem import FrictionProblem

DT_CANDIDATES = (5e-3, 2.5e-3, 1.25e-3, 6.25e-4, 3.125e-4, 1.5625e-4)
DT_TOLERANCE = 0.2            # integration-induced parameter shift allowed, in posterior sd
ADAPT_DT_MIN = 6.25e-4        # the sampler's adaptation phase runs no finer than this


def adaptation_dt(dt: float) -> float:
    """The RK4 step of the sampler's adaptation phase for a fit at step `dt`: `dt` itself down to
    0.625 ms, 0.625 ms below it.  The adaptation's samples only shape the sampler's proposal
    (production runs at `dt`), and at 0.625 ms they land where the posterior lies (on the twin's
    quiet stand log the medians within 0.2 sd of the 0.156 ms chain's).  The quiet log's chain
    then converges at 1250-1400 steps in 42-55 s alone, against 1200 steps in 74-77 s at 0.156 ms
    throughout."""
    return max(float(dt), ADAPT_DT_MIN)


def choose_dt(problem: FrictionProblem, lsq: dict, candidates=DT_CANDIDATES,
              tolerance: float = DT_TOLERANCE) -> tuple[float, dict]:
    """Largest RK4 step whose integration error is negligible FOR THE FIT, at the LSQ optimum.

    A per-sample error small next to the noise is not enough: a systematic error e repeated
    over N samples biases well-determined parameters by about |e| sqrt(N) / sigma standard
    deviations.  So the criterion is the parameter shift the error causes, linearised in the
    Laplace approximation: dx = cov J^T (y_dt - y_dt/2) / sigma^2, which must stay below
    `tolerance` x the Laplace standard deviation of every parameter (law and stand parameters,
    release states).  The prior's curvature in ``cov`` keeps a direction the data do not
    determine (Majd's n near 1) from amplifying the error, as an unregularised pinv(J) did
    (it sent the real log's Majd fit to the smallest step, 10x slower, for no accuracy).
    y_dt/2 stands in for the exact solution (its error is 4-16 times smaller).  Returns (dt, info) with info =
    {"max_shift_sd", "max_error_rad", "dt_s"} at the chosen step (the smallest candidate if
    none passes, which the fit then reports).
    """
    x = lsq["x"]
    J = lsq["jac"]
    sd = np.sqrt(np.clip(np.diag(lsq["cov"]), 1e-300, None))
    gain = lsq["cov"] @ J.T / max(lsq["sigma_hat"], 1e-12) ** 2
    prev = problem.predict(x[None, :], dt=candidates[0])[0]
    info = {}
    for dt in candidates:
        half = problem.predict(x[None, :], dt=dt / 2)[0]
        e = prev - half
        e = np.where(np.isfinite(e), e, 0.0)
        shift = float(np.max(np.abs(gain @ e) / sd))
        info = {"dt_s": dt, "max_shift_sd": shift, "max_error_rad": float(np.max(np.abs(e)))}
        if shift <= tolerance:
            return dt, info
        prev = half
    return candidates[-1], info
