"""The RK4 step of a friction fit, chosen at the least-squares optimum.

The largest of 5, 2.5, 1.25, 0.625, 0.3125 and 0.15625 ms whose integration error (change
against half the step) shifts no fitted parameter by more than 0.2 of its standard deviation: a
per-sample criterion is not enough, a systematic error adds up over thousands of samples.

The two smallest steps are for quiet logs.  The likelihood is smooth at every step: eq. 2's
torque jumps at the stiction band's edges, and the integrator cuts a step at an edge and steps
each side on its own branch (roboball.reduced.kernel).  Stepped across instead, the jump made the
log-likelihood jitter with the parameters: on the twin's steer-stand log (0.8 mrad noise) by
1.0-1.7 about a quadratic at 0.625 ms and 0.23-0.64 at 0.15625 ms, the step it then needed for a
chain that mixed (1200-1400 steps at acceptance 0.2, 42-92 s).  With the edges located: 0.003-0.03
at every step (tests/identify/test_timestep.py), the step chosen for its bias alone, 1.25 ms
(0.11 sd), and the chain converges in 1000 steps at acceptance 0.42, in 20 s.

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
    (production runs at `dt`); on the twin's quiet stand log, when its Coulomb + viscous fit still
    ran at 0.156 ms, the adaptation's medians at 0.625 ms lay within 0.2 sd of the fine chain's
    and the chain took 42-55 s instead of 74-77 s."""
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
