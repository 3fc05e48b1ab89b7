"""Joint-friction identification on stand recordings: least squares, then emcee posteriors.

Model: ONE friction law (roboball.physics.friction) on ONE joint, in the reduced stand model
of :mod:`roboball.reduced.planar` (steer stand: viscous, coulomb_viscous or majd; drive stand: any law,
the paper fits majd).  Data: every release of a stand recording at once, a list of segments
(t, y, release) with y the measured joint angle from the release instant to the end of the
free response.  Each release starts from rest at an initial angle that is a nuisance
parameter (initialised from the data, fitted, and marginalised in the posterior).

1. Least squares (scipy ``least_squares``, trust-region reflective within the prior bounds)
   on the stacked residuals y_sim - y of all releases.  Positive law parameters are fitted
   as their logarithms (positivity, and the scales differ by decades).  The Jacobian is a
   central difference computed in the same batched simulation as the residual (every
   perturbed parameter set is one more batch row, nearly free), so each iteration costs one
   integration.  Starts: the priors' ``start`` values and the best of a batch of prior draws.
2. Step size: the RK4 step is chosen at the least-squares optimum as the largest of
   10, 5, 2.5, 1.25, 0.625 ms whose integration error (change against half the step) shifts
   no fitted parameter by more than 0.2 of its standard deviation (:func:`choose_dt`; a
   per-sample criterion is not enough, a systematic error adds up over thousands of samples).
3. emcee: posterior of every law parameter, the noise level sigma (Gaussian likelihood,
   independent residuals) and the release angles (marginalised: the friction levels are
   correlated with the release amplitudes, so conditioning on fitted angles would give
   too-narrow intervals).  Walkers start from the least-squares
   Laplace approximation; differential-evolution moves adapt, then an independence proposal
   (multivariate t fitted to the samples so far, refitted once, then frozen) mixed with DE
   moves samples (:func:`sample_posterior`).  All walkers of a proposal are simulated in one vectorised call
   (``vectorize=True``).  The chain is stored with ``emcee.backends.HDFBackend``; an
   interrupted run resumes from the stored chain (and its random state).
4. Convergence is measured, not assumed: the chain runs in chunks until its post-burn-in
   length is at least ``autocorr_multiple`` (default 50) times the integrated
   autocorrelation time of every parameter (``get_autocorr_time(tol=0)``), or ``max_steps``
   is reached, in which case the result says ``converged: false``.  Burn-in = 5 tau (from
   the second half of the chain), at most half of it, counted after the adaptation phase
   (tau is measured on the production phase only).  Reported: acceptance fraction, tau and
   effective sample size n_walkers x n_after_burn / tau per parameter.
5. Model comparison: residual RMS, log-likelihood at the MAP sample and its maximum, BIC
   (k ln N - 2 ln L_max, k counting law parameters, sigma and release angles) and WAIC from
   posterior draws.

Identifiability.  Some Majd parameters are poorly constrained by swing decays: with n = 1
the sigma terms of eq. 3 cancel exactly (the law does not depend on sigma), and near n = 1
only sigma (n - 1) is identified.  Nothing is fixed behind the user's back: such parameters
are sampled under their prior, and each is reported with ``identifiability`` = posterior
95% width / prior 95% width (log scale for positive parameters); above 0.5 it is flagged
``weakly_identified`` and listed in ``notes`` (its interval then mostly restates the prior).

Priors: ``configs/priors.yaml`` (validated by ``configs/schema/priors.schema.yaml`` and
:func:`roboball.checks.check_priors`), per joint, law and parameter: ``uniform`` (low, high),
``loguniform`` (low, high) or ``lognormal`` (median, sigma_log, optional low/high), each with
a ``start`` for the least squares.  The noise level has a log-uniform prior on
[1e-5, 0.2] rad; each release angle a uniform prior +-0.25 rad around the data's value.

Every random draw comes from the ``seed`` argument.
"""
from __future__ import annotations

import functools
import hashlib
import json
import math
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
import pandas as pd

from roboball.reduced import planar as reduced
from roboball.config import CONFIG_DIR, RobotFacts, load_robot, load_yaml, validate
from roboball.errors import ConfigError, RoboballError
from roboball.metrics import burn_and_tau
from roboball.physics import friction

__all__ = [
    "Segment",
    "Prior",
    "FrictionProblem",
    "segments_from_arrays",
    "load_priors",
    "law_priors",
    "least_squares_fit",
    "choose_dt",
    "sample_posterior",
    "summarize",
    "fit_segments",
    "fit",
    "comparison",
    "KIND_OF_JOINT",
    "NOISE_PRIOR",
]

KIND_OF_JOINT = {"steer": "steer_stand", "drive": "drive_stand"}
JOINT_OF_KIND = {v: k for k, v in KIND_OF_JOINT.items()}
NOISE_PRIOR = {"type": "loguniform", "low": 1e-5, "high": 0.2, "start": 1e-3}
RELEASE_HALF_WIDTH_RAD = 0.25
DT_CANDIDATES = (1e-2, 5e-3, 2.5e-3, 1.25e-3, 6.25e-4)
DT_TOLERANCE = 0.2            # integration-induced parameter shift allowed, in posterior sd
WEAK_IDENTIFIABILITY = 0.5
# Adaptation: DE moves up to the first step count, then an independence proposal fitted to the
# DE samples, refitted at the second count to its own (far less correlated) samples and frozen.
ADAPT_SCHEDULE = (100, 200)


# ---------------------------------------------------------------------------------------------
# Data
# ---------------------------------------------------------------------------------------------
@dataclass
class Segment:
    """One release: sample times ``t`` (s, recording time base, all >= t_release), measured
    angles ``y`` (rad), the release instant and the angle there (initial guess)."""

    t: np.ndarray
    y: np.ndarray
    t_release: float
    y_release: float


def _get(release, *names, default=None):
    for n in names:
        if isinstance(release, Mapping) and n in release and release[n] is not None:
            return release[n]
        if not isinstance(release, Mapping) and getattr(release, n, None) is not None:
            return getattr(release, n)
    return default


