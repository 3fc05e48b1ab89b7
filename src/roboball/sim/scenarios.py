"""Scenario runs: set the released initial state, simulate, and return a recording.

Scenarios (specs: `roboball.sim.spec.SimSpec`; all built by `roboball.sim.plant.build`):

* `steer_stand`: stand holds the pitch centre and the pipe (outer rolling locked); the pendulum
  swings about the steer joint.  Main coordinate theta = steer_angle.
* `drive_stand`: stand holds the pipe; pitch centre + pendulum (steer locked) swing about the
  drive joint.  Main coordinate: drive_angle.
* `shell_rock`: steering (and drive) locked by the clamp; the robot rolls on flat ground in the
  steer plane.  Main coordinate phi = pipe_angle, the floating base's roll.
* `ramp`: 16 deg incline descending towards +x, pendulum free on both joints, released from rest
  at the given initial pipe angle.  Main signal: drive_rate.
* `free`: the full robot on flat ground, both joints free.
"""
from __future__ import annotations

import math
import os
import threading
import time

import numpy as np
import pandas as pd
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.systems.analysis import Simulator

from roboball.errors import SimulationError
from roboball.kinds import SIM_SIGNALS, STANDS
from roboball.sim.forces import Kin
from roboball.sim.plant import Built, build
from roboball.sim.spec import SimSpec

# A shell whose centre sinks below half its radius has gone through the ground: the run stops
# there, and no start is pressed in deeper.
MAX_SINK_FRACTION = 0.5
# The settling's first search bracket (m): every shell but the calibrated hydroelastic ones rests
# within it.
FIRST_BRACKET_M = 0.05


def set_release(built: Built, context, release: float, steer0: float = 0.0, settled: dict | None = None) -> None:
    """Put the plant at rest at the experiment's release state.  `settled`: see :func:`simulate`."""
    plant = built.plant
    pctx = plant.GetMyMutableContextFromRoot(context)
    kind = built.spec.kind
    if kind == "steer_stand":
        joint = plant.GetJointByName("steer")
        lo, hi = float(joint.position_lower_limits()[0]), float(joint.position_upper_limits()[0])
        if not lo <= release <= hi:
            # Drake's limit stop would throw the pendulum across its range in a few ms.
            raise SimulationError(f"steer_stand: release angle {release:.4g} rad is outside the steer joint's "
                                  f"limits [{lo:g}, {hi:g}] rad (configs/robot.yaml)")
        joint.set_angle(pctx, release)
    elif kind == "drive_stand":
        plant.GetJointByName("drive").set_angle(pctx, release)
    else:
        r = built.robot.radius
        normal = built.ground_normal
        R = RotationMatrix(RollPitchYaw(release, 0.0, 0.0))
        heading = built.spec.heading_deg
        if heading:   # the whole scene turned about world z: the robot's release pose with it
            R = RotationMatrix.MakeZRotation(math.radians(heading)).multiply(R)
        X = RigidTransform(R, r * normal)
        plant.SetFreeBodyPose(pctx, plant.GetBodyByName("pitch_center"), X)
        if plant.HasJointNamed("steer") and built.layout.joint_q.get("steer") is not None:
            plant.GetJointByName("steer").set_angle(pctx, steer0)
    plant.SetVelocities(pctx, np.zeros(plant.num_velocities()))
    if kind not in STANDS:
        if settled is None:
            settle_on_ground(built, context)
            return
        key = _settle_key(built.spec, release, steer0)
        if key in settled:
            if settled[key]:    # 0: a contact that did not hold the weight, the start left as it was
                _shift_along_normal(built, context, settled[key])
        else:
            settled[key] = settle_on_ground(built, context)


def _settle_key(spec: SimSpec, release: float, steer0: float) -> str:
    """What the settled penetration depends on: the whole scenario but its joint friction.  Every
    friction law is a function of the joint rate that vanishes at rest (roboball.physics.friction),
    and the settling step starts from rest, so runs that differ only in friction settle alike."""
    fields = {k: v for k, v in vars(spec).items() if k not in ("friction", "friction_params")}
    return repr((sorted(fields.items()), float(release), float(steer0)))


