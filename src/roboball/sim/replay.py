"""Meshcat replays of one simulated run: the robot with the scenery it ran on (ramp and floor,
or the stand that clamps it), filmed from the side that shows the motion, played in a loop.

The recording is returned as data (the viewer commands and the camera), not as a page: pages
are built by roboball.report.replays, which loads Meshcat's viewer code once for every replay.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from roboball.sim.spec import SimSpec

# The body the camera follows (its origin is the shell's centre) and where the camera stands,
# relative to the robot's start, per kind: looking along the axis the motion turns about
# (drive and ramp: the drive axle, y; steer stand and shell rock: the steer axis, x).
FOLLOW = "/drake/visualizer/roboball/pitch_center"
CAMERA_OFFSET_M = {"ramp": (0.0, -2.0, 0.3), "drive_stand": (0.0, -1.7, 0.25),
                   "steer_stand": (1.7, 0.0, 0.25), "shell_rock": (1.7, 0.0, 0.25)}
RAMP_WIDTH_M = 1.2            # scenery only: wide enough to frame the shell (0.61 m across)
SLAB_M = 0.04                 # thickness of the drawn ramp, floor and stand plates
# Three.js loop mode "repeat" (THREE.LoopRepeat) and enough repetitions to look endless.
REPEAT_FOREVER = 1_000_000


@dataclass
class Scene:
    """One recorded replay: the viewer commands (base64 msgpack, Meshcat's own encoding, played
    in order), the camera (world frame, m) and what ran (for the caption)."""

    commands: list
    camera_m: list
    target_m: list
    follow: str = FOLLOW
    facts: dict = field(default_factory=dict)


def _commands(static_html: str) -> list:
    """The scene commands Drake's StaticHtml() embeds as data URIs, in their order."""
    return re.findall(r'fetch\("data:application/octet-binary;base64,([^"]*)"\)', static_html)


def viewer_js() -> str:
    """Meshcat's viewer code (three.js and the Meshcat viewer, about 2.2 MB) as Drake ships it.

    Raises:
        RuntimeError: when Drake's page no longer has the viewer as its first script.
    """
    from pydrake.geometry import Meshcat, MeshcatParams

    html = Meshcat(MeshcatParams(host="localhost", port=None)).StaticHtml()
    m = re.search(r'<script type="text/javascript">(.*?)</script>', html, re.S)
    if m is None or "MeshCat" not in m.group(1):
        raise RuntimeError("Drake's Meshcat page has no viewer script where roboball expects it")
    return m.group(1)


def _box(meshcat, path: str, size, center, pitch_rad: float = 0.0, rgba=(0.6, 0.6, 0.6, 1.0)) -> None:
    from pydrake.geometry import Box, Rgba
    from pydrake.math import RigidTransform, RotationMatrix

    meshcat.SetObject(path, Box(*size), Rgba(*rgba))
    meshcat.SetTransform(path, RigidTransform(RotationMatrix.MakeYRotation(pitch_rad), list(center)))


def _ramp_scenery(meshcat, alpha: float, length_m: float, x_end_m: float) -> None:
    """The ramp (its top face is the contact plane through the origin, downhill +x; it starts
    0.5 m behind the robot) and the floor it ends on, L sin(alpha) lower, out to `x_end_m`."""
    d = np.array([math.cos(alpha), 0.0, -math.sin(alpha)])     # downhill, along the slope
    n = np.array([math.sin(alpha), 0.0, math.cos(alpha)])      # the ramp's normal
    s0, s1 = -0.5, length_m
    _box(meshcat, "/scenery/ramp", (s1 - s0, RAMP_WIDTH_M, SLAB_M), 0.5 * (s0 + s1) * d - 0.5 * SLAB_M * n,
         alpha, (0.72, 0.55, 0.36, 1.0))
    x0, z0 = length_m * math.cos(alpha), -length_m * math.sin(alpha)
    x1 = max(x_end_m + 2.0, x0 + 2.0)
    _box(meshcat, "/scenery/floor", (x1 - x0 + 0.5, 3.0, SLAB_M), (0.5 * (x0 + x1), 0.0, z0 - 0.5 * SLAB_M),
         rgba=(0.78, 0.8, 0.82, 1.0))
    # marks across the ramp every 0.5 m and the floor every metre: the camera follows the robot,
    # so they are what shows it moving
    for k in range(int(length_m / 0.5) + 1):
        _box(meshcat, f"/scenery/ramp_mark_{k}", (0.03, RAMP_WIDTH_M, 0.004), k * 0.5 * d + 0.001 * n, alpha,
             (0.35, 0.25, 0.15, 1.0))
    for k in range(int(x1 - x0) + 1):
        _box(meshcat, f"/scenery/floor_mark_{k}", (0.03, 3.0, 0.004), (x0 + k + 0.5, 0.0, z0 + 0.001),
             rgba=(0.35, 0.37, 0.4, 1.0))
    # the ramp's support: a post under its top end, so that it stands on the floor
    top = s0 * d
    h = top[2] - z0
    _box(meshcat, "/scenery/ramp_support", (0.08, RAMP_WIDTH_M, h), (top[0], 0.0, z0 + 0.5 * h),
         rgba=(0.45, 0.35, 0.25, 1.0))


