"""Reduced planar model of the ramp descent, vectorised over a batch of parameter sets.

The diagnosis searches effects on the ramp with this model and shows the result in Drake's
`ramp` scenario (point contact, Majd friction on both joints); `tests/test_diagnose_models.py`
checks that the two agree.

Model: two rigid bodies in the vertical plane of the descent.
* the shell (pipe assembly: mass m_s, centre of mass at the sphere's centre, inertia I_s about
  the driveshaft) rolls without slipping down an incline of angle alpha on the rolling radius
  R of Drake's point contact (roboball.diagnose.models.rolling_radius); its rotation theta
  (about the robot's +y, positive rolling downhill) moves the centre by R theta along the slope,
  and its rate is the recording's drive_rate;
* the pitch centre and pendulum (steering held at zero, as one body: mass m_p, centre of mass
  a distance -z_c below the centre in its own frame, inertia I_p about the driveshaft through
  its centre of mass) swing about the driveshaft with world pitch angle beta (0 = hanging
  vertically).
Lagrange's equations with M = m_s + m_p:
    M11 theta'' + M12 beta'' = M g R sin(alpha) + m_p R z_c sin(beta - alpha) beta'^2 + Q_theta
    M12 theta'' + M22 beta'' = m_p g z_c sin(beta) + Q_beta
    M11 = M R^2 + I_s,  M22 = I_p + m_p z_c^2,  M12 = m_p R z_c cos(beta - alpha).
The drive joint's angle is q_d = beta - theta (the pipe turns about -y relative to the pitch
centre), so Majd friction tau_d(q_d') (Table I, drive) enters as Q_theta = -tau_d,
Q_beta = +tau_d.  Effects on the rolling coordinate (roboball.physics.effects, e.g. rolling
resistance, shell damping) add tau_e(theta, theta') to Q_theta.  Left out: the steer joint and
the roll (pipe_angle) motion, which stay within a few hundredths of a radian on the ramp.

Integration: explicit midpoint (RK2) with a fixed step (2 ms), like roboball.diagnose.models.
"""
from __future__ import annotations

import math

import numpy as np

from .config import RobotFacts, load_robot
from .diagnose.models import DT, ReducedModel, active_effects, rolling_radius
from .physics import friction as friction_laws


class RampModel(ReducedModel):
    """Planar ramp descent: rolling shell + pendulum about the driveshaft."""

    release_params = ("t_shift",)

    def __init__(self, robot: RobotFacts | None = None, ramp_angle_deg: float | None = None):
        robot = robot or load_robot()
        self.kind = "ramp"
        self.signal = "drive_rate_rad_s"
        self.unit = "rad/s"
        self.dof = "drive"
        self.rest = 0.0
        L = robot.links
        self.alpha = math.radians(ramp_angle_deg if ramp_angle_deg is not None else robot.ramp_angle_deg)
        pend = [L["pitch_center"], L["pendulum"]]
        self.m_p = sum(l.mass_kg for l in pend)
        self.x_c = sum(l.mass_kg * l.com_m[0] for l in pend) / self.m_p
        self.z_c = sum(l.mass_kg * l.com_m[2] for l in pend) / self.m_p
        self.i_p = sum(l.inertia_kg_m2[1] + l.mass_kg * ((l.com_m[0] - self.x_c) ** 2 + (l.com_m[2] - self.z_c) ** 2)
                       for l in pend)
        self.m_s = L["pipe_assembly"].mass_kg
        self.i_s = L["pipe_assembly"].inertia_kg_m2[1]
        self.radius = rolling_radius(robot)
        self.g = robot.g
        self.majd = robot.majd_params("drive")
        self.context = {"k_g": 0.0}
        self.base_params = ()
        self.candidates = ("viscous_damping", "rolling_resistance", "quadratic_drag")
        self.description = (f"planar ramp descent on {math.degrees(self.alpha):.3g} deg: shell rolling without "
                            "slipping (rigid point contact) + pendulum about the driveshaft, Majd friction "
                            "(Table I) on the drive joint")

    def simulate(self, q0, P: dict, n_steps: int, dt: float = DT):
        """Released from rest (pendulum hanging) for a batch; returns drive rate and its
        derivative at every step, (n_steps + 1, B) each.  `q0` only sets the batch size."""
        B = np.asarray(q0).shape[0]
        active = active_effects(P, self.candidates)
        M = self.m_s + self.m_p
        R, a, g = self.radius, self.alpha, self.g
        m11 = M * R * R + self.i_s
        m22 = self.i_p + self.m_p * self.z_c ** 2
        mrz = self.m_p * R * self.z_c
        mgz = self.m_p * g * self.z_c
        drive_torque = M * g * R * math.sin(a)
        mj = self.majd
        extra = self.bind_effects(P, active) if active else None

        def deriv(th, be, w, wb):
            cba = np.cos(be - a)
            sba = np.sin(be - a)
            m12 = mrz * cba
            tau_d = friction_laws.majd(wb - w, mj["f_w"], mj["f_c"], mj["sigma"], mj["omega_c"], mj["n"])
            f1 = drive_torque + mrz * sba * wb * wb - tau_d
            if extra is not None:
                f1 = f1 + extra(th, w)
            f2 = mgz * np.sin(be) + tau_d
            det = m11 * m22 - m12 * m12
            return (m22 * f1 - m12 * f2) / det, (m11 * f2 - m12 * f1) / det

        Y = np.empty((n_steps + 1, B))
        Yd = np.empty((n_steps + 1, B))
        th = np.zeros(B)
        be = np.zeros(B)
        w = np.zeros(B)
        wb = np.zeros(B)
        h2 = 0.5 * dt
        a1, b1 = deriv(th, be, w, wb)
        Y[0], Yd[0] = w, a1
        for k in range(1, n_steps + 1):
            a2, b2 = deriv(th + h2 * w, be + h2 * wb, w + h2 * a1, wb + h2 * b1)
            th = th + dt * (w + h2 * a1)
            be = be + dt * (wb + h2 * b1)
            w = w + dt * a2
            wb = wb + dt * b2
            a1, b1 = deriv(th, be, w, wb)
            Y[k], Yd[k] = w, a1
        return Y, Yd
