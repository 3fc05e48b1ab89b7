"""The test bed's own physics (truth).  Written independently of the fitted models' laws."""
from __future__ import annotations

import copy
import numpy as np
import pydrake.symbolic as sym
from pydrake.systems.primitives import SymbolicVectorSystem

from roboball.config import RobotFacts, load_robot
from roboball.sim.forces import SYM
from roboball.testbed import membrane


def load_truth(path=None) -> dict:
    import yaml

    from roboball.testbed import TRUTH_YAML
    with open(path or TRUTH_YAML, encoding="utf-8") as fh:
        return yaml.safe_load(fh)


def true_robot(truth: dict, perturbed: bool = True) -> RobotFacts:
    """The robot as built: the URDF facts with the truth's mass properties."""
    nominal = load_robot()
    if not perturbed:
        return nominal
    data = copy.deepcopy(nominal.data)
    for link, props in truth["mass_properties"].items():
        data["links"][link].update(props)
    return RobotFacts(data, source="testbed truth")


def with_com_moved(robot: RobotFacts, link: str, dy_m: float) -> RobotFacts:
    """The robot facts with `link`'s centre of mass moved by dy_m (m) along the link's y axis:
    for the pipe assembly, a sideways imbalance in the steer direction."""
    data = copy.deepcopy(robot.data)
    com = data["links"][link]["com_m"]
    data["links"][link]["com_m"] = [com[0], com[1] + dy_m, com[2]]
    return RobotFacts(data, source=f"{robot.source}, {link}'s centre of mass moved {dy_m} m sideways")


def stribeck_g(v, F_c, F_s, v_s, m=SYM):
    return F_c + (F_s - F_c) * m.exp(-(v / v_s) * (v / v_s))


def lugre_system(joint_params: dict):
    """Factory for a discrete LuGre friction system on the named joints.

    Bristle state z per joint, updated semi-implicitly (unconditionally stable):
        z+ = (z + dt v) / (1 + dt sigma0 |v| / g(v)),
    torque = -(sigma0 z + sigma1 zdot + viscous v), zdot = v - sigma0 |v| z / g(v).
    At rest the bristles hold the joint (true stiction up to F_s); sliding gives g(v) sign(v).
    """
    def make(layout, dt):
        joints = [j for j in joint_params if j in layout.joint_v]
        q = np.array([sym.Variable(f"q{i}") for i in range(layout.nq)], dtype=object)
        v = np.array([sym.Variable(f"v{i}") for i in range(layout.nv)], dtype=object)
        z = np.array([sym.Variable(f"z_{j}") for j in joints], dtype=object)
        tau = [sym.Expression(0.0) for _ in range(layout.nv)]
        z_next = []
        for k, j in enumerate(joints):
            p = joint_params[j]
            vj = v[layout.joint_v[j]]
            g = stribeck_g(vj, p["F_c"], p["F_s"], p["v_s"])
            zdot = vj - p["sigma0"] * sym.abs(vj) * z[k] / g
            tau[layout.joint_v[j]] = -(p["sigma0"] * z[k] + p["sigma1"] * zdot + p["viscous"] * vj)
            z_next.append((z[k] + dt * vj) / (1.0 + dt * p["sigma0"] * sym.abs(vj) / g))
        if not joints:
            z = np.array([sym.Variable("z_unused")], dtype=object)
            z_next = [z[0]]
        system = SymbolicVectorSystem(state=z, input=np.concatenate([q, v]), dynamics=np.array(z_next, dtype=object),
                                      output=np.array(tau, dtype=object), time_period=dt)
        system.set_name("testbed_lugre")
        return system
    return make


def shell_truth_systems(truth: dict, p_kpa: float, robot: RobotFacts, roll_from_flat: float = 0.0) -> list:
    """The real (virtual) shell at pressure p, on top of hydroelastic contact: the membrane and
    bedliner law of roboball.testbed.membrane, as a discrete system at the test bed's step.
    `roll_from_flat` (rad): how far a hand has rolled the shell from the flat it rested on."""
    if p_kpa is None:
        return []
    bedliner = truth["shell"]["bedliner"]
    pt = membrane.patch(robot.weight_n, robot.radius, p_kpa, bedliner["set_tension_n_m"])
    return [membrane.shell_system(pt, bedliner, roll_from_flat)]
