"""The virtual robot's shell: a pressurised membrane with a bedliner skin on a flat floor.

Written from the shell's physics, in none of the forms the pipeline fits (the injected
k0 + k1 p stiffness and c0 exp(c1 p) damping, viscous / Coulomb / quadratic damping, tanh
rolling resistance).  The argument for every number is in docs/testbed.md; in short:

Contact patch (membrane limit).  The gauge pressure p carries the weight W over the patch, so
the patch area is A = W / p and its radius a = sqrt(W / (pi p)); the undeformed sphere of
radius R meets it at the half-angle beta = asin(a / R).

Restoring torque: the flat the patch leaves in the skin.  The bedliner creeps into the shape
of the floor over the patch while the shell sits still and keeps that flat for its creep time
T_set (long: the flat is set where the shell rests, and a hand's hold of a second barely moves
it).  The membrane tension p R / 2 pulls the skin back to round against the skin's set tension
T_b, so the skin keeps the share s = T_b / (T_b + p R / 2) of the patch's flat.  Rolled by
Delta away from its flat, the shell tilts the flat on the floor.  A full flat would react like
a Winkler foundation whose modulus reproduces the membrane's vertical stiffness (the patch grows
by 2 pi R per metre of sag: dW/d delta = 2 pi R p, i.e. k_w = 2 pi R p^2 / W per unit area):
small-tilt stiffness k_w I_patch = k_w pi a^4 / 4 = R W / 2, trailing edge lifting off at
Delta_l = a / (2 R).  Beyond lift-off the pressure centre moves toward the leading edge as on a
rocking strip foundation, K Delta_l (3 - 2 sqrt(Delta_l / |Delta|)) (continuous in value and
slope), and no more than the weight's lever about the flat's edge allows, W R sin(beta - |Delta|):
once the flat has rolled off the floor (|Delta| >= beta) it holds nothing.  The set flat gives
the share s of this torque.  The flat creeps toward the current bottom:
dDelta/dt = omega - Delta / T_set.

Rolling loss: the bedliner's hysteresis as it enters and leaves the patch (Tabor, Greenwood:
for a sphere M_h = (3/16) alpha W a, alpha the fraction of the strain energy lost).  The
bedliner's fast relaxation is a standard linear solid of retardation time tau_h: the skin is
strained once per passage of the patch, at the frequency w_c = R |omega| / (2 a), and its loss
follows the Debye peak alpha(w_c) = alpha_p 2 x / (1 + x^2), x = w_c tau_h.

The patch is round, so the same law acts in both rolling directions (the steer direction:
the pipe's roll, and the drive direction), each with its own flat state.

Two terms of the real robot that the test bed's own robot has off (neutral: truth.yaml's base
values; the calibrated twin's `real_robot:` section sets them, docs/testbed.md):

* the set flat's size (`patch(set_at_kpa=)`): the skin took its set while the robot stood at
  one pressure, so the flat in the skin has that pressure's patch size, not the current one's;
* the shell's profile (`profile_torque`): the pipe's mounting holds the shell out at its two
  poles (where the pipe meets the shell), so the shell is not a sphere but a body of
  revolution about the pipe a little longer along the pipe.  Tilting the pipe off horizontal
  brings a pole-ward, longer radius onto the floor and lifts the whole robot: a restoring
  torque of pure geometry, the same at every pressure.
"""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pydrake.symbolic as sym
from pydrake.systems.primitives import SymbolicVectorSystem

from roboball.sim.forces import SYM, Kin


def patch(weight_n: float, radius_m: float, p_kpa: float, set_tension_n_m: float,
          set_at_kpa: float | None = None) -> dict:
    """Geometry and stiffness of the contact patch at gauge pressure p (SI units).

    `set_at_kpa`: the pressure the skin took its set at (None: the current one, the test bed's own
    robot).  The flat crept into the skin over hours of standing; pumping the shell up for a
    test does not un-creep it within minutes, so the flat keeps the patch size of the pressure it
    was set at (a, beta, lift-off).  How much of it the skin holds against the membrane's pull
    (the share s) is the current pressure's: the tension p R / 2 acts now."""
    p = p_kpa * 1e3
    p_set = (set_at_kpa if set_at_kpa is not None else p_kpa) * 1e3
    a = math.sqrt(weight_n / (math.pi * p_set))           # m: A = W / p at the set's pressure
    if a >= radius_m:
        raise ValueError(f"pressure {p_set / 1e3:g} kPa too low: the patch exceeds the shell")
    share = set_tension_n_m / (set_tension_n_m + p * radius_m / 2.0)   # of the flat the skin keeps
    return dict(a=a, beta=math.asin(a / radius_m),        # rad: half-angle of the flat
                share=share,
                stiffness=radius_m * weight_n / 2.0,      # N m/rad: k_w pi a^4 / 4, a full flat
                lift_off=a / (2.0 * radius_m),            # rad: trailing edge leaves the floor
                weight=weight_n, radius=radius_m)


