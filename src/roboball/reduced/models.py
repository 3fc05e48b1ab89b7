"""Which reduced model stands in for Drake in the diagnosis of each experiment kind."""
from __future__ import annotations

from roboball.config import RobotFacts
from roboball.kinds import STANDS
from roboball.reduced.base import ReducedModel
from roboball.reduced.ramp import RampModel
from roboball.reduced.shell import ShellModel
from roboball.reduced.stand import StandModel


def model_for(kind: str, robot: RobotFacts | None = None, **kw) -> ReducedModel:
    """The reduced model of an experiment kind."""
    if kind in STANDS:
        return StandModel(kind, robot)
    if kind == "shell_rock":
        return ShellModel(robot)
    if kind == "ramp":
        return RampModel(robot, **kw)
    raise ValueError(f"no reduced model for kind '{kind}'")
