# The campaign plan (roboball.pipeline.plan: the recordings of raw_data/MANIFEST.csv and, when
# present, the authors' real logs) and the shell command that runs a package stage.
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
# What runs (the recordings, the ramp runs by pressure, the sweep cases, the replays) is planned
# by the package, where it is tested: roboball.pipeline.plan.
from roboball.pipeline.plan import REPLAYS, Campaign, friction_models, schedule_args, sweep_cases
from roboball.errors import RoboballError
try:
    CAMPAIGN = Campaign.from_config(config)
except RoboballError as exc:
    raise WorkflowError(str(exc))
for _note in CAMPAIGN.notes:
    print(_note)
REC = CAMPAIGN.recordings
REAL_ON = CAMPAIGN.real_on
stems = CAMPAIGN.stems


SHELL = stems("shell_rock")
RAMP = stems("ramp")
CONTACTS = config["shell"]["contact_models"]
RAMP_CONTACTS = config["ramp"]["contact_models"]
SWEEP = sweep_cases(config["shell"]["sweep_factors"])
FRICTION_MODELS = friction_models(config["friction"])
