"""Fast reduced models of the experiments, vectorised over a batch of parameter sets.

The diagnosis fits every candidate effect by SIMULATION error, many parameter sets at a time
(all candidates, all finite-difference perturbations, all releases and cross-validation folds
in one batch).  Each model here integrates its experiment's equation of motion for a batch of
B parameter sets at once with NumPy arrays of shape (B,), so the per-step Python overhead is
paid once for the whole batch.  The effect torques come from `roboball.physics.effects`, the
same law functions that the Drake augmented model evaluates symbolically.

Models (coordinates measured from the baseline model's rest; robot facts from configs/robot.yaml):

* `StandModel` (steer_stand, drive_stand): one rigid pendulum about the joint axis,
      I qdd = -k_g sin q - c qd + tau_effects(q, qd)
  with I, k_g = m g d and the rest angle from `RobotFacts.steer_stand_terms` /
  `drive_stand_terms` and the viscous coefficient c fitted inside the baseline.
* `ShellModel` (shell_rock): the whole robot (steering and drive locked) rolling without
  slipping on flat ground about the roll axis.  With d the distance of the centre of mass from
  the sphere's centre, m the total mass, I_c the roll inertia about the centre of mass and R the
  rolling radius (the shell's radius less half the static sink of Drake's compliant point
  contact, see `rolling_radius`), Lagrange's equation for the roll angle q (from rest) is
      M(q) qdd + m R d sin(q) qd^2 + k_g sin q = tau_effects(q, qd),
      M(q) = I_c + m (R^2 + d^2 - 2 R d cos q),  k_g = m g d,
  which at q = 0 gives eq. 4-5's M_eq and K_eq.
* `roboball.reduced.ramp.RampModel` (ramp): shell rolling + pendulum about the drive axis.

Integration: explicit midpoint (RK2) with a fixed step, 2 ms by default.  The dry-friction
laws switch sign within a step, so the method is only first order there, but at 2 ms the
simulation error of a 1-rad pendulum with 0.6 N m Coulomb friction is 0.3 mrad after fitting
(below the sensors' 1 mrad quantisation), against 1.8 mrad for semi-implicit Euler.
Outputs are stored at every step together with their time derivative, and evaluated at the
recording's own sample times by cubic Hermite interpolation.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from roboball.config import RobotFacts, load_robot
from roboball.physics import effects as fx
from roboball.physics.mathns import NP

DT = 2e-3


@dataclass
class BaseParam:
    """A parameter fitted inside the baseline (never reported as missing physics)."""

    name: str
    unit: str
    lo: float
    hi: float
    typical: float
    start: float


class ReducedModel:
    """Common interface of the reduced models.

    kind, signal (recording column), unit, dof (name used in diagnosis.json), rest (rest value
    of the signal in the model), context (experiment constants for the effect laws),
    base_params (fitted in the baseline), candidates (vocabulary entries that apply), and
    `simulate(q0, P, n_steps, dt) -> (Y, Ydot)`, each (n_steps + 1, B).
    """

    kind: str = ""
    signal: str = ""
    unit: str = "rad"
    dof: str = ""
    rest: float = 0.0
    base_params: tuple = ()
    candidates: tuple = ()
    release_params: tuple = ("q0", "t_shift")
    ts_bound: float = 0.1      # s: how far the fitted release instant may move from the finder's
    context: dict = {}
    description: str = ""

    def effect_torque(self, q, v, P: dict, active: list):
        """Sum of the active effects' torques (NumPy laws, batch arrays)."""
        return self.bind_effects(P, active)(q, v, np.zeros_like(np.asarray(q, dtype=float)))

    def bind_effects(self, P: dict, active: list):
        """A function add(q, v, tau) that adds the active effects' torques to `tau` in place
        (and returns it), with the parameters bound.

        Each effect is evaluated only on the rows where it is active when those rows form one
        contiguous block (the diagnosis orders its batches by candidate, so a candidate screened
        alone occupies one block); otherwise on the whole batch (zero magnitude -> zero torque).
        """
        full, part = [], []
        for name in active:
            eff = fx.LIBRARY[name]
            first = np.asarray(P[f"{name}.{eff.params[0].name}"])
            rows = np.nonzero(first != 0.0)[0]
            sl = None
            if rows.size and rows[-1] - rows[0] + 1 == rows.size and rows.size < first.size:
                sl = slice(int(rows[0]), int(rows[-1]) + 1)
            kw = {p: np.asarray(P[f"{name}.{p}"], dtype=float)[sl if sl is not None else slice(None)]
                  for p in eff.param_names}
            for key in eff.context:
                kw[key] = self.context[key]
            kw["m"] = NP
            if sl is None:
                full.append((eff.law, kw))
            else:
                part.append((eff.law, sl, kw))

        def add(q, v, tau):
            for law, kw in full:
                tau += law(q, v, **kw)
            for law, sl, kw in part:
                tau[sl] += law(q[sl], v[sl], **kw)
            return tau
        return add


