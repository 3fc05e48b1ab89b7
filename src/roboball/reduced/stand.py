"""The stand model of the diagnosis: one rigid pendulum about the joint axis (steer_stand, drive_stand),

    (I + delta_i) qdd = -k_g sin q - c qd + tau_effects(q, qd),

with I, k_g = m g d and the rest angle from `RobotFacts.steer_stand_terms` /
`drive_stand_terms`, the viscous coefficient c fitted inside the baseline and delta_i the
inertia an `added_inertia` effect adds (0 without it).  Integrated by
explicit midpoint (`roboball.reduced.integrate.midpoint`), batched over parameter sets.
"""
from __future__ import annotations

import numpy as np

from roboball.config import RobotFacts, load_robot
from roboball.reduced.base import DT, BaseParam, ReducedModel, active_effects
from roboball.reduced.integrate import midpoint


class StandModel(ReducedModel):
    """Rigid pendulum in the stand (steer or drive joint) with viscous damping."""

    release_params = ("q0", "t_shift")
    # Coulomb friction and a quadratic drag on large swings (1.2 rad) under 2 mrad of noise: the
    # friction alone fits better than the baseline but holds out worse (it cannot follow both
    # releases' decay), the drag alone is absorbed by the viscous coefficient, so the first round
    # keeps nothing and the pair is never grown: the pair's second round runs regardless.
    search_rounds = 2

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
                           "cubic_stiffness", "com_offset", "backlash", "added_inertia")
        self.description = (f"rigid pendulum about the {self.dof} joint (I = {self.inertia:.4g} kg m^2, "
                            f"m g d = {self.k_g:.4g} N m, rest {self.rest:.4g} rad) with viscous joint damping")

    def simulate(self, q0, P: dict, n_steps: int, dt: float = DT):
        if self.compiled:
            return self.stepper(q0, P, dt).advance(n_steps)
        active = active_effects(P, self.candidates)
        c, inv_i = self._damping_inertia(P, active)
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
        Q, V = midpoint(accel, q0, np.zeros_like(q0), n_steps, dt)
        Q += self.rest
        return Q, V

    def _damping_inertia(self, P: dict, active: list):
        """The viscous coefficient and 1 / inertia, per row where they vary."""
        c = np.asarray(P["viscous_c"], dtype=float)
        inv_i = 1.0 / self.inertia
        added = self.bind_inertia(P, active) if active else None
        if added is not None:
            inv_i = 1.0 / (self.inertia + added)
        return c, inv_i

    def stepper(self, q0, P: dict, dt: float = DT):
        """The compiled loop as a roboball.reduced.compiled.Stepper (a batch run a stretch at a time)."""
        from roboball.reduced import compiled
        active = active_effects(P, self.candidates)
        c, inv_i = self._damping_inertia(P, active)
        q0 = np.asarray(q0, dtype=float) - self.rest
        codes, par = compiled.effect_arrays(self, P, active, q0.size)
        return compiled.stand_stepper(self, q0, c, inv_i, codes, par, dt)