def flat_torque(delta, pt: dict, m=SYM):
    """Torque (N m) of the flat on a shell rolled by `delta` (rad) away from it: restoring."""
    mag = m.abs(delta)
    K, dl = pt["stiffness"], pt["lift_off"]
    rocking = K * dl * (3.0 - 2.0 * m.sqrt(dl / m.maximum(mag, dl)))
    elastic = m.where(mag <= dl, K * mag, rocking)
    pivot = pt["weight"] * pt["radius"] * m.sin(m.maximum(pt["beta"] - mag, 0.0))
    sign = m.where(delta >= 0.0, 1.0, -1.0)
    return -sign * pt["share"] * m.minimum(elastic, pivot)


def profile_torque(pipe_axis_z, pipe_axis_xy, weight_n: float, excess_m: float):
    """Torque (N m, world frame: (x, y) components; none about z) of the shell's profile on a
    robot whose pipe axis (unit vector u = R_WB e_y) has vertical component `pipe_axis_z` and
    horizontal components `pipe_axis_xy` = (u_x, u_y).

    The shell's radius grows from R at its equator to R + e at its poles (the pipe's ends hold
    it out): r(psi) = R + e cos^2(psi), psi measured from the pipe axis.  The centre of a
    convex body of revolution on a floor stands at its support height, to first order in e
    h = R + e sin^2(phi), phi the pipe axis's tilt from horizontal (sin phi = u_z).  The robot's
    weight W lifted by h is the potential W e u_z^2; its torque is u x (-dV/du) =
    -2 W e u_z (u x z_hat) = -2 W e u_z (u_y, -u_x, 0): -W e sin(2 phi) about the roll axis, zero
    for any turn about the pipe (rolling in the drive direction keeps the equator down).
    Pure geometry: it does not depend on the pressure, and it is about the pipe's horizontal,
    not about the robot's rest."""
    ux, uy = pipe_axis_xy
    k = -2.0 * weight_n * excess_m * pipe_axis_z
    return k * uy, -k * ux


def hysteresis_torque(omega, pt: dict, alpha_peak: float, loss_time_s: float):
    """Rolling loss (N m) of the bedliner's hysteresis at rolling rate omega (rad/s); odd in
    omega, so it needs no sign regularisation."""
    x = pt["radius"] * omega * loss_time_s / (2.0 * pt["a"])
    return -(3.0 / 16.0) * alpha_peak * pt["weight"] * pt["a"] * 2.0 * x / (1.0 + x * x)


def shell_system(pt: dict, bedliner: dict, roll_from_flat: float = 0.0, profile_excess_m: float = 0.0):
    """Factory (layout, dt) -> the shell as a discrete Drake system.  State: how far the shell
    has rolled from its flat in the steer (roll) and drive directions, less `roll_from_flat`
    (rad), the roll direction's value at the start (a hand held the shell away from the flat it
    rests on); input: plant state [q; v]; output: generalised force.  The flat's creep is
    integrated implicitly at the test bed's step, Delta+ = (Delta + dt omega) / (1 + dt / T_set).
    `profile_excess_m`: the shell's polar excess e (`profile_torque`; 0: a sphere)."""
    t_set, alpha, tau_h = bedliner["creep_s"], bedliner["hysteresis_loss_peak"], bedliner["loss_time_s"]

    def make(layout, dt):
        q = np.array([sym.Variable(f"q{i}") for i in range(layout.nq)], dtype=object)
        v = np.array([sym.Variable(f"v{i}") for i in range(layout.nv)], dtype=object)
        s_roll, d_drive = sym.Variable("flat_roll"), sym.Variable("flat_drive")
        d_roll = s_roll + roll_from_flat
        kin = Kin(layout, q, v, SYM)
        w_roll, w_drive = kin.pipe_rate(), kin.drive_rate()
        t_roll = flat_torque(d_roll, pt) + hysteresis_torque(w_roll, pt, alpha, tau_h)
        t_drive = flat_torque(d_drive, pt) + hysteresis_torque(w_drive, pt, alpha, tau_h)
        tau = [sym.Expression(0.0) for _ in range(layout.nv)]
        tau[layout.base_v] = tau[layout.base_v] + t_roll
        R = kin.base_rotation()
        for i in range(3):   # about the pipe's own axis, as the injected shell's drive term
            tau[layout.base_v + i] = tau[layout.base_v + i] + R[i][1] * t_drive
        if "drive" in layout.joint_v:
            tau[layout.joint_v["drive"]] = tau[layout.joint_v["drive"]] - t_drive
        if profile_excess_m:   # a floor-on-shell torque: on the base only, as the flat's
            tx, ty = profile_torque(R[2][1], (R[0][1], R[1][1]), pt["weight"], profile_excess_m)
            tau[layout.base_v] = tau[layout.base_v] + tx
            tau[layout.base_v + 1] = tau[layout.base_v + 1] + ty
        relax = 1.0 + dt / t_set
        system = SymbolicVectorSystem(
            state=[s_roll, d_drive], input=np.concatenate([q, v]),
            dynamics=[(d_roll + dt * w_roll) / relax - roll_from_flat, (d_drive + dt * w_drive) / relax],
            output=np.array(tau, dtype=object), time_period=dt)
        system.set_name("testbed_membrane_shell")
        return system
    return make


# The same laws on NumPy arrays (docs' tables, tests).
NP_NS = SimpleNamespace(abs=np.abs, sqrt=np.sqrt, sin=np.sin, maximum=np.maximum, minimum=np.minimum, where=np.where)