def active_effects(P: dict, names) -> list:
    """Effects with any non-zero magnitude in the batch (the others cost nothing)."""
    out = []
    for name in names:
        eff = fx.LIBRARY[name]
        first = f"{name}.{eff.params[0].name}"
        if first in P and np.any(np.asarray(P[first]) != 0.0):
            out.append(name)
    return out


def _rk2_1dof(accel, q0, v0, n_steps, dt):
    """Explicit midpoint integration of qdd = accel(q, v) for a batch; returns Q, V.
    (In-place NumPy operations: the per-step cost is Python overhead, not arithmetic.)"""
    B = q0.shape[0]
    Q = np.empty((n_steps + 1, B))
    V = np.empty((n_steps + 1, B))
    q = q0.astype(float).copy()
    v = v0.astype(float).copy()
    qm, vm, tmp = np.empty(B), np.empty(B), np.empty(B)
    Q[0], V[0] = q, v
    h2 = 0.5 * dt
    mul, add = np.multiply, np.add
    for k in range(1, n_steps + 1):
        a1 = accel(q, v)
        mul(v, h2, out=tmp)
        add(q, tmp, out=qm)
        mul(a1, h2, out=tmp)
        add(v, tmp, out=vm)
        a2 = accel(qm, vm)
        mul(vm, dt, out=tmp)
        q += tmp
        mul(a2, dt, out=tmp)
        v += tmp
        Q[k] = q
        V[k] = v
    return Q, V


class StandModel(ReducedModel):
    """Rigid pendulum in the stand (steer or drive joint) with viscous damping."""

    release_params = ("q0", "t_shift")

    def __init__(self, kind: str = "steer_stand", robot: RobotFacts | None = None):
        robot = robot or load_robot()
        self.kind = kind
        terms = robot.steer_stand_terms if kind == "steer_stand" else robot.drive_stand_terms
        self.inertia = float(terms["inertia"])
        self.k_g = float(terms["mgd"])
        self.rest = float(terms["rest_angle"])
        self.context = {"k_g": self.k_g}
        self.signal = "steer_angle_rad" if kind == "steer_stand" else "drive_angle_rad"
        self.dof = "steer" if kind == "steer_stand" else "drive"
        self.base_params = (BaseParam("viscous_c", "N m s/rad", 0.0, 20.0, 0.1, 0.1),)
        self.candidates = ("coulomb_friction", "stiction", "quadratic_drag", "linear_stiffness",
                           "cubic_stiffness", "com_offset", "backlash")
        self.description = (f"rigid pendulum about the {self.dof} joint (I = {self.inertia:.4g} kg m^2, "
                            f"m g d = {self.k_g:.4g} N m, rest {self.rest:.4g} rad) with viscous joint damping")

    def simulate(self, q0, P: dict, n_steps: int, dt: float = DT):
        active = active_effects(P, self.candidates)
        c = np.asarray(P["viscous_c"], dtype=float)
        inv_i = 1.0 / self.inertia
        k_g = self.k_g
        extra = self.bind_effects(P, active) if active else None

        cv = np.empty_like(c) if c.ndim else None

        def accel(q, v):
            tau = np.sin(q)
            tau *= -k_g
            if cv is not None:
                np.multiply(c, v, out=cv)
                tau -= cv
            else:
                tau -= c * v
            if extra is not None:
                extra(q, v, tau)
            tau *= inv_i
            return tau

        q0 = np.asarray(q0, dtype=float) - self.rest
        Q, V = _rk2_1dof(accel, q0, np.zeros_like(q0), n_steps, dt)
        Q += self.rest
        return Q, V


