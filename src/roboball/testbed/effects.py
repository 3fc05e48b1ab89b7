"""The test bed's own implementations of the diagnosis vocabulary, used to conceal effects.

`roboball diagnose` must find physics the baseline leaves out in recordings it knows nothing
about.  The blind benchmark (benchmarks/diagnose_blind.py) hides effects in test-bed
recordings with THIS module, written independently of the diagnosis's effect library
(roboball.physics.effects), with different mechanisms where the physics allows:

* dry friction (coulomb_friction, stiction, and rolling_resistance in the roll direction) is
  a LuGre bristle model with a discrete internal state (true sticking, presliding
  compliance), not a memoryless regularised sign;
* com_offset moves the centre of mass in the robot description itself (a real geometric
  change that Drake's multibody plant sees: gravity torque, inertia and rest angle);
* added_inertia (stands) adds to the pendulum's own inertia about the joint axis in the robot
  description (the diagnosis's law is a geared rotor's reflected inertia: the same slower
  swing, another mechanism);
* backlash is a dead-zone spring built from Drake symbolic if-then-else branches;
* rolling_resistance on the ramp uses the algebraic smooth sign w / sqrt(w^2 + eps^2);
* viscous_damping, quadratic_drag, linear_stiffness and cubic_stiffness are torque laws
  written here on the test bed's own kinematic signals.

`conceal(kind, effects, robot)` returns what `roboball.testbed.run.truth_spec` takes: extra
force terms, extra stateful systems, and the (possibly modified) robot facts.  Effect
parameters use the vocabulary's names and SI units, so the benchmark can compare what the
diagnosis reports with what was hidden.  The rest angle about which stiffness and backlash act
is the test bed robot's own rest.
"""
from __future__ import annotations

import copy
import math

import numpy as np
import pydrake.symbolic as sym
from pydrake.systems.primitives import SymbolicVectorSystem

from roboball.config import RobotFacts
from roboball.sim.forces import GeneralizedTerm, Kin

JOINT = {"steer_stand": "steer", "drive_stand": "drive"}
SMOOTH_SIGN_EPS = 0.05         # rad/s, ramp rolling resistance
BRISTLE = {"steer_stand": (2.0e5, 60.0), "drive_stand": (2.0e5, 60.0), "shell_rock": (1.0e6, 400.0)}
G_FLOOR = 1e-3                 # N m: smallest friction level in the LuGre division


def _rotate_com(robot: RobotFacts, links, axis: str, angle: float) -> RobotFacts:
    """Robot facts with the centres of mass of `links` rotated by `angle` about `axis`."""
    data = copy.deepcopy(robot.data)
    for name in links:
        x, y, z = data["links"][name]["com_m"]
        c, s = math.cos(angle), math.sin(angle)
        if axis == "x":
            y, z = c * y - s * z, s * y + c * z
        else:   # about y
            z, x = c * z - s * x, s * z + c * x
        data["links"][name]["com_m"] = [float(x), float(y), float(z)]
    return RobotFacts(data, source=robot.source + " (centre of mass moved by the test bed)")


def _add_inertia(robot: RobotFacts, link: str, axis: int, delta_i: float) -> RobotFacts:
    """Robot facts with `delta_i` (kg m^2) added to `link`'s inertia about its own `axis` (0: x,
    1: y): the test bed's slower stand, a body heavier to swing than the URDF says."""
    data = copy.deepcopy(robot.data)
    inertia = list(data["links"][link]["inertia_kg_m2"])
    inertia[axis] = float(inertia[axis]) + float(delta_i)
    data["links"][link]["inertia_kg_m2"] = inertia
    return RobotFacts(data, source=robot.source + " (inertia added by the test bed)")


def rest_angle(kind: str, robot: RobotFacts) -> float:
    """The robot's rest value of the experiment coordinate (test bed's own computation)."""
    L = robot.links
    if kind == "steer_stand":
        p = L["pendulum"]
        return -math.atan2(p.com_m[1], -p.com_m[2])
    if kind == "drive_stand":
        m = L["pitch_center"].mass_kg + L["pendulum"].mass_kg
        x = (L["pitch_center"].mass_kg * L["pitch_center"].com_m[0] + L["pendulum"].mass_kg * L["pendulum"].com_m[0]) / m
        z = (L["pitch_center"].mass_kg * L["pitch_center"].com_m[2] + L["pendulum"].mass_kg * L["pendulum"].com_m[2]) / m
        return math.atan2(x, -z)
    if kind == "shell_rock":
        lateral = sum(L[n].mass_kg * L[n].com_m[1] for n in ("pitch_center", "pendulum"))
        depth = -sum(L[n].mass_kg * L[n].com_m[2] for n in ("pitch_center", "pendulum"))
        return -math.atan2(lateral, depth)
    return 0.0