def set_release_rates(built: Built, context, pipe_rate: float = 0.0, steer_rate: float = 0.0) -> None:
    """Give a robot on flat ground, already at its release pose, a roll rate `pipe_rate` (rad/s,
    about world x, rolling without slip: its centre moves at -pipe_rate R along world y) and a
    steer joint rate `steer_rate` (rad/s): a log that starts a few samples after the let-go."""
    plant = built.plant
    pctx = plant.GetMyMutableContextFromRoot(context)
    body = plant.GetBodyByName("pitch_center")
    from pydrake.multibody.math import SpatialVelocity
    height = float(plant.GetFreeBodyPose(pctx, body).translation() @ built.ground_normal)
    plant.SetFreeBodySpatialVelocity(pctx, body, SpatialVelocity([pipe_rate, 0.0, 0.0], [0.0, -pipe_rate * height, 0.0]))
    if steer_rate:
        plant.GetJointByName("steer").set_angular_rate(pctx, steer_rate)


def _shift_along_normal(built: Built, context, sink: float) -> None:
    plant = built.plant
    pctx = plant.GetMyMutableContextFromRoot(context)
    body = plant.GetBodyByName("pitch_center")
    X = plant.GetFreeBodyPose(pctx, body)
    plant.SetFreeBodyPose(pctx, body, RigidTransform(X.rotation(), X.translation() - sink * built.ground_normal))


def settle_on_ground(built: Built, context, max_sink_m: float | None = None, tol_m: float = 1e-6) -> float:
    """Press the resting shell into the ground by the penetration at which its contact holds its
    weight, and return that penetration (m).

    A robot held still on the ground rests in its contact: a compliant (hydroelastic) shell is
    pressed in by 6-17 mm at eq. 10's moduli and by up to 140 mm at the calibrated ones (1e4 Pa),
    rigid point contact by its penetration allowance (under 1 mm).  Started touching but not
    pressed in, the shell would first fall into the ground for 25-45 ms after the release and
    bounce at the contact's natural frequency: a start transient no held robot has.  The
    penetration is the root (Brent's method, to `tol_m`) of the shell centre's speed along the
    ground normal after one time step from rest, computed in a scratch context; a contact that
    does not hold the weight within `max_sink_m` (default: the depth at which a run stops as
    sunk, MAX_SINK_FRACTION of the radius) leaves the start as it was.

    The root is searched in [0, FIRST_BRACKET_M] first, then deeper: Brent's iterates depend on
    the bracket, so a shell that rests within the first one settles to the same bits whatever
    the cap (the campaign's recordings are checked bit for bit)."""
    from scipy.optimize import brentq

    if max_sink_m is None:
        max_sink_m = MAX_SINK_FRACTION * built.robot.radius
    scratch = built.diagram.CreateDefaultContext()
    sim = Simulator(built.diagram, scratch)
    plant = built.plant
    body = plant.GetBodyByName("pitch_center")
    spctx = plant.GetMyContextFromRoot(scratch)

    def normal_speed(sink: float) -> float:
        scratch.SetTimeStateAndParametersFrom(context)
        _shift_along_normal(built, scratch, sink)
        sim.Initialize()
        sim.AdvanceTo(scratch.get_time() + built.spec.dt)
        return float(plant.EvalBodySpatialVelocityInWorld(spctx, body).translational() @ built.ground_normal)

    if not normal_speed(0.0) < 0.0:
        return 0.0
    brackets = (FIRST_BRACKET_M, max_sink_m) if max_sink_m > FIRST_BRACKET_M else (max_sink_m,)
    top = 0.0
    for deeper in brackets:
        if normal_speed(deeper) > 0.0:
            sink = float(brentq(normal_speed, top, deeper, xtol=tol_m))
            _shift_along_normal(built, context, sink)
            return sink
        top = deeper
    return 0.0


def signals_from_states(built: Built, x: np.ndarray) -> dict:
    """Recording signals from logged plant states x (n_x by N), per roboball.sim.forces.Kin."""
    lay = built.layout
    q, v = x[:lay.nq], x[lay.nq:]
    out = {}
    kin = Kin(lay, q, v, None)
    if "steer" in lay.joint_q:
        out["steer_angle_rad"] = q[lay.joint_q["steer"]]
        out["steer_rate_rad_s"] = v[lay.joint_v["steer"]]
    if "drive" in lay.joint_q:
        out["drive_angle_rad"] = q[lay.joint_q["drive"]]
    if lay.base_q is not None:
        out["pipe_angle_rad"] = kin.pipe_angle()
        out["pipe_rate_rad_s"] = kin.pipe_rate()
        out["drive_rate_rad_s"] = kin.drive_rate()
    return out


