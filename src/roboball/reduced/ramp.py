"""Reduced planar model of the ramp descent, vectorised over a batch of parameter sets.

The diagnosis searches effects on the ramp with this model and shows the result in Drake's
`ramp` scenario (point contact, Majd friction on both joints); `tests/reduced/test_reduced_vs_drake.py`
checks that the two agree.

Model: two rigid bodies in the vertical plane of the descent.
* the shell (pipe assembly: mass m_s, centre of mass at the sphere's centre, inertia I_s about
  the driveshaft) on an incline of angle alpha: its centre moves by s along the slope and it
  turns by theta about the robot's +y (positive rolling downhill); theta' is the recording's
  drive_rate.  It rolls on the radius R of Drake's compliant point contact
  (roboball.reduced.shell.rolling_radius);
* the pitch centre and pendulum (steering held at zero, as one body: mass m_p, centre of mass
  a distance -z_c below the centre in its own frame, inertia I_p about the driveshaft through
  its centre of mass) swing about the driveshaft with world pitch angle beta (0 = hanging).
With M = m_s + m_p and F the ground's friction force on the shell along the slope, Lagrange's
equations are
    M s'' + m_p z_c [cos(beta - alpha) beta'' - sin(beta - alpha) beta'^2] = M g sin(alpha) + F
    I_s theta'' = -R F + Q_theta
    (I_p + m_p z_c^2) beta'' + m_p z_c cos(beta - alpha) s'' = m_p g z_c sin(beta) + Q_beta.
The drive joint's angle is q_d = beta - theta (the pipe turns about -y relative to the pitch
centre), so Majd friction tau_d(q_d') (Table I, drive) enters as Q_theta = -tau_d,
Q_beta = +tau_d; effects on the rolling coordinate (roboball.physics.effects: rolling
resistance, shell damping, drag) add tau_e(theta, theta') to Q_theta.

Rolling or sliding.  The shell rolls (s = R theta) while the friction it needs stays within
Coulomb's cone, |F| <= mu N (mu = 0.2, the ground friction of the robot facts; N the normal
force including the pendulum's swing).  Since mu < tan(16 deg), a strong braking torque on the
shell (heavy damping near top speed) makes it SLIDE down the ramp with F = mu N opposing the
slip, as Drake's point contact does; the model switches per batch member and re-sticks when the
slip velocity s' - R theta' changes sign.  Left out: the steer joint and the roll (pipe_angle)
motion.  In Drake the pendulum swings sideways on the steer joint during a descent, by up to
0.07 rad with Table I friction and 0.11 rad with the weaker steer friction fitted on the stand
logs; the planar model then runs up to 0.2% (Table I) or 0.6% (fitted) of the top rate faster,
+0.02% or +0.09% by eq. 12 (tests/reduced/test_reduced_vs_drake.py).

Integration: explicit midpoint (RK2) with a fixed step (2 ms), the contact mode frozen within
a step.  The loop is the model's own, not roboball.reduced.integrate.midpoint: it carries five
coordinates and a contact mode, and reuses the derivative at the end of a step as the recorded
rate and the next step's first stage.  The equations are written once, in
roboball.reduced.ramp_equations, for this NumPy loop and the compiled one that the diagnosis runs
(roboball.reduced.compiled.ramp_run; `compiled = False` selects the NumPy loop, its reference).
"""
from __future__ import annotations

import math

import numpy as np

from roboball.config import RobotFacts, load_robot
from roboball.physics.mathns import NP
from roboball.reduced import ramp_equations as eq
from roboball.reduced.base import DT, ReducedModel, active_effects
from roboball.reduced.shell import rolling_radius
from roboball.physics import friction as friction_laws


