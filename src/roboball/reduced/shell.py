"""The shell model of the diagnosis (shell_rock): the whole robot (steering and drive locked)
rolling without slipping on flat ground about the roll axis.

With d the distance of the centre of mass from the sphere's centre, m the total mass, I_c the
roll inertia about the centre of mass and R the rolling radius (the shell's radius less half the
static sink of Drake's compliant point contact, see `rolling_radius`), Lagrange's equation for
the roll angle q (from rest) is

    M(q) qdd + m R d sin(q) qd^2 + k_g sin q = tau_effects(q, qd),
    M(q) = I_c + m (R^2 + d^2 - 2 R d cos q),  k_g = m g d,

which at q = 0 gives eq. 4-5's M_eq and K_eq.  Integrated by explicit midpoint
(`roboball.reduced.integrate.midpoint`), batched over parameter sets.
"""
from __future__ import annotations

import math

import numpy as np

from roboball.config import RobotFacts, load_robot
from roboball.reduced.base import DT, ReducedModel, active_effects
from roboball.reduced.integrate import midpoint


class ShellModel(ReducedModel):
    """The locked-steer robot rolling without slipping (rigid point contact, no shell terms)."""

    release_params = ("q0", "t_shift")

    def __init__(self, robot: RobotFacts | None = None):
        robot = robot or load_robot()
        self.kind = "shell_rock"
        m, yc, zc, i_c = composite(robot.links, tuple(robot.links))
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
        if self.compiled:
            return self.stepper(q0, P, dt).advance(n_steps)
        active = active_effects(P, self.candidates)
        k_g = self.k_g
        mrd, mrd2, m0 = self._constants()
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
        Q, V = midpoint(accel, q0, np.zeros_like(q0), n_steps, dt)
        Q += self.rest
        return Q, V

    def _constants(self) -> tuple:
        """m R d, 2 m R d and m0 = I_c + m (R^2 + d^2) of the equation (module docstring)."""
        m, R, d = self.mass, self.radius, self.d
        return m * R * d, 2.0 * m * R * d, self.i_com + m * (R * R + d * d)

    def stepper(self, q0, P: dict, dt: float = DT):
        """The compiled loop as a roboball.reduced.compiled.Stepper (a batch run a stretch at a time)."""
        from roboball.reduced import compiled
        active = active_effects(P, self.candidates)
        q0 = np.asarray(q0, dtype=float) - self.rest
        codes, par = compiled.effect_arrays(self, P, active, q0.size)
        return compiled.shell_stepper(self, q0, self.k_g, *self._constants(), codes, par, dt)


def composite(links, names) -> tuple:
    """Mass (kg), centre of mass (y, z; m) and roll inertia about it (kg m^2) of the links
    `names` moving as one body."""
    m = sum(links[n].mass_kg for n in names)
    yc = sum(links[n].mass_kg * links[n].com_m[1] for n in names) / m
    zc = sum(links[n].mass_kg * links[n].com_m[2] for n in names) / m
    i_c = 0.0
    for n in names:
        link = links[n]
        i_c += link.inertia_kg_m2[0] + link.mass_kg * ((link.com_m[1] - yc) ** 2 + (link.com_m[2] - zc) ** 2)
    return m, yc, zc, i_c


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
        from roboball.sim.plant import build
        from roboball.sim.scenarios import simulate
        from roboball.sim.spec import SimSpec
        spec = SimSpec(kind="shell_rock", contact="point", friction={"steer": "none", "drive": "none"}, robot=robot)
        _, x = simulate(spec, robot.shell_rest_angle, 0.5, sample_rate_hz=100.0, return_states=True)
        lay = build(spec).layout
        h = float(np.mean(x[lay.base_q + 6, -20:]))
        _ROLLING_RADIUS[key] = robot.radius - 0.5 * (robot.radius - h)
    return _ROLLING_RADIUS[key]
