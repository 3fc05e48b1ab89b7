"""The friction-fit problem: likelihood, priors and batched simulation of one law on one joint.

Each release starts from rest at an initial angle that is a nuisance parameter: initialised
from the data, fitted, and (by default) marginalised in the posterior; its prior is uniform
within +-0.25 rad (:data:`RELEASE_HALF_WIDTH_RAD`) of the data's value and inside the joint's
limits.  The likelihood is Gaussian with independent residuals and one noise level sigma.
"""
from __future__ import annotations

import hashlib
import json
import math
from typing import Mapping, Sequence

import numpy as np

from roboball.config import RobotFacts, load_robot
from roboball.errors import ConfigError, RoboballError
from roboball.identify.friction.priors import NOISE_PRIOR, Prior
from roboball.identify.friction.segments import JOINT_OF_KIND, Segment
from roboball.physics import friction
from roboball.reduced import planar as reduced

RELEASE_HALF_WIDTH_RAD = 0.25


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