def segments_from_arrays(data: Sequence, source: str = "data") -> list[Segment]:
    """Segments from a list of ``(t, y, release)`` triples.

    `release` is the release time (float), or a mapping / object with ``t_release_s`` (and
    optionally ``t_end_s``, ``y_release``; :class:`roboball.ingest.releases.record.Release` works).  Samples
    before the release and after ``t_end_s`` are dropped; the release angle defaults to the
    measured angle interpolated at the release time.  Several triples may share one (t, y).
    """
    segs = []
    for i, item in enumerate(data):
        try:
            t, y, rel = item
        except (TypeError, ValueError):
            raise RoboballError(f"{source}: segment {i + 1}: expected (t, y, release)")
        t = np.asarray(t, dtype=float).ravel()
        y = np.asarray(y, dtype=float).ravel()
        if t.shape != y.shape:
            raise RoboballError(f"{source}: segment {i + 1}: {t.size} times but {y.size} angles")
        if isinstance(rel, (int, float, np.floating)):
            t_rel, t_end, y_rel = float(rel), None, None
        else:
            t_rel = _get(rel, "t_release_s", "t_release")
            t_end = _get(rel, "t_end_s", "t_end")
            y_rel = _get(rel, "y_release")
            if t_rel is None:
                raise RoboballError(f"{source}: release {i + 1}: no release time (t_release_s)")
            t_rel = float(t_rel)
        keep = np.isfinite(t) & np.isfinite(y) & (t >= t_rel)
        if t_end is not None:
            keep &= t <= float(t_end)
        if keep.sum() < 10:
            raise RoboballError(f"{source}: release {i + 1} at {t_rel:.3f} s: only {int(keep.sum())} samples "
                                "after the release; need at least 10")
        if y_rel is None or not math.isfinite(float(y_rel)):
            y_rel = float(np.interp(t_rel, t[np.isfinite(y)], y[np.isfinite(y)]))
        segs.append(Segment(t[keep], y[keep], t_rel, float(y_rel)))
    if not segs:
        raise RoboballError(f"{source}: no releases to fit")
    return segs


