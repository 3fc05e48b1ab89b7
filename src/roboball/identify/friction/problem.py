"""The friction-fit problem: likelihood, priors and batched simulation of one law on one joint.

The model is the calibrated stand (:mod:`roboball.reduced.planar`): the friction law plus the
stand's added inertia ``delta_i`` and ``rest_offset``, with the priors of
``configs/priors.yaml`` (:mod:`~roboball.identify.friction.priors`; either may be held fixed).

Each release starts from rest at an initial angle and an instant that are nuisance parameters
(the release states): initialised from the data (the release finder's angle, shift 0), fitted,
and (by default) marginalised in the posterior.  The angle's prior is uniform within +-0.25 rad
(:data:`RELEASE_HALF_WIDTH_RAD`) of the data's value and inside the joint's limits; the
instant's uniform within +-0.25 s (:data:`RELEASE_SHIFT_HALF_WIDTH_S`) of the finder's.  The
instant is fitted because a hand lets go over about a tenth of a second: on the real steer log
the finder's instants are 0.03-0.16 s off the motion, which shifts every later swing's phase
(the fit's residual RMS 0.14 rad with the instants held, 0.05 rad with them fitted).  The
likelihood is Gaussian with independent residuals and one noise level sigma.
"""
from __future__ import annotations

import hashlib
import json
import math
from typing import Mapping, Sequence

import numpy as np

from roboball.config import RobotFacts, load_robot
from roboball.errors import ConfigError, RoboballError
from roboball.identify.friction.priors import NOISE_PRIOR, STAND_PARAMS, Prior
from roboball.identify.friction.segments import JOINT_OF_KIND, Segment
from roboball.physics import friction
from roboball.reduced import planar as reduced

RELEASE_HALF_WIDTH_RAD = 0.25
RELEASE_SHIFT_HALF_WIDTH_S = 0.25


