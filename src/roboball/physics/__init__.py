"""Physics laws written once, as plain functions of joint state and parameters.

Every law takes a math namespace `m` (default: NumPy) so the same function body is
evaluated on NumPy arrays by the fast reduced models and on Drake symbolic expressions
when the Drake diagram is built (see roboball.sim.forces).  Nothing here imports Drake.
"""
from roboball.physics.mathns import NP  # noqa: F401