def describe(spec: SimSpec, t: float | None = None) -> str:
    """The scenario and the parameters that define it, for one-line failure messages."""
    parts = [f"scenario {spec.kind}", f"contact {spec.contact}", f"friction {spec.friction}"]
    if spec.friction_params:
        parts.append(f"friction params {spec.friction_params}")
    if spec.added_inertia:
        parts.append(f"added inertia {spec.added_inertia} kg m^2")
    parts += [f"pressure {spec.pressure_kpa} kPa", f"dt {spec.dt} s"]
    sp = spec.shell
    for name in ("zeta", "omega_n", "hydro_modulus", "hydro_dissipation"):
        if getattr(sp, name) is not None:
            parts.append(f"{name} {getattr(sp, name):g}")
    for name in ("modulus_scale", "dissipation_scale"):
        if getattr(sp, name) != 1.0:
            parts.append(f"{name} {getattr(sp, name):g}")
    if sp.geometry != "planar":
        parts.append(f"shell geometry {sp.geometry}")
    if spec.heading_deg:
        parts.append(f"heading {spec.heading_deg:g} deg")
    if spec.pressure_schedule is not None:
        parts.append(spec.pressure_schedule.describe())
    if t is not None:
        parts.append(f"t = {t:.3f} s")
    return ", ".join(parts)


def _check_state(built: Built, x: np.ndarray, t: float) -> None:
    spec = built.spec
    where = describe(spec, t)
    if not np.all(np.isfinite(x)):
        raise SimulationError(f"simulation produced NaN/inf ({where})")
    lay = built.layout
    v = x[lay.nq:]
    if np.max(np.abs(v)) > 1e3:
        raise SimulationError(f"simulation blew up: |velocity| {np.max(np.abs(v)):.3g} > 1e3 ({where})")
    if lay.base_q is not None:
        p = x[lay.base_q + 4: lay.base_q + 7]
        height = float(np.dot(p, built.ground_normal))
        if height < (1.0 - MAX_SINK_FRACTION) * built.robot.radius:
            raise SimulationError(f"shell penetrated the ground by {built.robot.radius - height:.3f} m ({where})")


def _max_wall_s(max_wall_s: float | None) -> float | None:
    """The wall-clock budget of one simulate call: the argument, else $ROBOBALL_SIM_MAX_WALL_S."""
    if max_wall_s is not None:
        return float(max_wall_s)
    env = os.environ.get("ROBOBALL_SIM_MAX_WALL_S", "").strip()
    if not env:
        return None
    try:
        value = float(env)
    except ValueError:
        raise SimulationError(f"ROBOBALL_SIM_MAX_WALL_S={env!r}: not a number of seconds")
    return value if value > 0 else None


# Drake logs some warnings once per process from inside a C++ function-local static (a rigid
# half-space "not currently supported for deformable contact", when a context is first made),
# through pydrake's sink into Python's logging, which may hand the GIL to another thread.  Two
# threads making their first contexts at once then deadlock: one holds the static's guard and
# waits for the GIL, the other holds the GIL and waits for the guard.  Runs in threads (the
# diagnosis's side-by-side Drake runs) make their contexts (and any diagram built here) under
# this lock and step in parallel (AdvanceTo releases the GIL).
DRAKE_SETUP = threading.RLock()