class RampModel(ReducedModel):
    """Planar ramp descent: rolling shell + pendulum about the driveshaft."""

    # No release state is fitted: the descent starts at rest at the instant the release finder
    # detects (its hinge fit is within -1.5..+2.1 ms of the test bed's let-go instants,
    # benchmarks/ramp_release_audit.py), the instant from which every model of Fig. 13/14,
    # the diagnosed one included, is run and scored.  A fitted start is confounded with a torque
    # that acts from the first instant: with a 2.5 ms bound every pooled ramp diagnosis put its
    # start at the bound, late, standing in for part of the rolling resistance.
    release_params = ()

    def __init__(self, robot: RobotFacts | None = None, ramp_angle_deg: float | None = None,
                 friction: dict | None = None):
        """`friction`: Majd parameters per joint ({"steer": {...}, "drive": {...}}) that replace
        Table I in the baseline (the pipeline passes the friction fitted on the stand logs, so
        that the diagnosed model is the paper's point model + the effects found).  The reduced
        model carries the drive joint's law; the Drake runs carry both."""
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
        self.mu = float(robot.data["shell"]["ground_friction"])
        friction = {j: dict(p) for j, p in (friction or {}).items() if p}
        unknown = set(friction) - {"steer", "drive"}
        if unknown:
            raise ValueError(f"baseline friction for unknown joint(s) {', '.join(sorted(unknown))} (steer, drive)")
        for joint, params in friction.items():
            missing = set(friction_laws.PARAMS["majd"]) - set(params)
            if missing:
                raise ValueError(f"baseline {joint} friction lacks Majd parameter(s) {', '.join(sorted(missing))}")
        self.friction_params = {j: {k: float(friction[j][k]) for k in friction_laws.PARAMS["majd"]}
                                for j in friction}
        self.majd = self.friction_params.get("drive") or robot.majd_params("drive")
        source = "fitted" if friction else "Table I"
        self.context = {"k_g": 0.0}
        self.base_params = ()
        # stiction here is the shell's breakaway from the flat it rests on, its width fitted
        self.candidates = ("viscous_damping", "rolling_resistance", "quadratic_drag", "stiction")
        self.held_params = {}
        self.description = (f"planar ramp descent on {math.degrees(self.alpha):.3g} deg: shell rolling (or "
                            f"sliding beyond mu = {self.mu:g}) on rigid point contact + pendulum about the "
                            f"driveshaft, Majd friction ({source}) on both joints (the planar model holds the "
                            f"steering at zero, so only the drive joint's acts in it)")

    def simulate(self, q0, P: dict, n_steps: int, dt: float = DT):
        """Released from rest (pendulum hanging) for a batch; returns drive rate and its
        derivative at every step, (n_steps + 1, B) each.  `q0` only sets the batch size.

        Explicit midpoint with the contact mode frozen within a step; the derivative at the end
        of a step is the output's rate and the next step's first stage."""
        B = np.asarray(q0).shape[0]
        active = active_effects(P, self.candidates)
        const = self.row_constants(P, B)
        if self.compiled:
            from roboball.reduced import compiled
            return compiled.ramp_run(self, P, active, B, n_steps, dt, const)
        deriv = self._equations(self.bind_effects(P, active) if active else None, const)
        Y = np.empty((n_steps + 1, B))
        Yd = np.empty((n_steps + 1, B))
        th, be, vs, w, wb = (np.zeros(B) for _ in range(5))
        sliding = np.zeros(B, bool)
        direction = np.zeros(B)
        h2 = 0.5 * dt
        as1, a1, b1, f_req, normal = deriv(th, be, vs, w, wb, sliding, direction)
        Y[0], Yd[0] = w, a1
        for k in range(1, n_steps + 1):
            sliding, direction, vs, w, changed = self._contact_mode(sliding, direction, f_req, normal, vs, w, const)
            if changed:
                as1, a1, b1, f_req, normal = deriv(th, be, vs, w, wb, sliding, direction)
            as2, a2, b2, _, _ = deriv(th + h2 * w, be + h2 * wb, vs + h2 * as1, w + h2 * a1, wb + h2 * b1,
                                      sliding, direction)
            th = th + dt * (w + h2 * a1)
            be = be + dt * (wb + h2 * b1)
            vs = vs + dt * as2
            w = w + dt * a2
            wb = wb + dt * b2
            as1, a1, b1, f_req, normal = deriv(th, be, vs, w, wb, sliding, direction)
            Y[k], Yd[k] = w, a1
        return Y, Yd

    def constants(self) -> tuple:
        """The constants of roboball.reduced.ramp_equations (its `constants`)."""
        return eq.constants(self)

    window_keys = ("ramp_angle_rad",)

    def window_values(self, window) -> dict:
        """A pooled run's own ramp angle (its recording's; the model's where it has none)."""
        deg = getattr(getattr(window, "source", None), "ramp_angle_deg", None)
        return {"ramp_angle_rad": math.radians(deg) if deg is not None else self.alpha}

    def row_constants(self, P: dict, B: int) -> tuple:
        """The constants of each batch row: the model's (floats) unless P gives rows their own
        ramp angle (`ramp_angle_rad`, runs on several ramps diagnosed together), then a (B,)
        array each."""
        a = P.get("ramp_angle_rad")
        if a is None or np.all(np.asarray(a) == self.alpha):
            return self.constants()
        angles, row = np.unique(np.broadcast_to(np.asarray(a, dtype=float), (B,)), return_inverse=True)
        K = np.array([eq.constants(self, x) for x in angles])[row]     # once per ramp, not per row
        return tuple(K[:, j].copy() for j in range(K.shape[1]))

    def majd_args(self) -> tuple:
        """The drive joint's Majd parameters (f_w, f_c, sigma, omega_c, n)."""
        return tuple(float(self.majd[p]) for p in ("f_w", "f_c", "sigma", "omega_c", "n"))

    def _contact_mode(self, sliding, direction, f_req, normal, vs, w, k):
        """Contact mode for the next step: start sliding where rolling needs more than mu N;
        stick again where the slip velocity has reversed.  Returns (sliding, direction, vs, w,
        whether any member slides so that the step's first derivative must be re-evaluated)."""
        start = ~sliding & eq.exceeds_cone(f_req, normal, k, NP)
        if start.any():
            direction = np.where(start, np.sign(f_req), direction)
            sliding = sliding | start
        if not sliding.any():
            return sliding, direction, vs, w, False
        stick = sliding & eq.slip_reversed(vs, w, direction, k)
        if stick.any():
            vs_new, w_new = eq.restick(vs, w, k)
            w = np.where(stick, w_new, w)
            vs = np.where(stick, vs_new, vs)
            sliding = sliding & ~stick
        return sliding, direction, vs, w, True

    def _equations(self, extra, k):
        """deriv(theta, beta, s', theta', beta', sliding, direction) -> (s'', theta'', beta'', the
        friction the rolling mode needs, the normal force) for the current contact mode of each
        member, with the constants `k` (row_constants); `extra(q, v, tau)` adds the effects'
        torques on the rolling coordinate."""
        mj = self.majd_args()

        def deriv(th, be, vs, w, wb, sliding, direction):
            tau_d = friction_laws.majd(wb - w, *mj)
            q_th = -tau_d
            if extra is not None:
                q_th = extra(th, w, q_th)
            cba, sba, rhs_s, rhs_b = eq.terms(be, wb, tau_d, k, NP)
            s_r, th_r, be_r, f_req, normal = eq.rolling(cba, sba, rhs_s, rhs_b, wb, q_th, k)
            if not sliding.any():
                return s_r, th_r, be_r, f_req, normal
            s_sl, th_sl, be_sl = eq.sliding(cba, rhs_s, rhs_b, q_th, normal, direction, k, NP)
            return (np.where(sliding, s_sl, s_r), np.where(sliding, th_sl, th_r),
                    np.where(sliding, be_sl, be_r), f_req, normal)

        return deriv