class ShellModel(ReducedModel):
    """The locked-steer robot rolling without slipping (rigid point contact, no shell terms)."""

    release_params = ("q0", "t_shift")

    def __init__(self, robot: RobotFacts | None = None):
        robot = robot or load_robot()
        self.kind = "shell_rock"
        links = robot.links
        m = sum(l.mass_kg for l in links.values())
        yc = sum(l.mass_kg * l.com_m[1] for l in links.values()) / m
        zc = sum(l.mass_kg * l.com_m[2] for l in links.values()) / m
        i_c = 0.0
        for l in links.values():
            i_c += l.inertia_kg_m2[0] + l.mass_kg * ((l.com_m[1] - yc) ** 2 + (l.com_m[2] - zc) ** 2)
        self.mass, self.i_com = m, i_c
        self.radius = rolling_radius(robot)
        self.d = math.hypot(yc, zc)
        # The rest angle solves yc cos(phi) = zc sin(phi) with the centre of mass below the centre
        # (zc < 0, where atan2(yc, zc) would give the angle near +-pi): phi_r = atan(yc / zc).
        self.rest = float(math.atan(yc / zc))
        self.k_g = m * robot.g * self.d
        self.context = {"k_g": self.k_g}
        self.signal = "pipe_angle_rad"
        self.dof = "roll"
        self.base_params = ()
        self.candidates = ("viscous_damping", "rolling_resistance", "quadratic_drag", "linear_stiffness",
                           "cubic_stiffness", "com_offset")
        self.m_eq = i_c + m * (self.radius - self.d) ** 2
        self.description = (f"rigid sphere rolling without slipping, steering locked, no shell terms "
                            f"(M_eq = {self.m_eq:.4g} kg m^2, K_eq = {self.k_g:.4g} N m/rad, rest {self.rest:.4g} rad)")

    def simulate(self, q0, P: dict, n_steps: int, dt: float = DT):
        active = active_effects(P, self.candidates)
        m, R, d, k_g = self.mass, self.radius, self.d, self.k_g
        m0 = self.i_com + m * (R * R + d * d)
        mrd2 = 2.0 * m * R * d
        mrd = m * R * d
        extra = self.bind_effects(P, active) if active else None

        def accel(q, v):
            s = np.sin(q)
            tau = v * v
            tau *= -mrd
            tau -= k_g
            tau *= s
            if extra is not None:
                extra(q, v, tau)
            den = np.cos(q)
            den *= -mrd2
            den += m0
            tau /= den
            return tau

        q0 = np.asarray(q0, dtype=float) - self.rest
        Q, V = _rk2_1dof(accel, q0, np.zeros_like(q0), n_steps, dt)
        Q += self.rest
        return Q, V


_ROLLING_RADIUS: dict = {}


def rolling_radius(robot: RobotFacts) -> float:
    """Rolling radius of the shell on Drake's rigid point contact (cached per robot).

    Drake's point contact is compliant: under the robot's weight the sphere sinks by a small
    depth delta (0.8 mm with the default penetration allowance) and the contact point sits
    halfway into the overlap, so the shell rolls on a radius R - delta / 2.  The baselines of
    the shell and ramp runs ARE Drake's point-contact models (the report shows them), so the
    reduced models roll on that radius; delta is measured once from a Drake plant at rest.
    """
    key = (robot.source, robot.radius, robot.total_mass)
    if key not in _ROLLING_RADIUS:
        from roboball.sim.plant import SimSpec, build
        from roboball.sim.scenarios import simulate
        spec = SimSpec(kind="shell_rock", contact="point", friction={"steer": "none", "drive": "none"}, robot=robot)
        _, x = simulate(spec, robot.shell_rest_angle, 0.5, sample_rate_hz=100.0, return_states=True)
        lay = build(spec).layout
        h = float(np.mean(x[lay.base_q + 6, -20:]))
        _ROLLING_RADIUS[key] = robot.radius - 0.5 * (robot.radius - h)
    return _ROLLING_RADIUS[key]


def model_for(kind: str, robot: RobotFacts | None = None, **kw) -> ReducedModel:
    """The reduced model of an experiment kind."""
    if kind in ("steer_stand", "drive_stand"):
        return StandModel(kind, robot)
    if kind == "shell_rock":
        return ShellModel(robot)
    if kind == "ramp":
        from roboball.reduced.ramp import RampModel
        return RampModel(robot, **kw)
    raise ValueError(f"no reduced model for kind '{kind}'")


def hermite(Y, Yd, dt: float, tau, cols):
    """Cubic Hermite interpolation of stored outputs at times `tau` (array (n_b, n_s), s from
    the start of each batch column `cols` (n_b,)); values before 0 take the initial value."""
    n = Y.shape[0] - 1
    x = np.clip(tau / dt, 0.0, n - 1e-9)
    i = np.floor(x).astype(int)
    s = x - i
    c = cols[:, None]
    y0, y1 = Y[i, c], Y[i + 1, c]
    d0, d1 = Yd[i, c] * dt, Yd[i + 1, c] * dt
    s2, s3 = s * s, s * s * s
    return ((2 * s3 - 3 * s2 + 1) * y0 + (s3 - 2 * s2 + s) * d0 + (-2 * s3 + 3 * s2) * y1 + (s3 - s2) * d1)