def simulate(spec: SimSpec, release: float, duration: float, sample_rate_hz: float = 100.0,
             steer0: float = 0.0, chunk_s: float = 0.5, built: Built | None = None,
             return_states: bool = False, max_wall_s: float | None = None, before_chunk=None,
             rates0: dict | None = None, settled: dict | None = None):
    """Run `spec` from rest at `release` for `duration` s; return a recording DataFrame.

    The state is checked between chunks of `chunk_s` for NaN, blow-up and deep penetration; a
    failure raises SimulationError naming the scenario and parameters.  A stuck run (a contact
    solver crawling through a near-singular state) is caught by a wall-clock budget:
    `max_wall_s` (or the environment variable ROBOBALL_SIM_MAX_WALL_S; default none), checked
    between chunks.  With `return_states` the logged plant states (n_x by N) come back too:
    (df, states).  `before_chunk(built, context, t0, t1)`, when given, runs before each chunk
    is simulated (e.g. to replace contact properties between segments: roboball.sim.schedule_run).
    `rates0` ({"pipe_rate": ..., "steer_rate": ...}, rad/s) starts a robot on the ground moving
    (`set_release_rates`) instead of at rest.  `settled`, a dict the caller keeps across runs,
    remembers each start's settled penetration (`settle_on_ground`, about 50 ms of Drake steps a
    start), so runs that differ only in joint friction (a ramp run's posterior draws) settle once.
    """
    budget = _max_wall_s(max_wall_s)
    with DRAKE_SETUP:
        if built is None:
            built = build(spec, sample_period=1.0 / sample_rate_hz)
        sim = Simulator(built.diagram)
        ctx = sim.get_mutable_context()
        set_release(built, ctx, release, steer0, settled)
        if rates0:
            set_release_rates(built, ctx, **rates0)
        sim.Initialize()
    pctx = built.plant.GetMyContextFromRoot(ctx)
    t = 0.0
    start = time.monotonic()
    try:
        while t < duration - 1e-12:
            t_next = min(duration, t + chunk_s)
            if duration - t_next < 1e-9:   # sums of short chunks must still end exactly at duration
                t_next = duration
            if before_chunk is not None:
                before_chunk(built, ctx, t, t_next)
            t = t_next
            sim.AdvanceTo(t)
            _check_state(built, built.plant.GetPositionsAndVelocities(pctx), t)
            wall = time.monotonic() - start
            if budget is not None and wall > budget and t < duration - 1e-12:
                raise SimulationError(
                    f"simulation stuck: {wall:.1f} s of wall time for {t:.3f} of {duration:g} s simulated, "
                    f"over the budget of {budget:g} s ({describe(spec, t)}); check the parameters or "
                    "raise ROBOBALL_SIM_MAX_WALL_S")
    except RuntimeError as exc:
        raise SimulationError(f"Drake failed ({describe(spec, ctx.get_time())}): "
                              f"{str(exc).splitlines()[0]}")
    log = built.logger.FindLog(ctx)
    times = log.sample_times()
    sig = signals_from_states(built, log.data())
    cols = {"time_s": times}
    for name in SIM_SIGNALS[spec.kind]:
        # A joint locked for this run stays at zero.
        cols[name] = np.asarray(sig.get(name, np.zeros_like(times)), dtype=float)
    df = pd.DataFrame(cols)
    return (df, log.data()) if return_states else df


def simulate_calibrated_stand(spec: SimSpec, release: float, duration: float, rest_offset: float = 0.0,
                              **kw) -> pd.DataFrame:
    """A stand run as the friction fits' calibrated stand has it (roboball.reduced.planar): the
    spec's ``added_inertia`` on the joint's rotor, and the measured angle the joint angle plus
    `rest_offset` (an encoder's zero; for a stand the same motion as a centre of mass turned
    about the joint axis).  `release` is the measured release angle; the joint starts from
    ``release - rest_offset``.  Other arguments as for :func:`simulate`."""
    if spec.kind not in STANDS:
        raise ValueError(f"a calibrated stand run needs a stand scenario, not '{spec.kind}'")
    if kw.get("return_states"):
        raise ValueError("a calibrated stand run returns its recording only")
    df = simulate(spec, release - rest_offset, duration, **kw)
    col = "steer_angle_rad" if spec.kind == "steer_stand" else "drive_angle_rad"
    df[col] = df[col] + rest_offset
    return df


def energy(built: Built, x: np.ndarray) -> np.ndarray:
    """Total mechanical energy (kinetic + potential) at each logged state column."""
    plant = built.plant
    ctx = plant.CreateDefaultContext()
    out = np.empty(x.shape[1])
    for k in range(x.shape[1]):
        plant.SetPositionsAndVelocities(ctx, x[:, k])
        out[k] = plant.CalcKineticEnergy(ctx) + plant.CalcPotentialEnergy(ctx)
    return out
