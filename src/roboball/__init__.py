"""roboball: a reproducible pipeline from raw logs of a soft pendulum-driven spherical robot
to calibrated Drake models, uncertainty reports, paper figures and missing-physics diagnosis."""

__version__ = "0.1.0"
