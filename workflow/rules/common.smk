# Campaign bookkeeping: which recordings exist (raw_data/MANIFEST.csv and, when present,
# the authors' real logs), and the shell command that runs a package stage.
import csv
import os
import sys

# The roboball of the environment running Snakemake (the project's .venv).
ROBOBALL = os.path.join(os.path.dirname(sys.executable), "roboball") + " stage"

# Each rule's params carry CODE[stage]: a hash of the package source files the stage runs and,
# when it reads them, of the robot facts (roboball.pipeline.codedeps).  Editing a friction law
# reruns the fits and simulations that use it; editing configs/robot.yaml reruns what derives
# from it; a figure module's edit reruns its figures only.
from roboball.pipeline.codedeps import stage_fingerprints
CODE = stage_fingerprints(os.environ["ROBOBALL_CONFIG_DIR"])
RAW = config["raw_data"]


def _manifest():
    """stem -> src, kind, pressure_kpa; the manifest is checked (files exist, kinds, pressures,
    unique names) before anything is planned: a one-line error otherwise."""
    from roboball.checks import read_manifest
    from roboball.errors import RoboballError
    try:
        return read_manifest(RAW)
    except RoboballError as exc:
        raise WorkflowError(str(exc))


REC = _manifest()

_real = config["real_data"]
REAL_ON = _real["enabled"] is True or (_real["enabled"] == "auto" and os.path.isdir(_real["path"]))
if _real["enabled"] is True and not os.path.isdir(_real["path"]):
    raise WorkflowError(f"real_data.path {_real['path']}: folder not found (set real_data.enabled: auto or false)")
if REAL_ON:
    REC["real_steer_stand"] = {"src": os.path.join(_real["path"], _real["steer_stand"]), "kind": "steer_stand",
                               "pressure_kpa": ""}
    REC["real_shell_rock"] = {"src": os.path.join(_real["path"], _real["shell_rock"]), "kind": "shell_rock",
                              "pressure_kpa": ""}
else:
    print(f"roboball: real logs not found at {_real['path']}: the real-data part of the pipeline is skipped "
          "(see README, 'Real recordings').")


def stems(kind, real=False):
    return sorted(s for s, r in REC.items() if r["kind"] == kind and s.startswith("real_") == real)


SHELL = stems("shell_rock")
RAMP = stems("ramp")
CONTACTS = config["shell"]["contact_models"]
RAMP_CONTACTS = config["ramp"]["contact_models"]
F = config["shell"]["sweep_factors"]
SWEEP = {}   # the control case is the hydroelastic shell simulation itself
for f in F:
    SWEEP[f"modulus_x{f:g}"] = (f, 1.0)
    SWEEP[f"dissipation_x{f:g}"] = (1.0, f)
    SWEEP[f"both_x{f:g}"] = (f, f)
FRICTION_MODELS = [("steer", law) for law in config["friction"]["steer_laws"]] + \
                  [("drive", law) for law in config["friction"]["drive_laws"]]
