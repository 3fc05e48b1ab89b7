"""The test bed's own physics (truth).  Written independently of the fitted models' laws."""
from __future__ import annotations

import copy
import numpy as np
import pydrake.symbolic as sym
from pydrake.systems.primitives import SymbolicVectorSystem

from roboball.config import RobotFacts, load_robot
from roboball.sim.forces import SYM
from roboball.testbed import membrane


def load_truth(path=None, real: bool = False) -> dict:
    """The test bed's truth.  `real`: the calibrated twin of the real robot, i.e. the file's
    `real_robot:` section merged over the rest; without it, the test bed's own robot (the one
    before the calibration, which the blind benchmark and the tests draw their cases from)."""
    import yaml

    from roboball.testbed import TRUTH_YAML
    with open(path or TRUTH_YAML, encoding="utf-8") as fh:
        truth = yaml.safe_load(fh)
    overrides = truth.pop("real_robot", None)
    if real:
        if not overrides:
            raise ValueError(f"{path or TRUTH_YAML}: no real_robot section (the calibrated twin)")
        truth = merged(truth, overrides)
    return truth


def campaign_truth(path=None) -> dict:
    """The truth raw_data/ is generated with: the calibrated twin when the file's
    `campaign: robot:` says `real_robot`, else the test bed's own robot."""
    truth = load_truth(path)
    robot = truth["campaign"].get("robot", "base")
    if robot not in ("base", "real_robot"):
        raise ValueError(f"{path or 'truth.yaml'}: field campaign.robot: {robot!r}; give base or real_robot")
    return load_truth(path, real=True) if robot == "real_robot" else truth


def merged(base: dict, overrides: dict) -> dict:
    """`base` with `overrides` put in, nested dicts merged key by key (a copy)."""
    out = copy.deepcopy(base)
    for key, value in overrides.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = merged(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def true_robot(truth: dict, perturbed: bool = True) -> RobotFacts:
    """The robot as built: the URDF facts with the truth's mass properties."""
    nominal = load_robot()
    if not perturbed:
        return nominal
    data = copy.deepcopy(nominal.data)
    for link, props in truth["mass_properties"].items():
        data["links"][link].update(props)
    robot = RobotFacts(data, source="testbed truth")
    dy = float(truth.get("twin", {}).get("pipe_com_y_m", 0.0))
    # the real robot's sideways imbalance (0 in the test bed's own robot): docs/testbed.md
    return with_com_moved(robot, "pipe_assembly", dy) if dy else robot


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
    shell = truth["shell"]
    bedliner = shell["bedliner"]
    pt = membrane.patch(robot.weight_n, robot.radius, p_kpa, bedliner["set_tension_n_m"],
                        set_at_kpa=shell.get("set_at_kpa"))
    return [membrane.shell_system(pt, bedliner, roll_from_flat, float(shell.get("profile_excess_m", 0.0)))]
