"""Generalised-force systems built from the physics laws, with no Python in the time loop.

Each non-conservative module (a joint friction law, the injected shell, a diagnosed effect)
is a `ForceTerm`: given symbolic joint state it returns generalised-force expressions at
velocity indices.  `build_force_system` evaluates every term's law function from
`roboball.physics` on Drake symbolic variables (math namespace `SYM`) and wraps the sum in a
`SymbolicVectorSystem` (plant state in, generalised force out), which Drake evaluates in C++
at every step.  The same law functions run on NumPy arrays in the reduced models, so both
paths share one implementation of the physics.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from types import SimpleNamespace
from typing import Callable

import numpy as np
import pydrake.symbolic as sym
from pydrake.systems.primitives import SymbolicVectorSystem

from roboball.physics import friction as friction_laws
from roboball.physics import shell as shell_laws


def _sign(x):
    return sym.if_then_else(x > 0, 1.0, sym.if_then_else(x < 0, -1.0, 0.0))


SYM = SimpleNamespace(
    name="drake.symbolic",
    exp=sym.exp, abs=sym.abs, sign=_sign, tanh=sym.tanh, sqrt=sym.sqrt,
    sin=sym.sin, cos=sym.cos, where=sym.if_then_else, minimum=sym.min, maximum=sym.max,
)


@dataclass
class StateLayout:
    """Where things live in the plant's state vector (filled by roboball.sim.plant)."""

    nq: int
    nv: int
    joint_q: dict = field(default_factory=dict)       # joint name -> position index
    joint_v: dict = field(default_factory=dict)       # joint name -> velocity index
    base_q: int | None = None                        # start of [qw qx qy qz x y z]
    base_v: int | None = None                        # start of [wx wy wz vx vy vz] (world frame)


class Kin:
    """Kinematic quantities of the robot as functions of state, on NumPy or symbolic arrays.

    Used by force terms (symbolic) and by signal extraction from logs (NumPy), so the
    definition of pipe_angle and drive_rate exists once.
    """

    def __init__(self, layout: StateLayout, q, v, m):
        self.layout, self.q, self.v, self.m = layout, q, v, m

    def _quat(self):
        i = self.layout.base_q
        return self.q[i], self.q[i + 1], self.q[i + 2], self.q[i + 3]

    def base_rotation(self):
        """R_WB from the base quaternion (rows of a 3x3 nested list)."""
        w, x, y, z = self._quat()
        return [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]

    def pipe_angle(self):
        """phi: roll (about x) of the floating base, Drake's RollPitchYaw convention."""
        w, x, y, z = self._quat()
        atan2 = sym.atan2 if self.m is SYM else np.arctan2
        return atan2(2 * (y * z + w * x), 1 - 2 * (x * x + y * y))

    def pipe_rate(self):
        """Roll rate used by the injected shell: world-x component of the base angular velocity."""
        return self.v[self.layout.base_v]

    def drive_rate(self):
        """omega_d: pipe angular velocity about the driveshaft (+y of the robot), downhill positive."""
        R = self.base_rotation()
        i = self.layout.base_v
        wx, wy, wz = self.v[i], self.v[i + 1], self.v[i + 2]
        w_base_y = R[0][1] * wx + R[1][1] * wy + R[2][1] * wz
        qd_drive = self.v[self.layout.joint_v["drive"]] if "drive" in self.layout.joint_v else 0.0
        # The drive joint's axis is -y: a positive joint rate turns the pipe about -y.
        return w_base_y - qd_drive


class ForceTerm:
    """A generalised-force contribution: `expressions(kin)` -> list of (v_index, expression)."""

    name = "term"

    def expressions(self, kin: Kin) -> list:
        raise NotImplementedError


@dataclass
class JointFriction(ForceTerm):
    """A friction law (roboball.physics.friction) on one joint's velocity."""

    joint: str
    law: str
    params: dict

    @property
    def name(self):
        return f"friction[{self.joint}:{self.law}]"

    def expressions(self, kin):
        if self.law == "none" or self.joint not in kin.layout.joint_v:
            return []
        iv = kin.layout.joint_v[self.joint]
        return [(iv, friction_laws.torque(self.law, kin.v[iv], self.params, m=kin.m))]


@dataclass
class InjectedShell(ForceTerm):
    """Eq. 9 on the rolling coordinates: K and C in the steer direction, C only in the drive
    direction (section IV).  `steer=False` or `drive=False` drops a direction."""

    k_inject: float
    c_inject: float
    steer: bool = True
    drive: bool = True
    name: str = "injected_shell"

    def expressions(self, kin):
        if kin.layout.base_v is None:
            return []
        out = []
        i = kin.layout.base_v
        if self.steer:
            tau = shell_laws.injected_torque(kin.pipe_angle(), kin.pipe_rate(), self.k_inject, self.c_inject)
            out.append((i, tau))
        if self.drive:
            t_drive = shell_laws.injected_torque(0.0, kin.drive_rate(), 0.0, self.c_inject)
            R = kin.base_rotation()
            # A couple T about the pipe's +y axis: generalised force R[:,1] T on the base's
            # world-frame angular velocity and -T on the drive joint (axis -y).
            for k in range(3):
                out.append((i + k, R[k][1] * t_drive))
            if "drive" in kin.layout.joint_v:
                out.append((kin.layout.joint_v["drive"], -t_drive))
        return out


@dataclass
class GeneralizedTerm(ForceTerm):
    """Any law given as fn(kin) -> list of (v_index, expression); used by diagnosis effects."""

    fn: Callable
    name: str = "generalized"

    def expressions(self, kin):
        return list(self.fn(kin))


def build_force_system(layout: StateLayout, terms: list) -> SymbolicVectorSystem | None:
    """Sum all terms into one SymbolicVectorSystem: input = plant state [q; v], output = tau."""
    terms = [t for t in terms if t is not None]
    if not terms:
        return None
    q = np.array([sym.Variable(f"q{i}") for i in range(layout.nq)], dtype=object)
    v = np.array([sym.Variable(f"v{i}") for i in range(layout.nv)], dtype=object)
    kin = Kin(layout, q, v, SYM)
    tau = [sym.Expression(0.0) for _ in range(layout.nv)]
    any_term = False
    for term in terms:
        for idx, expr in term.expressions(kin):
            tau[idx] = tau[idx] + expr
            any_term = True
    if not any_term:
        return None
    system = SymbolicVectorSystem(state=[], input=np.concatenate([q, v]), output=np.array(tau, dtype=object))
    system.set_name("+".join(t.name for t in terms))
    return system
