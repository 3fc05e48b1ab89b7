"""The experiment kinds and their signals, named once (robot-facts.md, recordings.md).

A recording is of one kind; each kind has a main signal (the coordinate that is fitted and
plotted) and the signals a simulation of it records.  `free` is a simulation-only kind (the
robot on flat ground, no experiment behind it)."""
from __future__ import annotations

STANDS = ("steer_stand", "drive_stand")            # the pendulum on its test stand, shell removed
OSCILLATING = STANDS + ("shell_rock",)             # released by hand, swing and settle
RECORDED = OSCILLATING + ("ramp",)                 # every kind a recording may be of
SIMULATED = RECORDED + ("free",)                   # every kind a Drake scenario can run

# The coordinate each kind is judged on.  The drive joint is continuous: on the ramp its angle
# winds up without bound, so rolling runs are judged on its rate.
MAIN_SIGNAL = {"steer_stand": "steer_angle_rad", "drive_stand": "drive_angle_rad",
               "shell_rock": "pipe_angle_rad", "ramp": "drive_rate_rad_s", "free": "pipe_angle_rad"}

_ROLLING = ["drive_rate_rad_s", "pipe_angle_rad", "steer_angle_rad", "pipe_rate_rad_s", "steer_rate_rad_s"]
# What a simulation of each kind records.
SIM_SIGNALS = {
    "steer_stand": ["steer_angle_rad", "steer_rate_rad_s"],
    "drive_stand": ["drive_angle_rad"],
    "shell_rock": ["pipe_angle_rad", "pipe_rate_rad_s"],
    "ramp": list(_ROLLING),
    "free": list(_ROLLING),
}
# Every signal column a recording may hold, and the angles among them.
KNOWN_SIGNALS = ("steer_angle_rad", "drive_angle_rad", "pipe_angle_rad",
                 "drive_rate_rad_s", "steer_rate_rad_s", "pipe_rate_rad_s")
ANGLE_SIGNALS = ("steer_angle_rad", "drive_angle_rad", "pipe_angle_rad")
# Kinds whose pressure must be known (the shell is in contact with the ground).
PRESSURE_REQUIRED = ("shell_rock", "ramp")
