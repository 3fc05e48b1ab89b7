"""The emcee posterior of a friction fit, run (or resumed) until it has converged.

Sampled: every law parameter, the stand's calibration, the noise level sigma and the release
states (marginalised: the friction levels are correlated with the release amplitudes, so
conditioning on fitted angles would give too-narrow intervals).  Walkers start from the
least-squares Laplace approximation; differential-evolution moves adapt, then an independence
proposal (multivariate t fitted to the samples so far, refitted at each stage of
:data:`ADAPT_SCHEDULE`, then frozen) mixed with DE moves samples
(:mod:`roboball.identify.friction.moves`).  All walkers of a proposal are simulated in
one vectorised call (``vectorize=True``).  The adaptation may run at a coarser RK4 step than the
fit's (``adapt_dt``: its samples only shape the proposal); production runs at the fit's step.
The chain is stored in emcee's HDF5 layout, a chunk of steps at a time
(:mod:`roboball.identify.friction.backend`); an interrupted run resumes from the stored chain
and its random state (:mod:`roboball.identify.friction.chain`).

Convergence is measured, not assumed: the chain runs in chunks until its post-burn-in length
is at least ``autocorr_multiple`` (default 50) times the integrated autocorrelation time of
every parameter (``get_autocorr_time(tol=0)``), or ``max_steps`` is reached, in which case the
result says ``converged: false``.  Burn-in = 5 tau (from the second half of the chain), at
most half of it, counted after the adaptation phase (tau is measured on the production phase
only).
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from roboball.errors import RoboballError
from roboball.identify.friction.chain import steps_to_resume, write_meta
from roboball.identify.friction.moves import adapted_moves, default_moves
from roboball.identify.friction.problem import FrictionProblem
from roboball.metrics import burn_and_tau

# Adaptation: DE moves up to the first step count, then an independence proposal fitted to the
# DE samples, refitted at each later count to its own (far less correlated) samples, and frozen
# at the last.  The third stage matters where the least squares start far from the posterior's
# bulk (the real steer log's Majd fit: its least squares stop at f_c = 0.49 N m, the posterior
# lies below 0.07): a proposal fitted while the walkers still drift sticks walkers in the
# regions it under-proposes (slowest tau 69-85 steps, not converged in 2500 steps, with two
# stages; 18 steps, converged at 1450, with three).  The fourth: a weakly identified level (the
# real log's Coulomb + viscous mu_s, flat from its lower bound to about 0.4 N m) is still being
# spread over at 400 steps, and whether a proposal frozen there covered it depended on the seed
# (seeds 0-2: tau 92-138, not converged at 3000 steps; refitted at 800: tau 6-7, converged at
# 1200; the real Majd fit, 1 of 3 seeds before, 4 of 4 after; benchmarks/friction_speed.py).
ADAPT_SCHEDULE = (100, 200, 400, 800)


@dataclass(frozen=True)
class _Plan:
    """How the chain is run: the checked settings of :func:`sample_posterior`."""

    n_walkers: int
    autocorr_multiple: float
    max_steps: int
    chunk: int
    min_steps: int
    moves: object          # the given moves, or None: adapt along `schedule`
    schedule: tuple        # adaptation step counts, () with given moves
    adapt_dt: float | None = None   # the RK4 step of the adaptation phase (None: the problem's own)

    @property
    def adaptive(self) -> bool:
        return self.moves is None

    @property
    def adapt(self) -> int:
        """Steps of the adaptation phase (0 without adaptation)."""
        return self.schedule[-1] if self.adaptive else 0

    def stage_of(self, n_done: int) -> int:
        return sum(n_done >= a for a in self.schedule)

    def target(self, n: int, stage: int) -> int:
        """Chain length to run to next: the next chunk, cut at the next stage and at max_steps."""
        target = min(self.max_steps, (n // self.chunk + 1) * self.chunk)
        if stage < len(self.schedule):
            target = min(target, self.schedule[stage])
        return target


def _plan(problem: FrictionProblem, n_walkers, autocorr_multiple, max_steps, chunk, moves, min_steps,
          adapt_schedule: Sequence[int], stale: str, adapt_dt: float | None = None) -> _Plan:
    if problem.ndim * 2 > n_walkers:
        raise RoboballError(f"friction fit: {n_walkers} walkers for {problem.ndim} parameters; emcee needs at "
                            f"least {2 * problem.ndim}")
    adaptive = moves is None
    schedule = tuple(int(a) for a in adapt_schedule) if adaptive else ()
    if adaptive and (not schedule or any(b <= a for a, b in zip(schedule, schedule[1:])) or schedule[0] < 2):
        raise RoboballError(f"friction fit: adaptation schedule {schedule} must be increasing step counts >= 2")
    if stale not in ("refuse", "restart"):
        raise ValueError(f"stale must be 'refuse' or 'restart', not {stale!r}")
    if adapt_dt == problem.dt:
        adapt_dt = None
    if adapt_dt is not None and (not adaptive or not adapt_dt > 0):
        raise RoboballError(f"friction fit: an adaptation step ({adapt_dt}) needs the adaptive sampler and a "
                            "positive step")
    return _Plan(n_walkers, autocorr_multiple, max_steps, chunk, min_steps, moves, schedule, adapt_dt)


def _chain_meta(problem: FrictionProblem, plan: _Plan, seed: int, code: str | None) -> dict:
    """What a stored chain must match to be continued."""
    return {"fingerprint": problem.fingerprint(), "names": problem.names, "law": problem.law,
            "kind": problem.kind, "n_walkers": int(plan.n_walkers), "seed": int(seed), "dt": problem.dt,
            "sampler": f"adaptive-independence-t/{'-'.join(map(str, plan.schedule))}" if plan.adaptive
            else "given-moves",
            "code": code, **({"adapt_dt": plan.adapt_dt} if plan.adapt_dt is not None else {})}


def _initial_walkers(problem: FrictionProblem, lsq: dict, n_walkers: int, rng: np.random.Generator) -> np.ndarray:
    """Walkers drawn from the least-squares Laplace approximation, inside the prior support."""
    x = lsq["x"]
    cov = lsq["cov"]
    if not problem.releases_sampled:    # conditional on the release states: inverse of H's other block
        k = problem.n_phys
        x = x[:k]
        cov = np.linalg.pinv(np.linalg.pinv(cov)[:k, :k])
    w, V = np.linalg.eigh(0.5 * (cov + cov.T))
    L = V * np.sqrt(np.clip(w, 0, None))
    sig_u = math.log(max(lsq["sigma_hat"], 1.1 * problem.noise_prior.low))
    out = np.empty((0, problem.ndim))
    for _ in range(200):
        z = rng.standard_normal((4 * n_walkers, x.size))
        X = x[None, :] + z @ L.T
        s = sig_u + rng.standard_normal((4 * n_walkers, 1)) / math.sqrt(2 * problem.N)
        U = np.concatenate([X[:, :problem.n_phys], s, X[:, problem.n_phys:]], axis=1)
        U = U[np.isfinite(problem.log_prior(U))]
        out = np.vstack([out, U])
        if out.shape[0] >= n_walkers:
            break
    if out.shape[0] < n_walkers:
        raise RoboballError("friction fit: cannot place the walkers inside the prior support around the "
                            "least-squares optimum; check the priors' bounds")
    U = out[:n_walkers]
    lp = problem.log_prob(U)
    for _ in range(20):                          # replace walkers that start in a failed simulation
        bad = ~np.isfinite(lp)
        if not bad.any():
            break
        U[bad] = U[rng.choice(np.nonzero(~bad)[0], bad.sum())] + 1e-6 * rng.standard_normal((bad.sum(), problem.ndim))
        lp[bad] = problem.log_prob(U[bad])
    return U



def _make_sampler(problem: FrictionProblem, backend, plan: _Plan, stage: int):
    import emcee

    # a new sampler on a used backend continues from its last sample and random state
    if not plan.adaptive:
        mv = plan.moves
    elif stage == 0:
        mv = default_moves(plan.n_walkers, problem.ndim)
    else:
        mv = adapted_moves(backend.get_chain(), stage, plan.schedule, problem.priors)
    return emcee.EnsembleSampler(plan.n_walkers, problem.ndim, problem.log_prob, vectorize=True,
                                 backend=backend, moves=mv)


def _start(problem: FrictionProblem, lsq: dict, backend, plan: _Plan, resumed_from: int, seed: int):
    """(sampler, stage, initial walkers) to run from: fresh walkers and seeded random state for a
    new chain, the stored chain's last state (initial None) for a resumed one."""
    if resumed_from > 0:
        stage = plan.stage_of(resumed_from)
        return _make_sampler(problem, backend, plan, stage), stage, None
    rng = np.random.default_rng([seed, 1])
    initial = _initial_walkers(problem, lsq, plan.n_walkers, rng)
    sampler = _make_sampler(problem, backend, plan, 0)
    sampler._random = np.random.RandomState(np.random.SeedSequence([seed, 2]).generate_state(1)[0])
    return sampler, 0, initial


