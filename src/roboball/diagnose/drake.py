"""The augmented model in Drake: the chosen effects as a force element of the plant.

`effect_term` turns a set of effects with their parameter values into a
`roboball.sim.forces.GeneralizedTerm`: the SAME law functions of roboball.physics.effects that
the reduced models integrate with NumPy are evaluated here on Drake symbolic variables
(math namespace `SYM`), and `roboball.sim.plant.build` wires the resulting
SymbolicVectorSystem into the plant's applied-generalised-force port, so Drake evaluates the
effects in C++ at every step (no Python in the time loop).

Where each experiment's coordinate lives in the plant:
* stands: the steer (or drive) joint angle and rate, measured from the model's rest angle;
* shell_rock: the floating base's roll (pipe_angle, from the quaternion) and its world-x
  angular velocity (Kin.pipe_rate), torque on that velocity; with the steer joint free
  (roboball.reduced.shell_steer) the plant is the coupled scenario's, released with the steer
  joint's fitted state;
* ramp: the drive rate (Kin.drive_rate); the torque is a couple on the pipe assembly about its
  driveshaft axis (R[:,1] T on the base's angular velocity, -T on the drive joint), the same
  construction as the injected shell's drive damping.

An inertia effect (`added_inertia`) is no force: on a stand it is the joint actuator's rotor
inertia (`SimSpec.added_inertia`: a JointActuator with the facts' gear ratio N and rotor
inertia delta_i / N^2, which Drake adds to the joint's diagonal of the mass matrix as J N^2).
The shell's roll and the ramp's drive rate are no joint with a motor (the roll is the floating
base's), and the diagnosis offers no inertia effect there.

`simulate_windows` releases the Drake model from every fitted release state of a recording and
returns its prediction at the recording's own samples.
"""
from __future__ import annotations

import math

import numpy as np

from roboball.physics import effects as fx
from roboball.sim.forces import SYM, GeneralizedTerm, Kin
from roboball.sim.plant import build
from roboball.sim.scenarios import simulate
from roboball.sim.spec import ShellParams, SimSpec
from roboball.diagnose.data import Prepared
from roboball.diagnose.sensor import sensed
from roboball.reduced.base import ReducedModel

DRAKE_DT = {"steer_stand": 5e-4, "drive_stand": 5e-4, "shell_rock": 1e-3, "ramp": 1e-3}


def effect_values(effects, values: dict) -> dict:
    """{effect: {param: value}} from a flat parameter dict ('effect.param' keys)."""
    return {e: {p: float(values[f"{e}.{p}"]) for p in fx.LIBRARY[e].param_names} for e in effects}


def effect_term(model: ReducedModel, effects: dict) -> GeneralizedTerm | None:
    """A Drake force term applying `effects` ({name: params}) on the experiment's coordinate
    (None when none of them is a force: inertia effects are the plant's, see `drake_spec`)."""
    effects = {name: p for name, p in effects.items() if fx.LIBRARY[name].kind != "inertia"}
    if not effects:
        return None
    kind, rest, context = model.kind, model.rest, dict(model.context)

    def law(kin: Kin):
        lay = kin.layout
        if kind in ("steer_stand", "drive_stand"):
            joint = "steer" if kind == "steer_stand" else "drive"
            q = kin.q[lay.joint_q[joint]] - rest
            qd = kin.v[lay.joint_v[joint]]
            return [(lay.joint_v[joint], fx.total_torque(effects, q, qd, context, m=SYM))]
        if kind == "shell_rock":
            q = kin.pipe_angle() - rest
            qd = kin.pipe_rate()
            return [(lay.base_v, fx.total_torque(effects, q, qd, context, m=SYM))]
        if kind == "ramp":
            w = kin.drive_rate()
            t = fx.total_torque(effects, 0.0 * w, w, context, m=SYM)
            R = kin.base_rotation()
            out = [(lay.base_v + i, R[i][1] * t) for i in range(3)]
            if "drive" in lay.joint_v:
                out.append((lay.joint_v["drive"], -t))
            return out
        raise ValueError(f"no Drake effect term for kind '{kind}'")

    return GeneralizedTerm(law, name="diagnosed[" + "+".join(effects) + "]")


def drake_spec(prep: Prepared, model: ReducedModel, values: dict, effects, dt: float | None = None,
               ramp_angle_deg: float | None = None) -> SimSpec:
    """The Drake scenario of the baseline (effects=()) or the augmented model (a ramp run's on
    `ramp_angle_deg`, default the recording's)."""
    kind = prep.kind
    dt = dt or DRAKE_DT[kind]
    chosen = effect_values(effects, values)
    term = effect_term(model, chosen)
    extra = [term] if term is not None else []
    added = float(fx.total_inertia(chosen))
    if kind in ("steer_stand", "drive_stand"):
        joint = "steer" if kind == "steer_stand" else "drive"
        return SimSpec(kind=kind, contact="point", friction={joint: "viscous"},
                       friction_params={joint: {"c": float(values["viscous_c"])}}, dt=dt, extra_terms=extra,
                       added_inertia={joint: added} if added else {})
    if added:
        raise ValueError(f"no added inertia on the {kind} coordinate in Drake (no joint actuator there)")
    if kind == "shell_rock" and model.steer_joint == "free":
        # the pendulum free on its steer joint: Drake's coupled scenario (point contact, the
        # reduced model's Majd steer friction, drive held) with the effects on the roll
        from roboball.sim.coupled import coupled_spec
        spec = coupled_spec("point", ShellParams(), model.steer_friction, extra_terms=extra, dt=dt)
        spec.pressure_kpa = prep.recording.pressure_kpa
        return spec
    if kind == "shell_rock":
        return SimSpec(kind=kind, contact="point", friction={"steer": "none", "drive": "none"}, dt=dt,
                       pressure_kpa=prep.recording.pressure_kpa, extra_terms=extra)
    angle = prep.recording.ramp_angle_deg if ramp_angle_deg is None else ramp_angle_deg
    return ramp_spec(prep.recording.pressure_kpa, angle, extra, dt,
                     friction_params=getattr(model, "friction_params", None))


