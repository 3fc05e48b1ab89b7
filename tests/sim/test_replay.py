"""Meshcat replays (roboball.sim.replay): the ramp and the floor drawn where the robot rolls, the
stand drawn for the stand kinds, a camera beside the robot looking along the axis the motion
turns about, and a recording that loops."""
from __future__ import annotations

import base64
import math
import re

import pytest

from roboball.sim.replay import CAMERA_OFFSET_M, record
from roboball.sim.spec import ShellParams, SimSpec


def _paths(scene):
    return {m.decode() for c in scene.commands for m in re.findall(rb"/scenery/[a-z_0-9]+", base64.b64decode(c))}


def _animation(scene):
    return next(base64.b64decode(c) for c in scene.commands if b"set_animation" in base64.b64decode(c))


@pytest.fixture(scope="module")
def ramp():
    spec = SimSpec(kind="ramp", contact="point", friction={"steer": "majd", "drive": "majd"}, pressure_kpa=13.8,
                   shell=ShellParams(injected_steer=False))
    return record(spec, 0.0, 1.5, ramp_length_m=1.0)


def test_the_ramp_replay_draws_the_ramp_and_the_floor_and_loops(ramp):
    paths = _paths(ramp)
    assert {"/scenery/ramp", "/scenery/floor", "/scenery/ramp_support"} <= paths
    assert any(p.startswith("/scenery/floor_mark_") for p in paths)
    anim = _animation(ramp)
    # three.js LoopRepeat (2201, msgpack uint16) and many repetitions, not LoopOnce's single pass
    assert b"loopMode\xcd\x08\x99" in anim
    reps = anim.split(b"repetitions", 1)[1]
    assert reps[0] == 0xce and int.from_bytes(reps[1:5], "big") >= 1000


def test_the_camera_stands_beside_the_robot_on_the_side_the_motion_shows(ramp):
    start, end = ramp.facts["start_m"], ramp.facts["end_m"]
    assert end[0] - start[0] > 1.0 and end[2] < start[2] - 0.2        # it rolled down the ramp onto the floor
    cam, target = ramp.camera_m, ramp.target_m
    assert target == pytest.approx(start)
    # the ramp's motion is in the x-z plane: the camera looks along y, from about 2 m
    assert abs(cam[1] - target[1]) > 5 * abs(cam[0] - target[0])
    assert 1.5 < math.dist(cam, target) < 3.0
    assert CAMERA_OFFSET_M["shell_rock"][0] != 0 and CAMERA_OFFSET_M["shell_rock"][1] == 0   # rocks about x


def test_the_stand_replay_draws_the_stand():
    spec = SimSpec(kind="steer_stand", contact="point", friction={"steer": "majd", "drive": "majd"},
                   shell=ShellParams())
    scene = record(spec, 0.5, 0.3)
    assert {"/scenery/stand_base", "/scenery/stand_left", "/scenery/clamp_right"} <= _paths(scene)
    assert "/scenery/ramp" not in _paths(scene)