def _measure(backend, n: int, plan: _Plan) -> tuple[int, np.ndarray, bool]:
    """(burn-in, tau, converged) of the chain's first `n` steps.  Only the production phase
    (adapt = 0 without adaptation) is judged, once it has min_steps steps: its samples come
    from one fixed kernel."""
    judge = n >= plan.adapt + plan.min_steps
    start = plan.adapt if judge else 0
    burn_rel, tau = burn_and_tau(backend.get_chain()[start:])
    burn = start + burn_rel
    converged = judge and np.all(np.isfinite(tau)) and (n - burn) >= plan.autocorr_multiple * float(np.max(tau))
    return burn, tau, bool(converged)


def _run(problem: FrictionProblem, backend, plan: _Plan, sampler, stage: int, initial) -> tuple[int, np.ndarray, bool]:
    """Extend the chain chunk by chunk (a new sampler at each adaptation stage) until it has
    converged or reached max_steps; returns (burn-in, tau, converged).  With ``plan.adapt_dt`` the
    adaptation phase runs at that step and production at the problem's own, on which the walkers'
    log-probabilities are recomputed where production starts."""
    fine_dt = problem.dt
    converged = False
    burn, tau = 0, np.full(problem.ndim, np.nan)
    try:
        while True:
            n = backend.iteration
            if n >= plan.min_steps:
                burn, tau, converged = _measure(backend, n, plan)
                if converged:
                    break
            if n >= plan.max_steps:
                break
            if plan.stage_of(n) != stage:
                stage = plan.stage_of(n)
                sampler = _make_sampler(problem, backend, plan, stage)
            state = initial if n == 0 else None
            if plan.adapt_dt is not None:
                problem.dt = plan.adapt_dt if n < plan.adapt else fine_dt
                if n == plan.adapt:       # the walkers' log-probabilities were the adaptation step's
                    import emcee
                    last = backend.get_last_sample()
                    state = emcee.State(last.coords, random_state=last.random_state)
            sampler.run_mcmc(state, plan.target(n, stage) - n, progress=False)
            backend.flush()
            initial = None
    finally:
        problem.dt = fine_dt
    return burn, tau, converged


