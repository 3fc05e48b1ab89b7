"""Run one experiment on the virtual robot (dense, noiseless; sensors are applied later)."""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from roboball.physics import shell as shell_laws
from roboball.sim.coupled import predict
from roboball.sim.scenarios import simulate
from roboball.sim.spec import ShellParams, SimSpec
from roboball.testbed.physics import load_truth, lugre_system, shell_truth_systems, true_robot

ALL_EXTRAS = frozenset({"friction", "shell", "mass", "hydro"})


def truth_spec(kind: str, p_kpa: float | None, truth: dict, extras=ALL_EXTRAS,
               ramp_length_m: float | None = None, extra_terms=(), extra_systems=(),
               base_friction: dict | None = None, robot=None, release: float | None = None) -> SimSpec:
    """The test bed's simulation spec.  `extras` switches the hidden physics on or off:
    friction (LuGre/Stribeck instead of Table I Majd), shell (shell torques), mass (mass
    properties differ from the URDF), hydro (fine-mesh hydroelastic instead of point contact).

    Blind diagnosis cases (benchmarks/diagnose_blind.py) use two more options, both off by
    default: `base_friction` ({joint: (law, params)}) replaces the joints' friction laws without
    "friction" in `extras` (e.g. viscous with a drawn coefficient), and `robot` replaces the
    robot facts (e.g. a centre of mass moved by roboball.testbed.effects).  `release`: the
    held value of the experiment's coordinate; a shell held away from its rest has rolled off the
    flat it rested on (roboball.testbed.membrane)."""
    extras = frozenset(extras)
    sim = truth["simulation"]
    if robot is None:
        robot = true_robot(truth, perturbed="mass" in extras)
    stand = kind in ("steer_stand", "drive_stand")
    dt = sim["dt_stand_s"] if stand else sim["dt_shell_s"]
    systems = list(extra_systems)
    friction = {"steer": "none", "drive": "none"}
    friction_params = {}
    if "friction" in extras:
        systems.append(lugre_system(truth["joint_friction"]))
    else:
        friction = {"steer": "majd", "drive": "majd"}
    for joint, (law, params) in (base_friction or {}).items():
        friction[joint] = law
        friction_params[joint] = dict(params)
    contact = "point"
    shell = ShellParams()
    if not stand and "hydro" in extras and p_kpa is not None:
        contact = "hydroelastic"
        sh = truth["shell"]
        shell = ShellParams(hydro_modulus=sh["modulus_scale"] * shell_laws.hydro_modulus(
            p_kpa * 1e3, robot.weight_n, robot.radius), hydro_dissipation=sh["hunt_crossley_s_m"])
    terms = list(extra_terms)
    if not stand and "shell" in extras:
        off_flat = release - robot.shell_rest_angle if kind == "shell_rock" and release is not None else 0.0
        systems += shell_truth_systems(truth, p_kpa, robot, off_flat)
    # the steer motor's rotor behind its gear (0 in the test bed's own robot): reflected inertia on the joint
    rotor = float(truth.get("twin", {}).get("steer_rotor_inertia_kg_m2", 0.0))
    added = {"steer": rotor} if rotor else {}
    return SimSpec(kind=kind, contact=contact, friction=friction, friction_params=friction_params,
                   added_inertia=added, pressure_kpa=p_kpa, shell=shell, dt=dt, extra_terms=terms, extra_systems=systems, robot=robot,
                   resolution_hint=sim["hydro_resolution_hint_m"], ramp_length_m=ramp_length_m,
                   sampled_output_ports=True,   # Drake's default: the campaign as it was recorded
                   approximation="lagged")


def run_free(kind: str, release: float, duration: float, p_kpa=None, truth=None, extras=ALL_EXTRAS,
             ramp_length_m=None, extra_terms=(), extra_systems=(), base_friction=None, robot=None):
    """Free response from rest at `release`; returns (df at 1 kHz, states, spec)."""
    truth = truth or load_truth()
    spec = truth_spec(kind, p_kpa, truth, extras, ramp_length_m, extra_terms, extra_systems,
                      base_friction=base_friction, robot=robot, release=release)
    df, x = simulate(spec, release, duration, sample_rate_hz=truth["simulation"]["sample_rate_hz"],
                     return_states=True)
    return df, x, spec


def coupled_release(p_kpa: float, t, pipe0: float, steer0: float, rates0: dict | None = None, truth=None,
                    robot=None, extra_terms=()) -> dict:
    """The coupled steer experiment on the virtual robot: the shell_rock setting with the clamp
    off (the pendulum free on its steer joint), released at `pipe0`, `steer0` (rad) with `rates0`
    ({"pipe_rate", "steer_rate"} rad/s; None: at rest) and its flat set at its rest.  Both
    coordinates at the times `t` (s, from the let-go at t[0]); the real logs of this experiment
    are the authors' coupled repeats (benchmarks/testbed_vs_real.py)."""
    truth = truth or load_truth()
    spec = truth_spec("shell_rock", p_kpa, truth, release=float(pipe0), extra_terms=extra_terms, robot=robot)
    spec = dataclasses.replace(spec, kind="steer_coupled")
    return predict(spec, t, float(pipe0), float(steer0), rates0=rates0)


def ramp_exit_time(df, x, spec) -> float | None:
    """First time the shell touches the floor at the bottom of the finite ramp."""
    if spec.ramp_length_m is None:
        return None
    from roboball.sim.plant import build  # layout of the same spec (cheap relative to the run)
    lay = build(spec).layout
    z = x[lay.base_q + 6]
    alpha = math.radians(spec.ramp_angle_deg if spec.ramp_angle_deg is not None else spec.robot.ramp_angle_deg)
    floor = -spec.ramp_length_m * math.sin(alpha)
    touching = np.nonzero(z - floor <= spec.robot.radius + 1e-3)[0]
    return float(df.time_s.values[touching[0]]) if len(touching) else None