def ramp_spec(pressure_kpa, ramp_angle_deg, extra_terms=(), dt: float | None = None,
              friction_params: dict | None = None) -> SimSpec:
    """The ramp baseline of the contract (point contact, Majd friction on both joints: Table I,
    or `friction_params` per joint where given) with `extra_terms` (the diagnosed effects) added."""
    return SimSpec(kind="ramp", contact="point", friction={"steer": "majd", "drive": "majd"},
                   friction_params={j: dict(p) for j, p in (friction_params or {}).items() if p},
                   dt=dt or DRAKE_DT["ramp"], pressure_kpa=pressure_kpa, ramp_angle_deg=ramp_angle_deg,
                   extra_terms=list(extra_terms))


def _level_before(prep: Prepared, window, column: str, t0: float) -> float:
    """Median of `column` over the 0.25 s before t0 in the recording `window` was cut from."""
    rec = prep.source_of(window)
    if not rec.has_signal(column):
        return 0.0
    t, y = rec.time, rec.signal(column)
    m = (t >= t0 - 0.25) & (t <= t0)
    return float(np.median(y[m])) if m.any() else float(np.interp(t0, t, y))


def simulate_windows(prep: Prepared, model: ReducedModel, values: dict, effects, dt: float | None = None,
                     notes: list | None = None) -> dict:
    """Drake prediction at every window's samples, from the fitted release states (a pooled
    ramp run on its own ramp: one diagram per angle).  What the runs had to change (a release
    past a joint's stop) is noted in `notes`, by default the recording's own (`prep.notes`);
    runs made side by side in threads each take a list of their own."""
    notes = prep.notes if notes is None else notes
    rate = 1000.0
    diagrams = {}
    out = {}
    for w in prep.windows:
        angle = prep.source_of(w).ramp_angle_deg if prep.kind == "ramp" else None
        if angle not in diagrams:
            spec = drake_spec(prep, model, values, effects, dt, ramp_angle_deg=angle)
            diagrams[angle] = (spec, build(spec, sample_period=1.0 / rate))
        spec, built = diagrams[angle]
        ts = float(values.get(f"ts@{w.index}", 0.0))
        duration = float(w.t[-1] - w.t0 - ts) + 0.05
        if prep.kind == "ramp":
            release = _level_before(prep, w, "pipe_angle_rad", w.t0 + ts)
            steer0 = _level_before(prep, w, "steer_angle_rad", w.t0 + ts)
        else:
            release = float(values.get(f"q0@{w.index}", w.q0))
            steer0 = 0.0
            if prep.kind == "steer_stand":
                # the reduced model has no joint stop; Drake refuses a release past it (the real
                # log's third swing starts at 1.044 rad, beyond the robot facts' 1.0 rad stop)
                joint = built.plant.GetJointByName("steer")
                lo, hi = float(joint.position_lower_limits()[0]), float(joint.position_upper_limits()[0])
                if not lo <= release <= hi:
                    note = (f"release {w.index + 1}: start angle {release:.4g} rad lies past the steer joint's "
                            f"limits [{lo:g}, {hi:g}] rad of the robot facts; the Drake runs start at the limit")
                    if note not in notes:
                        notes.append(note)
                    release = min(max(release, lo), hi)
        rates0 = None
        if model.hidden_release:       # the unobserved steer joint's fitted release state
            steer0 = float(values.get(f"steer_angle@{w.index}", 0.0))
            rates0 = {"pipe_rate": 0.0, "steer_rate": float(values.get(f"steer_rate@{w.index}", 0.0))}
        df = simulate(spec, release, max(duration, 0.1), sample_rate_hz=rate, steer0=steer0, built=built,
                      rates0=rates0)
        tau = w.t - w.t0 - ts
        y = df[prep.signal].to_numpy()
        out[w.index] = w.observe(sensed(w, tau, df.time_s.to_numpy(), y, values))
    return out


def rmse(prep: Prepared, pred: dict, masks: dict | None = None) -> float:
    sq, n = 0.0, 0
    for w in prep.windows:
        r = pred[w.index] - w.y
        if masks is not None:
            r = r[masks[w.index]]
        sq += float(np.sum(r * r))
        n += len(r)
    return math.sqrt(sq / max(n, 1))