def sample_posterior(problem: FrictionProblem, lsq: dict, chain_path: str | os.PathLike, seed: int = 0,
                     n_walkers: int = 32, autocorr_multiple: float = 50.0, max_steps: int = 20000,
                     chunk: int = 50, moves=None, min_steps: int = 100,
                     adapt_schedule: Sequence[int] = ADAPT_SCHEDULE, stale: str = "refuse",
                     code: str | None = None, adapt_dt: float | None = None) -> dict:
    """Run (or resume) the emcee chain in `chain_path` until converged or `max_steps`.

    A stored chain is resumed only if it belongs to this fit: the same data, priors, robot facts,
    sampler settings and the same `code`.  Another fit's chain is refused (`stale="refuse"`, for
    a chain a user keeps) or deleted and sampled afresh (`stale="restart"`, the pipeline's:
    there the chain is a resumable cache of its rule).

    With ``moves=None`` the chain adapts, then samples with a frozen kernel.  Adaptation:
    differential-evolution moves from the Laplace start up to ``adapt_schedule[0]`` steps, then
    an independence proposal (:class:`~roboball.identify.friction.moves.IndependentT`) fitted to
    the DE samples, refitted at each later count of the schedule to the samples since the
    previous one.  Production, from ``adapt_schedule[-1]`` on: the last proposal, frozen, mixed
    with DE moves.  On the test bed's Majd steer fit this cut the integrated autocorrelation
    time from about 37 steps (DE alone) to about 14 (:data:`ADAPT_SCHEDULE` for the third
    stage).  Burn-in and tau are measured on the production phase only (burn-in >=
    ``adapt_schedule[-1]``), so the reported samples come from one fixed kernel.  Given
    `moves`, one phase with those moves (burn-in from the whole chain).

    Args:
        code: identity of the source code that computes the log-probability, stored with the
            chain so that a chain sampled by other code is not continued.  The pipeline passes
            the source fingerprint of roboball.identify.friction.fit (roboball.pipeline.codedeps);
            None records no code identity.
        adapt_dt: the RK4 step of the adaptation phase, when it differs from the problem's own
            (:func:`~roboball.identify.friction.timestep.adaptation_dt`): its samples only shape
            the proposal, production runs at the problem's step, so the posterior is that
            step's.  None: the problem's step throughout.

    Returns:
        ``chain`` (steps, walkers, ndim) in sampling coordinates, ``log_prob``, ``burn``, ``tau``,
        ``converged``, ``acceptance``, ``n_steps``, ``resumed_from``, and the settings
        ``n_walkers``, ``autocorr_multiple``, ``max_steps``, ``chain_path``, ``adapt_schedule``.
    """
    from roboball.identify.friction.backend import ChunkedHDFBackend

    chain_path = Path(chain_path)
    chain_path.parent.mkdir(parents=True, exist_ok=True)
    plan = _plan(problem, n_walkers, autocorr_multiple, max_steps, chunk, moves, min_steps, adapt_schedule, stale,
                 adapt_dt)
    meta = _chain_meta(problem, plan, seed, code)
    resumed_from = steps_to_resume(chain_path, meta, stale)
    backend = ChunkedHDFBackend(str(chain_path), name="mcmc")  # checkpoint: resumable emcee chain, checked by fingerprint on reuse
    if resumed_from == 0:
        backend.reset(n_walkers, problem.ndim)
        write_meta(chain_path, meta)
    sampler, stage, initial = _start(problem, lsq, backend, plan, resumed_from, seed)
    burn, tau, converged = _run(problem, backend, plan, sampler, stage, initial)
    chain = backend.get_chain()
    return {"chain": chain, "log_prob": backend.get_log_prob(), "burn": int(burn), "tau": np.asarray(tau),
            "converged": bool(converged), "acceptance": backend.accepted / max(backend.iteration, 1),
            "n_steps": int(backend.iteration), "resumed_from": resumed_from, "n_walkers": int(n_walkers),
            "autocorr_multiple": float(autocorr_multiple), "max_steps": int(max_steps), "chain_path": str(chain_path),
            "adapt_schedule": list(plan.schedule)}