def _stand_scenery(meshcat, radius: float) -> None:
    """The stand: a base plate under the shell, two uprights beside it and the clamp that holds
    the axle (along y) at the shell's centre, the origin."""
    floor = -radius - 0.25
    y = radius + 0.08
    _box(meshcat, "/scenery/floor", (3.0, 3.0, SLAB_M), (0.0, 0.0, floor - 0.5 * SLAB_M), rgba=(0.78, 0.8, 0.82, 1.0))
    _box(meshcat, "/scenery/stand_base", (0.5, 2 * y + 0.2, SLAB_M), (0.0, 0.0, floor + 0.5 * SLAB_M),
         rgba=(0.25, 0.25, 0.28, 1.0))
    for side, sign in (("left", 1.0), ("right", -1.0)):
        _box(meshcat, f"/scenery/stand_{side}", (0.06, 0.06, -floor), (0.0, sign * y, 0.5 * floor),
             rgba=(0.25, 0.25, 0.28, 1.0))
        _box(meshcat, f"/scenery/clamp_{side}", (0.1, 0.1, 0.1), (0.0, sign * (y - 0.03), 0.0),
             rgba=(0.8, 0.3, 0.1, 1.0))


def record(spec: SimSpec, release: float, duration: float, ramp_length_m: float = 2.0) -> Scene:
    """Simulate `spec` from rest at `release` (rad) for `duration` (s) with Meshcat recording.

    Args:
        spec: the scenario; for the ramp, its `ramp_length_m` is set to `ramp_length_m`.
        release: initial angle of the main coordinate (rad).
        duration: simulated time (s), played in a loop.
        ramp_length_m: length of the ramp along the slope (m), after which the robot rolls on
            the floor.
    Returns:
        The recorded Scene (no file is written).
    """
    from pydrake.geometry import Meshcat, MeshcatAnimation, MeshcatParams
    from pydrake.systems.analysis import Simulator

    from roboball.sim.plant import build
    from roboball.sim.scenarios import set_release

    if spec.kind == "ramp":
        spec.ramp_length_m = ramp_length_m
    meshcat = Meshcat(MeshcatParams(host="localhost", port=None))   # loopback only, any free port
    built = build(spec, meshcat=meshcat)
    vis = next(s for s in built.diagram.GetSystems() if s.get_name().startswith("meshcat_visualizer"))
    sim = Simulator(built.diagram)
    set_release(built, sim.get_mutable_context(), release)
    pctx = built.plant.GetMyContextFromRoot(sim.get_context())
    centre = built.plant.GetBodyByName("pitch_center")
    start = built.plant.EvalBodyPoseInWorld(pctx, centre).translation().copy()
    vis.StartRecording()
    sim.AdvanceTo(duration)
    end = built.plant.EvalBodyPoseInWorld(pctx, centre).translation()
    anim = vis.get_mutable_recording()
    anim.set_loop_mode(MeshcatAnimation.LoopMode.kLoopRepeat)
    anim.set_repetitions(REPEAT_FOREVER)
    vis.PublishRecording()
    meshcat.SetProperty("/Grid", "visible", False)     # the grid is level; the ramp is not
    if spec.kind == "ramp":
        _ramp_scenery(meshcat, built.ramp_alpha, ramp_length_m, float(end[0]))
    elif spec.kind in ("steer_stand", "drive_stand"):
        _stand_scenery(meshcat, built.robot.radius)
    else:
        _box(meshcat, "/scenery/floor", (4.0, 4.0, SLAB_M), (0.0, 0.0, -0.5 * SLAB_M), rgba=(0.78, 0.8, 0.82, 1.0))
    offset = np.array(CAMERA_OFFSET_M[spec.kind])
    return Scene(commands=_commands(meshcat.StaticHtml()), camera_m=(start + offset).tolist(),
                 target_m=start.tolist(), facts={"end_m": end.tolist(), "start_m": start.tolist()})