def lugre(velocity_index, F_c: float, F_s: float, v_s: float, sigma0: float, sigma1: float, name: str):
    """Factory (layout, dt) -> discrete LuGre friction on the generalised velocity chosen by
    `velocity_index(layout)`: bristle state z, g(v) = F_c + (F_s - F_c) exp(-(v / v_s)^2),
    semi-implicit update z+ = (z + dt v) / (1 + dt sigma0 |v| / g), torque
    -(sigma0 z + sigma1 zdot)."""
    def make(layout, dt):
        q = np.array([sym.Variable(f"q{i}") for i in range(layout.nq)], dtype=object)
        v = np.array([sym.Variable(f"v{i}") for i in range(layout.nv)], dtype=object)
        z = sym.Variable(f"z_{name}")
        iv = velocity_index(layout)
        w = v[iv]
        g = sym.max(F_c + (F_s - F_c) * sym.exp(-(w / v_s) * (w / v_s)), G_FLOOR)
        zdot = w - sigma0 * sym.abs(w) * z / g
        tau = [sym.Expression(0.0) for _ in range(layout.nv)]
        tau[iv] = -(sigma0 * z + sigma1 * zdot)
        z_next = (z + dt * w) / (1.0 + dt * sigma0 * sym.abs(w) / g)
        system = SymbolicVectorSystem(state=[z], input=np.concatenate([q, v]), dynamics=[z_next],
                                      output=np.array(tau, dtype=object), time_period=dt)
        system.set_name(f"testbed_{name}")
        return system
    return make


def _coordinate(kind: str):
    """(angle(kin), rate(kin), apply(kin, torque)) of the experiment's coordinate."""
    if kind in JOINT:
        j = JOINT[kind]
        return (lambda kin: kin.q[kin.layout.joint_q[j]], lambda kin: kin.v[kin.layout.joint_v[j]],
                lambda kin, t: [(kin.layout.joint_v[j], t)])
    if kind == "shell_rock":
        return (lambda kin: kin.pipe_angle(), lambda kin: kin.v[kin.layout.base_v],
                lambda kin, t: [(kin.layout.base_v, t)])
    if kind == "ramp":
        def couple(kin, t):
            R = kin.base_rotation()
            out = [(kin.layout.base_v + i, R[i][1] * t) for i in range(3)]
            if "drive" in kin.layout.joint_v:
                out.append((kin.layout.joint_v["drive"], -t))
            return out
        return (lambda kin: 0.0, lambda kin: kin.drive_rate(), couple)
    raise ValueError(f"no concealment for kind '{kind}'")


def _velocity_index(kind: str):
    if kind in JOINT:
        return lambda layout: layout.joint_v[JOINT[kind]]
    return lambda layout: layout.base_v


def _described(kind: str, effects: dict, robot: RobotFacts) -> RobotFacts:
    """The robot facts with the effects that live in the robot description (com_offset,
    added_inertia) put there."""
    if "com_offset" in effects:
        delta = float(effects["com_offset"]["delta"])
        if kind == "steer_stand":
            robot = _rotate_com(robot, ["pendulum"], "x", -delta)
        elif kind == "drive_stand":
            robot = _rotate_com(robot, ["pitch_center", "pendulum"], "y", delta)
        elif kind == "shell_rock":
            robot = _rotate_com(robot, ["pitch_center", "pendulum"], "x", -delta)
        else:
            raise ValueError(f"com_offset is not concealed in {kind} runs")
    if "added_inertia" in effects:
        if kind not in JOINT:
            raise ValueError(f"added_inertia is not concealed in {kind} runs")
        robot = _add_inertia(robot, "pendulum", 0 if kind == "steer_stand" else 1,
                             effects["added_inertia"]["delta_i"])
    return robot


def conceal(kind: str, effects: dict, robot: RobotFacts):
    """Terms, systems and robot facts that hide `effects` ({name: {param: value}}) in a test-bed
    run of `kind`.  Returns (extra_terms, extra_systems, robot)."""
    effects = dict(effects)
    robot = _described(kind, effects, robot)
    rest = rest_angle(kind, robot)
    angle, rate, apply = _coordinate(kind)
    terms, systems = [], []

    if "coulomb_friction" in effects or "stiction" in effects or (kind == "shell_rock" and "rolling_resistance" in effects):
        if kind not in BRISTLE:
            raise ValueError(f"dry friction is not concealed in {kind} runs")
        if kind == "shell_rock":
            f_c = float(effects.get("rolling_resistance", {}).get("tau_rr", 0.0))
        else:
            f_c = float(effects.get("coulomb_friction", {}).get("tau_c", 0.0))
        st = effects.get("stiction", {})
        f_s = f_c + float(st.get("tau_s", 0.0))
        v_s = float(st.get("v_s", 0.02))
        s0, s1 = BRISTLE[kind]
        systems.append(lugre(_velocity_index(kind), f_c, f_s, v_s, s0, s1, name=f"dry_{kind}"))

    def law(kin: Kin):
        q = angle(kin)
        w = rate(kin)
        x = q - rest
        tau = sym.Expression(0.0)
        for name, p in effects.items():
            if name == "viscous_damping":
                tau = tau - p["c"] * w
            elif name == "quadratic_drag":
                tau = tau - p["c2"] * w * sym.abs(w)
            elif name == "linear_stiffness":
                tau = tau - p["k"] * x
            elif name == "cubic_stiffness":
                tau = tau - p["k3"] * x * x * x
            elif name == "backlash":
                b, k_b = p["b"], p["k_b"]
                tau = tau + sym.if_then_else(x > b, -k_b * (x - b), sym.if_then_else(x < -b, -k_b * (x + b), 0.0))
            elif name == "rolling_resistance" and kind == "ramp":
                tau = tau - p["tau_rr"] * w / sym.sqrt(w * w + SMOOTH_SIGN_EPS ** 2)
        return apply(kin, tau)

    torque_effects = {"viscous_damping", "quadratic_drag", "linear_stiffness", "cubic_stiffness", "backlash"}
    if torque_effects & set(effects) or (kind == "ramp" and "rolling_resistance" in effects):
        terms.append(GeneralizedTerm(law, name=f"testbed_effects_{kind}"))
    return terms, systems, robot