# ---------------------------------------------------------------------------------------------
# Priors
# ---------------------------------------------------------------------------------------------
@dataclass
class Prior:
    """A prior on a positive parameter theta, evaluated on the sampling coordinate
    u = log(theta - shift).

    ``shift`` is 0 except for a parameter whose prior starts at ``low >= 1`` with a natural
    origin there (Majd's ``n``: the law loses its sigma terms at n = 1 and only sigma (n - 1)
    is identified near it, so log(n - 1) turns that curved ridge into a straight one, which
    the ensemble moves sample far better).
    """

    name: str
    type: str
    low: float = 0.0
    high: float = math.inf
    median: float | None = None
    sigma_log: float | None = None
    start: float | None = None
    shift: float = 0.0

    @classmethod
    def from_spec(cls, name: str, spec: Mapping, shift: float = 0.0) -> "Prior":
        typ = spec["type"]
        low = float(spec.get("low", 0.0))
        high = float(spec.get("high", math.inf))
        p = cls(name, typ, low, high, spec.get("median"), spec.get("sigma_log"), spec.get("start"), float(shift))
        if typ not in ("uniform", "loguniform", "lognormal"):
            raise ConfigError(f"prior of {name}: unknown type {typ!r} (uniform, loguniform, lognormal)")
        if typ in ("uniform", "loguniform") and not (math.isfinite(high) and high > low):
            raise ConfigError(f"prior of {name}: {typ} needs low < high")
        if typ == "lognormal" and not (p.median and p.sigma_log and p.median > 0 and p.sigma_log > 0):
            raise ConfigError(f"prior of {name}: lognormal needs a positive median and sigma_log")
        if p.shift and p.low < p.shift:
            raise ConfigError(f"prior of {name}: low {p.low:g} is below the sampling origin {p.shift:g}")
        return p

    def theta(self, u):
        return self.shift + np.exp(u)

    def u_of(self, theta):
        return np.log(np.asarray(theta, dtype=float) - self.shift)

    @property
    def u_low(self) -> float:
        return math.log(self.low - self.shift) if self.low > self.shift else -math.inf

    @property
    def u_high(self) -> float:
        return math.log(self.high - self.shift) if math.isfinite(self.high) else math.inf

    def logpdf_u(self, u: np.ndarray) -> np.ndarray:
        """log density of u, up to a constant (-inf outside the bounds): log p(theta) + log dtheta/du."""
        u = np.asarray(u, dtype=float)
        inside = (u > self.u_low) & (u < self.u_high)
        with np.errstate(all="ignore"):
            th = self.theta(u)
            lt = np.log(th)
            if self.type == "loguniform":
                lp = -lt
            elif self.type == "uniform":
                lp = np.zeros_like(u)
            else:
                lp = -lt - 0.5 * ((lt - math.log(self.median)) / self.sigma_log) ** 2
            lp = lp + u
        return np.where(inside, lp, -np.inf)

    def sample_u(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """n draws of u from the prior (bounded lognormals by rejection)."""
        if n <= 0:
            return np.empty(0)
        if self.type == "loguniform":
            th = np.exp(rng.uniform(math.log(self.low), math.log(self.high), n))
        elif self.type == "uniform":
            th = rng.uniform(self.low, self.high, n)
        else:
            th = np.empty(0)
            while th.size < n:
                d = np.exp(rng.normal(math.log(self.median), self.sigma_log, 4 * n))
                th = np.concatenate([th, d[(d > self.low) & (d < self.high)]])
            th = th[:n]
        return self.u_of(np.maximum(th, self.shift + 1e-12))

    def interval95_u(self) -> tuple[float, float]:
        """The prior's central 95% interval of u (for the identifiability ratio), by quantiles
        of a fixed-seed sample (exact enough for a ratio)."""
        u = self.sample_u(np.random.default_rng(0), 20000)
        a, b = np.percentile(u, [2.5, 97.5])
        return float(a), float(b)

    def describe(self) -> dict:
        d = {"type": self.type, "low": self.low, "high": self.high if math.isfinite(self.high) else None}
        if self.type == "lognormal":
            d.update(median=self.median, sigma_log=self.sigma_log)
        if self.shift:
            d["sampled_as"] = f"log({self.name} - {self.shift:g})"
        return d


def load_priors(path: str | os.PathLike | None = None) -> dict:
    """Read configs/priors.yaml (or `path`), schema-validated and cross-checked."""
    from roboball.checks import check_priors

    path = Path(path) if path is not None else CONFIG_DIR / "priors.yaml"
    data = load_yaml(path, schema="priors.schema.yaml")
    return check_priors(data, str(path))


def law_priors(joint: str, law: str, priors: Mapping | str | os.PathLike | None = None,
               source: str = "priors") -> dict[str, Prior]:
    """Priors of the free parameters of `law` on `joint`.

    `priors` is a whole priors mapping (as in configs/priors.yaml), the block of this one law
    (``{param: spec}``, e.g. from ``--prior-json``), a path, or None for configs/priors.yaml.
    A law block is validated with the same schema and checks as the file.
    """
    from roboball.checks import check_priors

    if law not in friction.PARAMS or law == "none":
        raise RoboballError(f"{source}: unknown friction law '{law}' (viscous, coulomb_viscous, majd)")
    if joint not in KIND_OF_JOINT:
        raise RoboballError(f"{source}: unknown joint '{joint}' (steer or drive)")
    if priors is None or isinstance(priors, (str, os.PathLike)):
        data = load_priors(priors)
        source = str(priors or CONFIG_DIR / "priors.yaml")
    else:
        data = dict(priors)
        if not set(data) <= {"steer", "drive"}:     # a single law block
            data = {joint: {law: data}}
        validate(data, "priors.schema.yaml", source=source)
        check_priors(data, source)
    try:
        block = data[joint][law]
    except KeyError:
        raise ConfigError(f"{source}: no priors for law '{law}' on the {joint} joint; add '{joint}.{law}'")
    out = {}
    for name in friction.PARAMS[law]:
        if name in block:
            shift = 1.0 if (law == "majd" and name == "n" and float(block[name].get("low", 0.0)) >= 1.0) else 0.0
            out[name] = Prior.from_spec(name, block[name], shift=shift)
    return out


# ---------------------------------------------------------------------------------------------
# The problem
# ---------------------------------------------------------------------------------------------
class FrictionProblem:
    """Likelihood, priors and batched simulation of one law on one joint's releases.

    Sampling coordinates (one row per walker): ``[log theta_law..., log noise_rad]`` followed
    by the release angles ``q0_1..q0_S`` when they are sampled (``fix_angles(None)``, the
    default after construction); :meth:`fix_angles` conditions on given angles instead.
    Least-squares coordinates: ``[log theta_law..., q0_1..q0_S]``.
    """

    def __init__(self, kind: str, law: str, segments: Sequence[Segment], priors: Mapping[str, Prior],
                 fixed: Mapping | None = None, dt: float = reduced.DEFAULT_DT, robot: RobotFacts | None = None,
                 noise_prior: Mapping | None = None, release_half_width: float = RELEASE_HALF_WIDTH_RAD):
        if kind not in reduced.KINDS:
            raise RoboballError(f"friction fit: unknown kind '{kind}'")
        self.kind, self.law = kind, law
        self.segments = list(segments)
        self.robot = robot if robot is not None else load_robot()
        self.model = reduced.planar_model(kind, self.robot)
        self.fixed = dict(fixed or {})
        if law == "coulomb_viscous" and "v_tol" not in self.fixed and "v_tol" not in priors:
            self.fixed["v_tol"] = float(self.robot.friction_table1["coulomb_viscous"]["v_tol"])
        self.law_names = [p for p in friction.PARAMS[law] if p not in self.fixed]
        missing = [p for p in self.law_names if p not in priors]
        if missing:
            raise ConfigError(f"priors for {law}: missing {', '.join(missing)}")
        self.priors = [priors[p] for p in self.law_names]
        self.noise_prior = Prior.from_spec("noise_rad", noise_prior or NOISE_PRIOR)
        self.S = len(self.segments)
        self.q0_data = np.array([s.y_release for s in self.segments])
        self.half_width = float(release_half_width)
        # A release angle lies within the data's angle +- half_width AND inside the joint's limits
        # (configs/robot.yaml): the reduced model has no limit stops, Drake has, so an angle past a
        # limit would fit here and throw the pendulum against the stop in Drake.
        joint = JOINT_OF_KIND[kind]
        jl = self.robot.joints.get(joint, {})
        lower, upper = float(jl.get("lower_rad", -np.inf)), float(jl.get("upper_rad", np.inf))
        self.q0_low = np.maximum(self.q0_data - self.half_width, lower)
        self.q0_high = np.minimum(self.q0_data + self.half_width, upper)
        for i, (lo, hi, q) in enumerate(zip(self.q0_low, self.q0_high, self.q0_data)):
            if not lo < hi:
                raise RoboballError(f"friction fit: release {i + 1} starts at {q:.3f} rad, outside the {joint} "
                                    f"joint's limits [{lower:g}, {upper:g}] rad")
        self.angle_names = [f"release_angle_{i + 1}" for i in range(self.S)]
        self.n_law = len(self.law_names)
        self.fix_angles(None)
        self.dt = float(dt)
        self.y_obs = np.concatenate([s.y for s in self.segments])
        self.N = self.y_obs.size
        self.seg_pairs = [(s.t, s.t_release) for s in self.segments]
        self.n_sim_calls = 0
        self.n_sim_rows = 0

    # ---- coordinates ------------------------------------------------------------------------
    def fix_angles(self, q0: np.ndarray | None) -> None:
        """Condition the posterior on release angles `q0` (S,), or sample them (None)."""
        # rounded so that a resumed run recognises its own chain (fingerprint) bit for bit
        self.q0_fixed = None if q0 is None else np.round(np.asarray(q0, dtype=float), 9)
        self.names = self.law_names + ["noise_rad"] + (self.angle_names if q0 is None else [])
        self.ndim = len(self.names)

    @property
    def angles_sampled(self) -> bool:
        return self.q0_fixed is None

    def law_params(self, u_law: np.ndarray) -> dict:
        """Natural-unit parameter dict (arrays (P,)) from sampling coordinates (P, n_law)."""
        out = {n: self.priors[i].theta(u_law[:, i]) for i, n in enumerate(self.law_names)}
        out.update({k: float(v) for k, v in self.fixed.items()})
        return out

    def lsq_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lo = [p.u_low for p in self.priors] + list(self.q0_low)
        hi = [p.u_high for p in self.priors] + list(self.q0_high)
        return np.array(lo), np.array(hi)

    def start_point(self) -> np.ndarray:
        """LSQ start from the priors' `start` (else median / geometric centre) and the data angles."""
        u = []
        for p in self.priors:
            v = p.start or p.median or math.sqrt(max(p.low, 1e-12) * (p.high if math.isfinite(p.high) else 1.0))
            u.append(float(p.u_of(max(v, p.shift + 1e-9))))
        return np.concatenate([u, np.clip(self.q0_data, self.q0_low, self.q0_high)])

    # ---- simulation -------------------------------------------------------------------------
    def predict(self, x: np.ndarray, dt: float | None = None) -> np.ndarray:
        """Simulated angles, shape (P, N), for LSQ rows x (P, n_law + S)."""
        x = np.atleast_2d(x)
        P = x.shape[0]
        params = self.law_params(x[:, :self.n_law])
        q0 = x[:, self.n_law:]
        self.n_sim_calls += 1
        self.n_sim_rows += P * self.S
        with np.errstate(all="ignore"):
            ys = reduced.simulate_segments(self.kind, self.seg_pairs, q0, self.law, params,
                                           dt=dt or self.dt, model=self.model)
        return np.concatenate(ys, axis=1)

    def residuals(self, x: np.ndarray, dt: float | None = None) -> np.ndarray:
        return self.predict(x, dt) - self.y_obs[None, :]

    # ---- posterior --------------------------------------------------------------------------
    def to_lsq(self, U: np.ndarray) -> np.ndarray:
        U = np.atleast_2d(U)
        q0 = U[:, self.n_law + 1:] if self.q0_fixed is None else np.tile(self.q0_fixed, (U.shape[0], 1))
        return np.concatenate([U[:, :self.n_law], q0], axis=1)

    def log_prior(self, U: np.ndarray) -> np.ndarray:
        U = np.atleast_2d(U)
        lp = np.zeros(U.shape[0])
        for i, p in enumerate(self.priors):
            lp = lp + p.logpdf_u(U[:, i])
        lp = lp + self.noise_prior.logpdf_u(U[:, self.n_law])
        if self.q0_fixed is None:
            q0 = U[:, self.n_law + 1:]
            inside = np.all((q0 > self.q0_low[None, :]) & (q0 < self.q0_high[None, :]), axis=1)
            lp = lp + np.where(inside, 0.0, -np.inf)
        return lp

    def log_likelihood(self, U: np.ndarray, residuals: np.ndarray | None = None) -> np.ndarray:
        U = np.atleast_2d(U)
        r = self.residuals(self.to_lsq(U)) if residuals is None else residuals
        sigma = np.exp(U[:, self.n_law])
        ss = np.sum(r * r, axis=1)
        ll = -self.N * np.log(sigma) - 0.5 * ss / sigma ** 2 - 0.5 * self.N * math.log(2 * math.pi)
        return np.where(np.isfinite(ll), ll, -np.inf)

    def log_prob(self, U: np.ndarray) -> np.ndarray:
        """Vectorised log posterior (emcee ``vectorize=True``): U (P, ndim) -> (P,)."""
        U = np.atleast_2d(U)
        lp = self.log_prior(U)
        out = np.full(U.shape[0], -np.inf)
        ok = np.isfinite(lp)
        if ok.any():
            out[ok] = lp[ok] + self.log_likelihood(U[ok])
        return out

    def fingerprint(self) -> str:
        """Hash of the data, law, priors, fixed values and robot facts: a stored chain belongs to
        exactly this (and to the code that computes its log-probability: `sample_posterior`)."""
        h = hashlib.sha256()
        h.update(json.dumps({"kind": self.kind, "law": self.law, "names": self.names, "robot": self.robot.data,
                             "priors": [p.describe() for p in self.priors],
                             "noise": self.noise_prior.describe(), "fixed": self.fixed,
                             "half_width": self.half_width,
                             "q0_bounds": [[float(a), float(b)] for a, b in zip(self.q0_low, self.q0_high)],
                             "fixed_angles": None if self.q0_fixed is None else [float(q) for q in self.q0_fixed]},
                            sort_keys=True).encode())
        for s in self.segments:
            h.update(np.ascontiguousarray(s.t).tobytes())
            h.update(np.ascontiguousarray(s.y).tobytes())
            h.update(np.float64(s.t_release).tobytes())
        return h.hexdigest()[:16]


# ---------------------------------------------------------------------------------------------
# Least squares
# ---------------------------------------------------------------------------------------------
def _fd_steps(problem: FrictionProblem) -> np.ndarray:
    return np.concatenate([np.full(problem.n_law, 1e-4), np.full(problem.S, 1e-5)])


def least_squares_fit(problem: FrictionProblem, seed: int = 0, n_candidates: int = 64, n_starts: int = 2,
                      max_nfev: int = 200) -> dict:
    """Least-squares fit of the law parameters and release angles (see module docstring).

    Returns a dict: ``x`` (LSQ coordinates), ``cost`` (sum of squares / 2), ``rms``,
    ``sigma_hat`` (residual RMS, the noise level's ML estimate), ``jac`` (N x n at x),
    ``cov`` (Laplace covariance of x, prior-regularised), ``nfev``, ``success``, ``starts``.
    """
    from scipy.optimize import least_squares

    rng = np.random.default_rng(seed)
    lo, hi = problem.lsq_bounds()
    eps = _fd_steps(problem)
    n = lo.size

    # starts: the priors' start values and the best prior draws (one batched evaluation)
    x_start = np.clip(problem.start_point(), lo + 1e-9, hi - 1e-9)
    cand = np.tile(problem.q0_data, (n_candidates, 1))
    cand = np.concatenate([np.column_stack([p.sample_u(rng, n_candidates) for p in problem.priors])
                           if problem.n_law else np.zeros((n_candidates, 0)), cand], axis=1)
    allc = np.vstack([x_start[None, :], cand])
    r = problem.residuals(allc)
    cost = np.where(np.all(np.isfinite(r), axis=1), 0.5 * np.sum(r * r, axis=1), np.inf)
    # the priors' start, plus the best prior draws that already beat it (a start in the wrong
    # basin); most fits need one least-squares run
    better = [int(i) for i in np.argsort(cost) if i != 0 and cost[i] < cost[0]]
    starts = [allc[0]] + [allc[i] for i in better[:max(n_starts, 1) - 1]]

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
    # Laplace covariance with the priors' curvature as a floor (weakly identified directions
    # are bounded by the prior instead of by a singular J^T J)
    prior_prec = []
    for p in problem.priors:
        a, b = p.interval95_u()
        prior_prec.append(1.0 / max(((b - a) / 3.92) ** 2, 1e-12))
    prior_prec += [1.0 / (problem.half_width / 2) ** 2] * problem.S
    H = J.T @ J / max(sigma_hat, 1e-12) ** 2 + np.diag(prior_prec)
    cov = np.linalg.pinv(H)
    return {"x": best.x, "cost": float(best.cost), "rms": sigma_hat, "sigma_hat": sigma_hat, "jac": J,
            "cov": cov, "nfev": int(best.nfev), "success": bool(best.success), "message": str(best.message),
            "starts": len(starts)}


def choose_dt(problem: FrictionProblem, lsq: dict, candidates=DT_CANDIDATES,
              tolerance: float = DT_TOLERANCE) -> tuple[float, dict]:
    """Largest RK4 step whose integration error is negligible FOR THE FIT, at the LSQ optimum.

    A per-sample error small next to the noise is not enough: a systematic error e repeated
    over N samples biases well-determined parameters by about |e| sqrt(N) / sigma standard
    deviations.  So the criterion is the parameter shift the error causes, linearised:
    dx = pinv(J) (y_dt - y_dt/2), which must stay below `tolerance` x the Laplace standard
    deviation of every parameter (law parameters and release angles).  y_dt/2 stands in for
    the exact solution (its error is 4-16 times smaller).  Returns (dt, info) with info =
    {"max_shift_sd", "max_error_rad", "dt_s"} at the chosen step (the smallest candidate if
    none passes, which the fit then reports).
    """
    x = lsq["x"]
    J = lsq["jac"]
    sd = np.sqrt(np.clip(np.diag(lsq["cov"]), 1e-300, None))
    pinv = np.linalg.pinv(J)
    prev = problem.predict(x[None, :], dt=candidates[0])[0]
    info = {}
    for dt in candidates:
        half = problem.predict(x[None, :], dt=dt / 2)[0]
        e = prev - half
        e = np.where(np.isfinite(e), e, 0.0)
        shift = float(np.max(np.abs(pinv @ e) / sd))
        info = {"dt_s": dt, "max_shift_sd": shift, "max_error_rad": float(np.max(np.abs(e)))}
        if shift <= tolerance:
            return dt, info
        prev = half
    return candidates[-1], info


# ---------------------------------------------------------------------------------------------
# Posterior
# ---------------------------------------------------------------------------------------------
def _default_moves(n_walkers: int, ndim: int):
    import emcee

    if n_walkers >= 8 * ndim:
        # many walkers: a KDE of the other half-ensemble is a near-independent proposal for a
        # unimodal posterior; DE moves keep it robust on curved (weakly identified) ridges
        return [(emcee.moves.KDEMove(), 0.5), (emcee.moves.DEMove(), 0.4), (emcee.moves.DESnookerMove(), 0.1)]
    return [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]


class IndependentT:
    """Independence proposal for emcee's ``MHMove``: a multivariate Student t (``df``) with the
    mean and ``scale``^2 x covariance of given samples, and the Metropolis-Hastings correction
    log g(x) - log g(x') that makes a proposal independent of the current state exact.

    Fitted once to the adaptation phase of the chain and then frozen, so the chain after it is
    a fixed-kernel (valid) MCMC chain.  Heavier tails than a Gaussian (df = 6) keep the chain
    from sticking where the posterior is wider than the fit; proposals outside the prior
    support are rejected by the posterior itself."""

    def __init__(self, mean: np.ndarray, cov: np.ndarray, df: float = 6.0, scale: float = 1.2):
        self.mean = np.asarray(mean, dtype=float)
        d = self.mean.size
        cov = 0.5 * (cov + cov.T) * scale ** 2
        w, V = np.linalg.eigh(cov)
        w = np.clip(w, max(float(w.max()), 1e-300) * 1e-12, None)
        self.L = V * np.sqrt(w)                 # cov = L L^T
        self.Linv = (V / np.sqrt(w)).T          # whitening
        self.df, self.d = float(df), d

    @classmethod
    def from_chain(cls, chain: np.ndarray, **kw) -> "IndependentT":
        X = chain.reshape(-1, chain.shape[-1])
        return cls(X.mean(axis=0), np.cov(X.T).reshape(X.shape[1], X.shape[1]), **kw)

    def log_density(self, x: np.ndarray) -> np.ndarray:
        z = (x - self.mean) @ self.Linv.T
        return -0.5 * (self.df + self.d) * np.log1p(np.sum(z * z, axis=1) / self.df)

    def __call__(self, coords: np.ndarray, random) -> tuple[np.ndarray, np.ndarray]:
        n = coords.shape[0]
        z = random.randn(n, self.d) @ self.L.T
        w = random.chisquare(self.df, n) / self.df
        q = self.mean + z / np.sqrt(w)[:, None]
        return q, self.log_density(coords) - self.log_density(q)


def _adapted_moves(chain: np.ndarray, stage: int, schedule: Sequence[int]):
    """Moves of adaptation stage `stage` >= 1 (stage 0 is DE alone): the independence
    proposal fitted to the previous stage's samples (for stage 1, the second half of the DE
    stage, whose start is not yet in equilibrium), mixed with a few DE moves for robustness."""
    import emcee

    end = schedule[stage - 1]
    begin = end // 2 if stage == 1 else schedule[stage - 2]
    prop = IndependentT.from_chain(chain[begin:end])
    return [(emcee.moves.MHMove(prop), 0.9), (emcee.moves.DEMove(), 0.1)]


def _initial_walkers(problem: FrictionProblem, lsq: dict, n_walkers: int, rng: np.random.Generator) -> np.ndarray:
    """Walkers drawn from the least-squares Laplace approximation, inside the prior support."""
    x = lsq["x"]
    cov = lsq["cov"]
    if not problem.angles_sampled:      # conditional on the angles: inverse of the law block of H
        k = problem.n_law
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
        U = np.concatenate([X[:, :problem.n_law], s, X[:, problem.n_law:]], axis=1)
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


@functools.lru_cache(maxsize=None)
def _code_fingerprint() -> str:
    """The source of the log-probability: this module's import closure (once per process)."""
    from roboball.pipeline.codedeps import source_fingerprint
    return source_fingerprint(__name__)


def _meta_attrs(path: Path, meta: dict | None = None) -> dict | None:
    import h5py

    if meta is None:
        try:
            with h5py.File(path, "r") as f:
                s = f.attrs.get("roboball_meta")
                return json.loads(s) if s is not None else None
        except OSError:
            return None
    with h5py.File(path, "a") as f:  # checkpoint: the chain file's fit fingerprint
        f.attrs["roboball_meta"] = json.dumps(meta, sort_keys=True)
    return meta


def sample_posterior(problem: FrictionProblem, lsq: dict, chain_path: str | os.PathLike, seed: int = 0,
                     n_walkers: int = 32, autocorr_multiple: float = 50.0, max_steps: int = 20000,
                     chunk: int = 50, moves=None, min_steps: int = 100,
                     adapt_schedule: Sequence[int] = ADAPT_SCHEDULE, stale: str = "refuse") -> dict:
    """Run (or resume) the emcee chain in `chain_path` until converged or `max_steps`.

    A stored chain is resumed only if it belongs to this fit: the same data, priors, robot facts,
    sampler settings and the same source code of the log-probability (`code` in its metadata,
    roboball.pipeline.codedeps.source_fingerprint of this module).  Another fit's chain is
    refused (`stale="refuse"`, for a chain a user keeps) or deleted and sampled afresh
    (`stale="restart"`, the pipeline's: there the chain is a resumable cache of its rule).

    With ``moves=None`` the chain adapts, then samples with a frozen kernel.  Adaptation:
    differential-evolution moves from the Laplace start up to ``adapt_schedule[0]`` steps, then
    an independence proposal (:class:`IndependentT`) fitted to the DE samples, refitted at each
    later count of the schedule to the samples since the previous one.  Production, from
    ``adapt_schedule[-1]`` on: the last proposal, frozen, mixed with DE moves.  On the test
    bed's Majd steer fit this cut the integrated autocorrelation time from about 37 steps (DE
    alone) to about 14.  Burn-in and tau are measured on the production phase only (burn-in
    >= ``adapt_schedule[-1]``), so the reported samples come from one fixed kernel.  Given
    `moves`, one phase with those moves (burn-in from the whole chain).

    Returns ``chain`` (steps, walkers, ndim) in sampling coordinates, ``log_prob``,
    ``burn``, ``tau``, ``converged``, ``acceptance``, ``n_steps``, ``resumed_from``.
    """
    import emcee

    chain_path = Path(chain_path)
    chain_path.parent.mkdir(parents=True, exist_ok=True)
    if problem.ndim * 2 > n_walkers:
        raise RoboballError(f"friction fit: {n_walkers} walkers for {problem.ndim} parameters; emcee needs at "
                            f"least {2 * problem.ndim}")
    adaptive = moves is None
    schedule = tuple(int(a) for a in adapt_schedule) if adaptive else ()
    if adaptive and (not schedule or any(b <= a for a, b in zip(schedule, schedule[1:])) or schedule[0] < 2):
        raise RoboballError(f"friction fit: adaptation schedule {schedule} must be increasing step counts >= 2")
    adapt = schedule[-1] if adaptive else 0
    if stale not in ("refuse", "restart"):
        raise ValueError(f"stale must be 'refuse' or 'restart', not {stale!r}")
    meta = {"fingerprint": problem.fingerprint(), "names": problem.names, "law": problem.law,
            "kind": problem.kind, "n_walkers": int(n_walkers), "seed": int(seed), "dt": problem.dt,
            "sampler": f"adaptive-independence-t/{'-'.join(map(str, schedule))}" if adaptive else "given-moves",
            "code": _code_fingerprint()}
    resumed_from = 0
    if chain_path.exists():
        stored = _meta_attrs(chain_path)
        try:
            it = emcee.backends.HDFBackend(str(chain_path), name="mcmc", read_only=True).iteration  # checkpoint: read only
        except Exception as exc:   # noqa: BLE001 - an unreadable file is a user-facing problem
            if stale != "restart":
                raise RoboballError(f"{chain_path}: cannot read the stored chain ({exc}); delete it to start afresh")
            it, stored = 0, None
        if it > 0 and (stored is None or {k: stored.get(k) for k in meta} != meta):
            diff = [k for k in meta if stored is None or stored.get(k) != meta[k]]
            if stale != "restart":
                raise RoboballError(f"{chain_path}: holds a chain of a different fit (differs in "
                                    f"{', '.join(diff)}); delete it or give another chain path")
            print(f"{chain_path}: the stored chain is of a different fit (differs in {', '.join(diff)}); "
                  "sampling afresh", file=sys.stderr)
            it = 0
        if it == 0 and stale == "restart":
            chain_path.unlink()   # the pipeline's cache starts afresh; a user's empty chain is reset below
        resumed_from = int(it)
    backend = emcee.backends.HDFBackend(str(chain_path), name="mcmc")  # checkpoint: resumable emcee chain, checked by fingerprint on reuse

    def stage_of(n_done: int) -> int:
        return sum(n_done >= a for a in schedule)

    def make_sampler(stage: int):
        # a new sampler on a used backend continues from its last sample and random state
        if not adaptive:
            mv = moves
        elif stage == 0:
            mv = _default_moves(n_walkers, problem.ndim)
        else:
            mv = _adapted_moves(backend.get_chain(), stage, schedule)
        return emcee.EnsembleSampler(n_walkers, problem.ndim, problem.log_prob, vectorize=True,
                                     backend=backend, moves=mv)

    if resumed_from == 0:
        backend.reset(n_walkers, problem.ndim)
        _meta_attrs(chain_path, meta)
        rng = np.random.default_rng([seed, 1])
        initial = _initial_walkers(problem, lsq, n_walkers, rng)
        stage = 0
        sampler = make_sampler(stage)
        sampler._random = np.random.RandomState(np.random.SeedSequence([seed, 2]).generate_state(1)[0])
    else:
        initial = None
        stage = stage_of(resumed_from)
        sampler = make_sampler(stage)
    converged = False
    burn, tau = 0, np.full(problem.ndim, np.nan)
    while True:
        n = backend.iteration
        # only the production phase (adapt = 0 without adaptation) is judged, once it has
        # min_steps steps: its samples come from one fixed kernel
        judge = n >= adapt + min_steps
        if n >= min_steps:
            start = adapt if judge else 0
            burn_rel, tau = burn_and_tau(backend.get_chain()[start:])
            burn = start + burn_rel
            if judge and np.all(np.isfinite(tau)) and (n - burn) >= autocorr_multiple * float(np.max(tau)):
                converged = True
                break
        if n >= max_steps:
            break
        if stage_of(n) != stage:
            stage = stage_of(n)
            sampler = make_sampler(stage)
        target = min(max_steps, (n // chunk + 1) * chunk)
        if stage < len(schedule):
            target = min(target, schedule[stage])
        state = initial if n == 0 else None
        sampler.run_mcmc(state, target - n, progress=False)
        initial = None
    chain = backend.get_chain()
    return {"chain": chain, "log_prob": backend.get_log_prob(), "burn": int(burn), "tau": np.asarray(tau),
            "converged": bool(converged), "acceptance": backend.accepted / max(backend.iteration, 1),
            "n_steps": int(backend.iteration), "resumed_from": resumed_from, "n_walkers": int(n_walkers),
            "autocorr_multiple": float(autocorr_multiple), "max_steps": int(max_steps), "chain_path": str(chain_path),
            "adapt_schedule": list(schedule)}


# ---------------------------------------------------------------------------------------------
# Summary
# ---------------------------------------------------------------------------------------------
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


def summarize(problem: FrictionProblem, lsq: dict, post: dict, seed: int = 0, n_waic_draws: int = 200,
              step_error: float | None = None) -> tuple[dict, pd.DataFrame]:
    """JSON-serialisable result and the flat posterior samples (law parameters + noise_sigma)."""
    chain, logp, burn = post["chain"], post["log_prob"], post["burn"]
    flat = chain[burn:].reshape(-1, problem.ndim)
    flat_lp = logp[burn:].reshape(-1)
    nat = _natural(problem, flat)
    i_map = int(np.argmax(flat_lp))
    U_map = flat[i_map]
    x_lsq = lsq["x"]
    lsq_nat = np.concatenate([[p.theta(x_lsq[i]) for i, p in enumerate(problem.priors)], [lsq["sigma_hat"]],
                              x_lsq[problem.n_law:]])
    n_after = chain.shape[0] - burn
    tau = post["tau"]
    params, angles, notes = {}, [], []
    all_priors = problem.priors + [problem.noise_prior]
    for j, name in enumerate(problem.names):
        col = nat[:, j]
        lo, med, hi = np.percentile(col, [2.5, 50, 97.5])
        entry = {"median": float(med), "ci95_low": float(lo), "ci95_high": float(hi),
                 "map": float(_natural(problem, U_map)[j]), "lsq": float(lsq_nat[j]),
                 "mean": float(col.mean()), "std": float(col.std()),
                 "tau_steps": float(tau[j]) if np.isfinite(tau[j]) else None,
                 "ess": float(post["n_walkers"] * n_after / tau[j]) if np.isfinite(tau[j]) and tau[j] > 0 else None}
        if j < problem.n_law + 1:
            pr = all_priors[j]
            entry["unit"] = friction.UNITS.get(name, "rad")
            entry["prior"] = pr.describe()
            a, b = pr.interval95_u()
            ul, uh = np.percentile(flat[:, j], [2.5, 97.5])
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
            params[name] = entry
        else:
            entry["unit"] = "rad"
            entry["source"] = "posterior (marginalised)"
            angles.append(entry)
    if not problem.angles_sampled:
        sd = np.sqrt(np.clip(np.diag(lsq["cov"])[problem.n_law:], 0, None))
        for q, e in zip(problem.q0_fixed, sd):
            angles.append({"median": float(q), "ci95_low": float(q - 1.96 * e), "ci95_high": float(q + 1.96 * e),
                           "map": float(q), "lsq": float(q), "unit": "rad",
                           "source": "least squares (Laplace interval); the posterior is conditioned on it"})
    if problem.law == "majd" and "n" in params and "sigma" in params:
        n_lo = params["n"]["ci95_low"]
        if n_lo < 1.1:
            notes.append("majd: n reaches 1 within the 95% interval; at n = 1 the sigma terms of eq. 3 cancel, "
                         "so sigma is only identified through sigma (n - 1)")
    # fit statistics
    r_map = problem.residuals(problem.to_lsq(U_map[None, :]))[0]
    ll_map = float(problem.log_likelihood(U_map[None, :], r_map[None, :])[0])
    N = problem.N
    ll_max_lsq = -0.5 * N * (math.log(2 * math.pi * lsq["sigma_hat"] ** 2) + 1.0)
    ll_max = max(ll_max_lsq, ll_map)
    k_bic = problem.n_law + 1 + problem.S         # law parameters, noise level, release angles
    rng = np.random.default_rng([seed, 3])
    draws = flat[rng.choice(flat.shape[0], min(n_waic_draws, flat.shape[0]), replace=False)]
    fit_stats = {"rmse_rad": float(np.sqrt(np.mean(r_map ** 2))), "rmse_lsq_rad": float(lsq["rms"]),
                 "loglik_map": ll_map, "loglik_max": float(ll_max), "n_obs": int(N), "n_params": int(k_bic),
                 "loglik": float(ll_max), "bic": float(k_bic * math.log(N) - 2 * ll_max),
                 "waic": _waic(problem, draws),
                 "lsq_success": lsq["success"], "lsq_nfev": lsq["nfev"]}
    acc = np.asarray(post["acceptance"], dtype=float)
    tau_max = float(np.nanmax(tau)) if np.any(np.isfinite(tau)) else float("nan")
    ess = [post["n_walkers"] * n_after / t for t in tau if np.isfinite(t) and t > 0]
    conv = {"converged": post["converged"], "n_steps": post["n_steps"], "burn_in": post["burn"],
            # the keys the reports read (pipeline/report.py, params_report.py)
            "steps": post["n_steps"], "max_tau": tau_max, "ess_min": float(min(ess)) if ess else float("nan"),
            "acceptance_fraction": float(np.mean(post["acceptance"])), "burn": post["burn"],
            "n_walkers": post["n_walkers"], "autocorr_multiple": post["autocorr_multiple"],
            "max_steps": post["max_steps"], "tau_max_steps": float(np.nanmax(tau)) if np.any(np.isfinite(tau)) else None,
            "chain_over_tau": float(n_after / np.nanmax(tau)) if np.any(np.isfinite(tau)) else None,
            "tau_steps": {n: (float(t) if np.isfinite(t) else None) for n, t in zip(problem.names, tau)},
            "ess": {n: (float(post["n_walkers"] * n_after / t) if np.isfinite(t) and t > 0 else None)
                    for n, t in zip(problem.names, tau)},
            "acceptance_fraction_mean": float(acc.mean()), "acceptance_fraction_min": float(acc.min()),
            "resumed_from_steps": post["resumed_from"], "chain": post["chain_path"]}
    if not post["converged"]:
        notes.append(f"NOT CONVERGED: the chain stopped at max_steps = {post['max_steps']} with "
                     f"{conv['chain_over_tau']:.1f} autocorrelation times after burn-in "
                     f"(required {post['autocorr_multiple']:g})")
    res = {"kind": problem.kind, "joint": JOINT_OF_KIND.get(problem.kind, problem.kind), "law": problem.law,
           "parameters": params, "fixed": {k_: float(v) for k_, v in problem.fixed.items()},
           "release_angles_rad": [a["median"] for a in angles], "release_angles": angles,
           "release_times_s": [float(s.t_release) for s in problem.segments],
           "fit": fit_stats, "convergence": conv,
           "integration": {"method": "RK4 + implicit stiction step (roboball.reduced.planar, compiled loop roboball.reduced.kernel)", "dt_s": problem.dt,
                           "step_error_rad": step_error},
           "angles_sampled": problem.angles_sampled, "chain": post["chain_path"],
           "seed": int(seed), "notes": notes}
    sample_cols = problem.law_names + ["noise_rad"]
    thin = max(1, int(np.nanmax(tau) // 2)) if np.any(np.isfinite(tau)) else 1
    kept = chain[burn::thin].reshape(-1, problem.ndim)
    samples = pd.DataFrame(_natural(problem, kept)[:, :problem.n_law + 1], columns=sample_cols)
    return res, samples


# ---------------------------------------------------------------------------------------------
# Entry points
# ---------------------------------------------------------------------------------------------
def fit_segments(kind: str, law: str, segments: Sequence, chain_path: str | os.PathLike,
                 priors: Mapping | str | os.PathLike | None = None, *, seed: int = 0, walkers: int = 32,
                 autocorr_multiple: float = 50.0, max_steps: int = 20000, dt: float | None = None,
                 chunk: int = 50, robot: RobotFacts | None = None, fixed: Mapping | None = None,
                 source: str = "data", moves=None, min_steps: int = 100,
                 sample_angles: bool = True, stale: str = "refuse") -> tuple[dict, pd.DataFrame]:
    """Full fit of `law` on stand `kind` from segments (:func:`segments_from_arrays` input or
    :class:`Segment` list): least squares, step choice, emcee to convergence, summary.

    `dt` None chooses the RK4 step at the least-squares optimum (:func:`choose_dt`).
    `sample_angles` True (default) marginalises the release angles in the posterior.  False
    conditions on their least-squares values: cheaper, but the friction levels are correlated
    with the release amplitudes, so the conditional intervals come out too narrow (by ~40% for
    f_w, f_c of a Majd fit in the tests); use it only for quick looks.
    `walkers` is raised to 2 x (number of sampled parameters) + 2 if it is smaller.  `stale`: what
    to do with a stored chain of another fit (:func:`sample_posterior`)."""
    t_start = time.perf_counter()
    joint = JOINT_OF_KIND.get(kind)
    if joint is None:
        raise RoboballError(f"{source}: friction fits need a stand recording (steer_stand or drive_stand), "
                            f"not '{kind}'")
    segs = segments if all(isinstance(s, Segment) for s in segments) else segments_from_arrays(segments, source)
    pri = law_priors(joint, law, priors, source=str(priors) if isinstance(priors, (str, os.PathLike)) else "priors")
    problem = FrictionProblem(kind, law, segs, pri, fixed=fixed, robot=robot,
                              dt=dt or DT_CANDIDATES[0])
    lsq = least_squares_fit(problem, seed=seed)
    if dt is None:
        chosen, dt_info = choose_dt(problem, lsq)
        if chosen != problem.dt:
            problem.dt = chosen
            lsq = _refine(problem, lsq, seed)
    else:
        _, dt_info = choose_dt(problem, lsq, candidates=(float(dt),), tolerance=math.inf)
    t_lsq = time.perf_counter() - t_start
    if not sample_angles:
        problem.fix_angles(lsq["x"][problem.n_law:])
    walkers = max(int(walkers), 2 * problem.ndim + 2)
    post = sample_posterior(problem, lsq, chain_path, seed=seed, n_walkers=walkers,
                            autocorr_multiple=autocorr_multiple, max_steps=max_steps, chunk=chunk,
                            moves=moves, min_steps=min_steps, stale=stale)
    res, samples = summarize(problem, lsq, post, seed=seed, step_error=dt_info["max_error_rad"])
    res["integration"]["parameter_shift_sd"] = dt_info["max_shift_sd"]
    if dt_info["max_shift_sd"] > DT_TOLERANCE:
        res["notes"].append(f"integration error {dt_info['max_error_rad']:.2g} rad shifts a parameter by "
                            f"{dt_info['max_shift_sd']:.2g} posterior sd at dt = {problem.dt:g} s (tolerance "
                            f"{DT_TOLERANCE}); the intervals may be biased")
    res["recording"] = Path(source).stem if source not in ("data", "") else source
    res["timing"] = {"wall_s": time.perf_counter() - t_start, "least_squares_s": t_lsq,
                     "simulation_calls": problem.n_sim_calls, "simulated_rows": problem.n_sim_rows}
    return res, samples


def _refine(problem: FrictionProblem, lsq: dict, seed: int) -> dict:
    """Re-run the least squares from the previous optimum after the step size changed."""
    saved = problem.start_point

    problem.start_point = lambda: lsq["x"]            # noqa: E731 - start from the previous optimum
    try:
        return least_squares_fit(problem, seed=seed, n_candidates=0, n_starts=1, max_nfev=30)
    finally:
        problem.start_point = saved


def fit(recording: str | os.PathLike, releases: str | os.PathLike, joint: str, law: str,
        prior: Mapping | str | os.PathLike | None, chain: str | os.PathLike, *, walkers: int = 32,
        autocorr_multiple: float = 50.0, max_steps: int = 20000, seed: int = 0,
        dt: float | None = None, sample_angles: bool = True, stale: str = "refuse") -> tuple[dict, pd.DataFrame]:
    """Pipeline entry: fit `law` on `joint` to a stand recording (CSV + sidecar) and its
    releases JSON (``{"releases": [{"t_release_s", "t_end_s", "y_release", ...}]}``)."""
    from roboball.ingest.recording import read_recording

    if joint not in KIND_OF_JOINT:
        raise RoboballError(f"--joint: unknown joint '{joint}' (steer or drive)")
    rec = read_recording(recording)
    kind = KIND_OF_JOINT[joint]
    if rec.kind != kind:
        raise RoboballError(f"{rec.label}: kind is '{rec.kind}', but a {joint}-joint friction fit needs a "
                            f"{kind} recording")
    try:
        with open(releases, encoding="utf-8") as fh:
            rels = json.load(fh)["releases"]
    except FileNotFoundError:
        raise RoboballError(f"{releases}: file not found")
    except (json.JSONDecodeError, KeyError, TypeError) as exc:
        raise RoboballError(f"{releases}: not a releases JSON with a 'releases' list ({exc})")
    t, y = rec.time, rec.main_values()
    segs = segments_from_arrays([(t, y, r) for r in rels], source=str(releases))
    res, samples = fit_segments(kind, law, segs, chain, prior, seed=seed, walkers=walkers,
                                autocorr_multiple=autocorr_multiple, max_steps=max_steps, dt=dt,
                                source=rec.label, sample_angles=sample_angles, stale=stale)
    res["releases_file"] = str(releases)
    return res, samples


def comparison(fits: Sequence) -> pd.DataFrame:
    """Model-comparison table of fits to the same data (fit JSON paths or result dicts):
    residual RMS, log-likelihoods, BIC and WAIC, with differences to the best (lowest BIC)."""
    rows = []
    for f in fits:
        if not isinstance(f, Mapping):
            try:
                with open(f, encoding="utf-8") as fh:
                    f = json.load(fh)
            except FileNotFoundError:
                raise RoboballError(f"{f}: file not found")
            except json.JSONDecodeError as exc:
                raise RoboballError(f"{f}: not a JSON file ({exc.msg} at line {exc.lineno})")
        try:
            st = f["fit"]
            rows.append({"joint": f["joint"], "law": f["law"], "recording": f.get("recording", ""),
                         "n_params": st["n_params"], "n_obs": st["n_obs"], "rmse_rad": st["rmse_rad"],
                         "loglik_map": st.get("loglik_map", float("nan")),
                         "loglik": st.get("loglik_max", st.get("loglik")), "bic": st["bic"],
                         "waic": st.get("waic", float("nan")),
                         "converged": bool(f.get("convergence", {}).get("converged", False))})
        except KeyError as exc:
            raise RoboballError(f"friction comparison: a fit result lacks field {exc}")
    df = pd.DataFrame(rows)
    if df.empty:
        raise RoboballError("friction comparison: no fits given")
    df["delta_bic"] = df["bic"] - df.groupby(["joint", "recording"])["bic"].transform("min")
    df["delta_waic"] = df["waic"] - df.groupby(["joint", "recording"])["waic"].transform("min")
    return df.sort_values(["joint", "recording", "bic"]).reset_index(drop=True)
