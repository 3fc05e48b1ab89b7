"""A 3-D injected shell: the paper's eq. 9 about both horizontal rolling axes, heading-free.

The paper injects K_inject and C_inject (eq. 7-8) in the steering plane only: the stiffness acts
on the pipe angle phi (the base's roll about world x) and the damping on the world-x angular
rate, plus a damping-only term about the driveshaft for the ramp (section IV).  Those are tied
to one direction of the world and of the robot: turn the scene by 90 deg about the vertical and
the "steer" term acts on the wrong axis.

`InjectedShell3D` uses the same K(p), C(p) and the same law (`shell.injected_torque`) on
vector quantities that do not depend on a heading:

* Stiffness on the **tilt of the base** (pitch_center, which carries the pendulum) from its
  upright rest: the rotation vector that takes world z onto the base's z axis,
  tilt = angle * (e_z x b_z) / |e_z x b_z|, angle = atan2(|e_z x b_z|, b_z . e_z).  It is
  horizontal by construction, bounded while the pipe rolls on (the base only swings), and
  for a pure roll phi about x it is exactly (phi, 0, 0): the planar model's K phi.  Gravity's
  restoring torque on the same tilt is what K_eq of eq. 4 describes, so K_inject stiffens it
  the same way in every direction.  The torque -K tilt acts on the base.
* Damping on the **rolling angular velocity of the pipe** (the shell's body): the pipe's world
  angular velocity with its spin about the ground normal n removed, w_t = w - (w . n) n.  A
  couple -C w_t on the pipe, which enters the generalised forces on the base's angular
  velocity and on the drive joint (its axis is the base's -y).  For a pure roll about x this is
  the planar -C phi_dot; for rolling about the driveshaft it is the planar drive term -C omega_d.

So locked-steer rocking gives the planar model's equations exactly, rolling down a ramp adds
the stiffness about the driveshaft that the paper drops, and the whole term is equivariant
under rotations about the vertical: a run in any heading is the same run turned.

Quantities are written once for NumPy and Drake symbolic arrays (`Kin.m`), as in
`roboball.sim.forces`; K and C may be numbers or symbolic expressions (pressure input).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pydrake.symbolic as sym

from roboball.physics import shell as shell_laws
from roboball.sim.forces import SYM, ForceTerm, Kin


def _ops(kin: Kin):
    if kin.m is SYM:
        return sym.atan2, sym.sqrt, sym.if_then_else
    return np.arctan2, np.sqrt, np.where


def base_tilt(kin: Kin) -> list:
    """Rotation vector (world frame, horizontal) from upright to the base's orientation,
    ignoring its yaw: see the module docstring.  Equals (phi, 0, 0) for a roll phi about x."""
    atan2, sqrt, where = _ops(kin)
    R = kin.base_rotation()
    bx, by, bz = R[0][2], R[1][2], R[2][2]          # base z axis in the world
    s = sqrt(bx * bx + by * by)                      # |e_z x b_z| = sin(tilt angle)
    if kin.m is SYM:
        ratio = where(s > 1e-9, atan2(s, bz) / s, 1.0)
    else:
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = where(s > 1e-9, atan2(s, bz) / np.where(s > 1e-9, s, 1.0), 1.0)
    return [-by * ratio, bx * ratio, 0.0 * s]


def pipe_angular_velocity(kin: Kin) -> list:
    """World angular velocity of the pipe (the shell's body): the base's plus the drive joint's
    rate about its axis, the base's -y."""
    i = kin.layout.base_v
    w = [kin.v[i], kin.v[i + 1], kin.v[i + 2]]
    if "drive" in kin.layout.joint_v:
        R = kin.base_rotation()
        qd = kin.v[kin.layout.joint_v["drive"]]
        w = [w[k] - R[k][1] * qd for k in range(3)]
    return w


def rolling_rate(kin: Kin, normal) -> list:
    """The pipe's angular velocity without its spin about the ground normal (world frame)."""
    w = pipe_angular_velocity(kin)
    n = [float(c) for c in normal]
    wn = w[0] * n[0] + w[1] * n[1] + w[2] * n[2]
    return [w[k] - wn * n[k] for k in range(3)]


@dataclass
class InjectedShell3D(ForceTerm):
    """Eq. 9 as vectors: -K tilt on the base, -C (rolling rate) on the pipe; any heading."""

    k_inject: object
    c_inject: object
    normal: tuple = (0.0, 0.0, 1.0)
    stiffness: bool = True
    damping: bool = True
    name: str = "injected_shell_3d"

    def torques(self, kin: Kin) -> tuple[list, list]:
        """(stiffness torque on the base, damping couple on the pipe), world frame."""
        zero = [0.0, 0.0, 0.0]
        t_k, t_c = zero, zero
        if self.stiffness:
            tilt = base_tilt(kin)
            t_k = [shell_laws.injected_torque(tilt[k], 0.0, self.k_inject, 0.0) for k in range(3)]
        if self.damping:
            w_t = rolling_rate(kin, self.normal)
            t_c = [shell_laws.injected_torque(0.0, w_t[k], 0.0, self.c_inject) for k in range(3)]
        return t_k, t_c

    def expressions(self, kin: Kin) -> list:
        if kin.layout.base_v is None:
            return []
        i = kin.layout.base_v
        t_k, t_c = self.torques(kin)
        out = []
        # The base's generalised velocities start with its world angular velocity: a world
        # torque on the base (or on the pipe, which shares that rotation) enters there as is.
        for k in range(3):
            if self.stiffness and k < 2:
                out.append((i + k, t_k[k]))
            if self.damping:
                out.append((i + k, t_c[k]))
        if self.damping and "drive" in kin.layout.joint_v:
            # The pipe also turns with the drive joint about the base's -y: power T . (-y_b) qd.
            R = kin.base_rotation()
            out.append((kin.layout.joint_v["drive"], -(R[0][1] * t_c[0] + R[1][1] * t_c[1] + R[2][1] * t_c[2])))
        return out
