"""The experiment kinds and their signals, named once (robot-facts.md, recordings.md).

A recording is of one kind; each kind has a main signal (the coordinate that is fitted and
plotted) and the signals a simulation of it records.  `free` is a simulation-only kind (the
robot on flat ground, no experiment behind it).  `steer_coupled` (shell rocking in the steer
direction with the pendulum free on its steer joint, issue 27) is recorded and simulated; stages
that cannot handle a kind say so (NOT_YET)."""
from __future__ import annotations

STANDS = ("steer_stand", "drive_stand")            # the pendulum on its test stand, shell removed
OSCILLATING = STANDS + ("shell_rock",)             # released by hand, swing and settle
# every kind a recording may be of; steer_coupled also swings and settles after a hand's release
RECORDED = OSCILLATING + ("ramp", "steer_coupled")
SIMULATED = OSCILLATING + ("ramp", "free", "steer_coupled")   # every kind a Drake scenario can run

# The coordinate each kind is judged on.  The drive joint is continuous: on the ramp its angle
# winds up without bound, so rolling runs are judged on its rate.
MAIN_SIGNAL = {"steer_stand": "steer_angle_rad", "drive_stand": "drive_angle_rad",
               "shell_rock": "pipe_angle_rad", "ramp": "drive_rate_rad_s", "free": "pipe_angle_rad",
               "steer_coupled": "pipe_angle_rad"}
# Kinds recorded with a second coordinate that a recording of them must hold too.
SECOND_SIGNAL = {"steer_coupled": "steer_angle_rad"}

_ROLLING = ["drive_rate_rad_s", "pipe_angle_rad", "steer_angle_rad", "pipe_rate_rad_s", "steer_rate_rad_s"]
# What a simulation of each kind records.
SIM_SIGNALS = {
    "steer_stand": ["steer_angle_rad", "steer_rate_rad_s"],
    "drive_stand": ["drive_angle_rad"],
    "shell_rock": ["pipe_angle_rad", "pipe_rate_rad_s"],
    "ramp": list(_ROLLING),
    "free": list(_ROLLING),
    # both coordinates the coupled test logs, with their rates (the drive joint is held)
    "steer_coupled": ["pipe_angle_rad", "steer_angle_rad", "pipe_rate_rad_s", "steer_rate_rad_s"],
}
# Every signal column a recording may hold, and the angles among them.
KNOWN_SIGNALS = ("steer_angle_rad", "drive_angle_rad", "pipe_angle_rad",
                 "drive_rate_rad_s", "steer_rate_rad_s", "pipe_rate_rad_s")
ANGLE_SIGNALS = ("steer_angle_rad", "drive_angle_rad", "pipe_angle_rad")
# Kinds whose pressure must be known (the shell is in contact with the ground).  A steer_coupled
# recording's pressure may be unknown (the authors' coupled logs do not give it).
PRESSURE_REQUIRED = ("shell_rock", "ramp")
# The pipeline's shell contact models, in the order every figure and table lists them: the
# paper's three (section III) and the hydroelastic contact calibrated to the shell releases
# (issue 25, roboball.identify.shell.hydro).  Config shell/ramp.contact_models choose among them.
CONTACT_MODELS = ("point", "injected", "hydroelastic", "hydro_tuned")
# Recorded kinds a stage cannot handle yet, by stage.
# steer_coupled is diagnosed in Drake (roboball.diagnose.coupled_effects), not by the reduced
# models; the pipeline takes every recorded kind (its coupled repeats make Fig. S2).
NOT_YET = {"reduced-model diagnosis": ("steer_coupled",), "pipeline": (),
           "simulation scenarios": ()}


def not_yet_message(kind: str, stage: str) -> str:
    """What a stage says of a recorded kind it cannot handle yet (after the file's name)."""
    return f"kind {kind} is not supported in the {stage} yet"