class FrictionProblem:
    """Likelihood, priors and batched simulation of one law on one joint's releases.

    Parameters, in order: the law's sampled parameters (``law_names``, n_law), the stand's
    (``stand_names``), together ``phys_names`` (n_phys, priors ``priors``); then the noise level;
    then the release states, the angles ``q0_1..q0_S`` and (when ``shifts_fitted``) the instants'
    shifts ``ts_1..ts_S``.  Sampling coordinates (one row per walker): ``[u_phys..., log
    noise_rad, release states...]``, the release states only when they are sampled
    (``fix_releases(None)``, the default); least-squares coordinates: ``[u_phys..., release
    states...]``.  ``u`` is a prior's sampling coordinate (:class:`Prior`).
    """

    def __init__(self, kind: str, law: str, segments: Sequence[Segment], priors: Mapping[str, Prior],
                 fixed: Mapping | None = None, dt: float = reduced.DEFAULT_DT, robot: RobotFacts | None = None,
                 noise_prior: Mapping | None = None, release_half_width: float = RELEASE_HALF_WIDTH_RAD,
                 stand: Mapping[str, Prior] | None = None, shift_half_width: float = RELEASE_SHIFT_HALF_WIDTH_S):
        if kind not in reduced.KINDS:
            raise RoboballError(f"friction fit: unknown kind '{kind}'")
        self.kind, self.law = kind, law
        self.segments = list(segments)
        self.robot = robot if robot is not None else load_robot()
        self.model = reduced.planar_model(kind, self.robot)
        self.fixed = dict(fixed or {})
        self._sampled_parameters(law, priors, stand)
        self.noise_prior = Prior.from_spec("noise_rad", noise_prior or NOISE_PRIOR)
        self.S = len(self.segments)
        self._release_bounds(release_half_width, shift_half_width)
        self.fix_releases(None)
        self.dt = float(dt)
        self.y_obs = np.concatenate([s.y for s in self.segments])
        self.N = self.y_obs.size
        self.seg_pairs = [(s.t, s.t_release) for s in self.segments]
        self.n_sim_calls = 0
        self.n_sim_rows = 0

    def _sampled_parameters(self, law: str, priors: Mapping[str, Prior], stand: Mapping[str, Prior] | None) -> None:
        """The law's and the stand's sampled parameters and their priors (the others fixed).
        Without stand priors the stand is not calibrated (delta_i = rest_offset = 0)."""
        if law == "coulomb_viscous" and "v_tol" not in self.fixed and "v_tol" not in priors:
            self.fixed["v_tol"] = float(self.robot.friction_table1["coulomb_viscous"]["v_tol"])
        if stand is None:
            self.fixed.update({k: 0.0 for k in STAND_PARAMS if k not in self.fixed})
        derived = [p for p in friction.PARAMS[law] if p not in friction.FIT_PARAMS[law] and p != "v_tol"]
        held = [p for p in derived if p in self.fixed]
        if held and len(held) < len(derived):
            raise ConfigError(f"{law}: hold {' and '.join(derived)} together or neither (the fit samples "
                              f"{', '.join(friction.FIT_PARAMS[law])})")
        self.law_names = [p for p in friction.FIT_PARAMS[law] if p not in self.fixed
                          and not (held and p in ("h_peak", "v_peak"))]
        self.stand_names = [p for p in STAND_PARAMS if p not in self.fixed]
        missing = [p for p in self.law_names if p not in priors] + \
                  [p for p in self.stand_names if p not in (stand or {})]
        if missing:
            raise ConfigError(f"priors for {law}: missing {', '.join(missing)}")
        self.priors = [priors[p] for p in self.law_names] + [stand[p] for p in self.stand_names]
        self.phys_names = self.law_names + self.stand_names
        self.n_law = len(self.law_names)
        self.n_phys = len(self.phys_names)

    def _release_bounds(self, half_width: float, shift_half_width: float) -> None:
        """Bounds of the release states.  An angle lies within the data's angle +- half_width AND
        inside the joint's limits (configs/robot.yaml): the reduced model has no limit stops,
        Drake has, so an angle past a limit would fit here and throw the pendulum against the
        stop in Drake.  A shift lies within +- shift_half_width (0: the instants are not fitted)."""
        self.q0_data = np.array([s.y_release for s in self.segments])
        self.half_width = float(half_width)
        self.shift_half_width = float(shift_half_width)
        joint = JOINT_OF_KIND[self.kind]
        jl = self.robot.joints.get(joint, {})
        lower, upper = float(jl.get("lower_rad", -np.inf)), float(jl.get("upper_rad", np.inf))
        self.q0_low = np.maximum(self.q0_data - self.half_width, lower)
        self.q0_high = np.minimum(self.q0_data + self.half_width, upper)
        for i, (lo, hi, q) in enumerate(zip(self.q0_low, self.q0_high, self.q0_data)):
            if not lo < hi:
                raise RoboballError(f"friction fit: release {i + 1} starts at {q:.3f} rad, outside the {joint} "
                                    f"joint's limits [{lower:g}, {upper:g}] rad")
        self.angle_names = [f"release_angle_{i + 1}" for i in range(self.S)]
        self.shift_names = [f"release_shift_{i + 1}" for i in range(self.S)] if self.shifts_fitted else []
        h = self.shift_half_width
        self.release_low = np.concatenate([self.q0_low, np.full(len(self.shift_names), -h)])
        self.release_high = np.concatenate([self.q0_high, np.full(len(self.shift_names), h)])
        self.release_data = np.concatenate([self.q0_data, np.zeros(len(self.shift_names))])

    # ---- coordinates ------------------------------------------------------------------------
    @property
    def shifts_fitted(self) -> bool:
        return self.shift_half_width > 0

    @property
    def release_names(self) -> list:
        return self.angle_names + self.shift_names

    def fix_releases(self, states: np.ndarray | None) -> None:
        """Condition the posterior on release states (angles, then shifts when fitted), or
        sample them (None)."""
        # rounded so that a resumed run recognises its own chain (fingerprint) bit for bit
        self.release_fixed = None if states is None else np.round(np.asarray(states, dtype=float), 9)
        self.names = self.phys_names + ["noise_rad"] + (self.release_names if states is None else [])
        self.ndim = len(self.names)

    @property
    def releases_sampled(self) -> bool:
        return self.release_fixed is None

    def law_params(self, u_phys: np.ndarray) -> dict:
        """Natural-unit parameter dict (arrays (P,)) of the law and the stand from sampling
        coordinates (P, n_phys), the fixed values included; Majd's sigma and omega_c from its
        stiction peak (:func:`roboball.physics.friction.natural_params`)."""
        out = {n: self.priors[i].theta(u_phys[:, i]) for i, n in enumerate(self.phys_names)}
        out.update({k: float(v) for k, v in self.fixed.items()})
        return friction.natural_params(self.law, out)

    def lsq_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lo = [p.u_low for p in self.priors] + list(self.release_low)
        hi = [p.u_high for p in self.priors] + list(self.release_high)
        return np.array(lo), np.array(hi)

    def start_point(self) -> np.ndarray:
        """LSQ start from the priors' `start` (else median / geometric centre) and the data's
        release states."""
        u = []
        for p in self.priors:
            if p.linear:
                u.append(float(p.start if p.start is not None else 0.5 * (p.low + p.high)))
                continue
            v = p.start or p.median or math.sqrt(max(p.low, 1e-12) * (p.high if math.isfinite(p.high) else 1.0))
            u.append(float(p.u_of(max(v, p.shift + 1e-9))))
        return np.concatenate([u, np.clip(self.release_data, self.release_low, self.release_high)])

    # ---- simulation -------------------------------------------------------------------------
    def predict(self, x: np.ndarray, dt: float | None = None) -> np.ndarray:
        """Simulated angles, shape (P, N), for LSQ rows x (P, n_phys + release states)."""
        x = np.atleast_2d(x)
        P = x.shape[0]
        params = self.law_params(x[:, :self.n_phys])
        stand = {k: params.pop(k) for k in STAND_PARAMS}
        bad = ~np.broadcast_to(friction.admissible(self.law, params), (P,))
        q0 = x[:, self.n_phys:self.n_phys + self.S]
        shift = x[:, self.n_phys + self.S:] if self.shifts_fitted else None
        self.n_sim_calls += 1
        self.n_sim_rows += P * self.S
        with np.errstate(all="ignore"):
            ys = reduced.simulate_segments(self.kind, self.seg_pairs, q0, self.law, params,
                                           dt=dt or self.dt, model=self.model, added_inertia=stand["delta_i"],
                                           rest_offset=stand["rest_offset"], release_shift=shift)
        y = np.concatenate(ys, axis=1)
        y[bad] = np.nan               # outside the law's support: no residual (least squares: a penalty)
        return y

    def residuals(self, x: np.ndarray, dt: float | None = None) -> np.ndarray:
        return self.predict(x, dt) - self.y_obs[None, :]

    # ---- posterior --------------------------------------------------------------------------
    def to_lsq(self, U: np.ndarray) -> np.ndarray:
        U = np.atleast_2d(U)
        rel = U[:, self.n_phys + 1:] if self.release_fixed is None else np.tile(self.release_fixed, (U.shape[0], 1))
        return np.concatenate([U[:, :self.n_phys], rel], axis=1)

    def log_prior(self, U: np.ndarray) -> np.ndarray:
        U = np.atleast_2d(U)
        lp = np.zeros(U.shape[0])
        for i, p in enumerate(self.priors):
            lp = lp + p.logpdf_u(U[:, i])
        lp = lp + self.noise_prior.logpdf_u(U[:, self.n_phys])
        lp = np.where(friction.admissible(self.law, self.law_params(U[:, :self.n_phys])), lp, -np.inf)
        if self.release_fixed is None:
            rel = U[:, self.n_phys + 1:]
            inside = np.all((rel > self.release_low[None, :]) & (rel < self.release_high[None, :]), axis=1)
            lp = lp + np.where(inside, 0.0, -np.inf)
        return lp

    def log_likelihood(self, U: np.ndarray, residuals: np.ndarray | None = None) -> np.ndarray:
        U = np.atleast_2d(U)
        r = self.residuals(self.to_lsq(U)) if residuals is None else residuals
        sigma = np.exp(U[:, self.n_phys])
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
                             "half_width": self.half_width, "shift_half_width": self.shift_half_width,
                             "release_bounds": [[float(a), float(b)] for a, b in zip(self.release_low, self.release_high)],
                             "fixed_releases": None if self.release_fixed is None else [float(q) for q in self.release_fixed]},
                            sort_keys=True).encode())
        for s in self.segments:
            h.update(np.ascontiguousarray(s.t).tobytes())
            h.update(np.ascontiguousarray(s.y).tobytes())
            h.update(np.float64(s.t_release).tobytes())
        return h.hexdigest()[:16]
