# Included first, so everything the other .smk files share is defined before them.  It checks
# the configs, plans the campaign (roboball.pipeline.plan) and holds the shell command that runs
# a package stage, the input functions (get_*) and the workflow's final targets; the other files
# define rules only.
import json
import os
import sys
from pathlib import Path

from snakemake.utils import validate

from roboball.checks import check_config_dir
from roboball.config import first_nonfinite, load_yaml
from roboball.errors import RoboballError
from roboball.pipeline.codedeps import stage_fingerprints
from roboball.pipeline.allocator import job_preload
from roboball.pipeline.plan import (REPLAYS, Campaign, friction_models, hydro_fit_settings, hydro_grid_moduli,
                                    schedule_args, shell_pressure_groups, sweep_cases)


##### configs: checked before any job runs #####

validate(config, "../../configs/schema/config.schema.yaml")
if first_nonfinite(config):   # JSON Schema's bounds cannot refuse NaN
    raise WorkflowError("configs/config.yaml: field '{}': {} is not a finite number".format(*first_nonfinite(config)))

# The robot facts (and every other configs/*.yaml with a schema, e.g. the friction priors) are
# checked before any job runs; every stage then reads this workflow's configs/ folder.
os.environ.setdefault("ROBOBALL_CONFIG_DIR", os.path.abspath("configs"))
# matplotlib's configuration and font cache per environment, not the user's shared ones: a cache
# written by another matplotlib can make the PDFs embed another DejaVu Sans file (same pixels,
# other bytes), and a personal matplotlibrc would restyle the figures.  In the environment when it
# is writable, else beside the results.
_mpl = os.path.join(sys.prefix, "matplotlib-config")
if not (os.access(sys.prefix, os.W_OK) or os.path.isdir(_mpl)):
    _mpl = os.path.abspath(os.path.join("results", ".matplotlib-config"))
os.environ["MPLCONFIGDIR"] = _mpl
CONFIG_DIR = os.environ["ROBOBALL_CONFIG_DIR"]
try:
    check_config_dir(CONFIG_DIR, exclude=("config.yaml",))
except RoboballError as exc:
    raise WorkflowError(str(exc))


##### how a rule runs a stage #####

# The roboball of the environment running Snakemake (the project's .venv).
ROBOBALL = os.path.join(os.path.dirname(sys.executable), "roboball") + " stage"

# Every job runs with mimalloc preloaded: the Drake jobs are 8-17% cheaper, no output changes
# (roboball.pipeline.allocator; ROBOBALL_MALLOC=system to keep glibc's malloc).
_preload = job_preload(os.environ)
if _preload:
    os.environ["LD_PRELOAD"] = _preload

# Each rule's params carry CODE[stage]: a hash of the package source files the stage runs and,
# when it reads them, of the robot facts (roboball.pipeline.codedeps).  Editing a friction law
# reruns the fits and simulations that use it; editing configs/robot.yaml reruns what derives
# from it; a figure module's edit reruns its figures only.
CODE = stage_fingerprints(CONFIG_DIR)


##### the campaign plan #####

# What runs (the recordings, the ramp runs by pressure, the sweep cases, the replays) is planned
# by the package, where it is tested: roboball.pipeline.plan.
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
# The hydroelastic calibration (issue 25): its grid's columns (job -> modulus), the shell
# recordings by pressure, and the table the tuned contact model (hydro_tuned) and others read.
HYDRO = hydro_fit_settings(config["shell"])
HYDRO_GRID = hydro_grid_moduli(HYDRO)
SHELL_GROUPS = shell_pressure_groups(REC, SHELL)
HYDRO_TUNED = "results/identify/hydro_tuned.csv"
if not SHELL_GROUPS and "hydro_tuned" in CONTACTS + RAMP_CONTACTS:
    print("roboball: no shell recording with a known pressure: nothing to calibrate the tuned hydroelastic "
          "model (hydro_tuned) on; it and Fig. S3 are skipped.")
    CONTACTS = [c for c in CONTACTS if c != "hydro_tuned"]
    RAMP_CONTACTS = [c for c in RAMP_CONTACTS if c != "hydro_tuned"]

# Friction: the stand recording of each (dataset, joint) and every fitted (dataset, joint, law):
# the test bed's steer and drive stands, and the real steer-stand log when present.
STAND = {("testbed", "steer"): "steer_stand_r1", ("testbed", "drive"): "drive_stand_r1",
         ("real", "steer"): "real_steer_stand"}
FITS = [("testbed", j, law) for j, law in friction_models(config["friction"])]
if REAL_ON:
    FITS += [("real", "steer", law) for law in config["friction"]["steer_laws"]]
# the workflow's priors (CONFIG_DIR, checked against their schema above)
PRIORS = load_yaml(os.path.join(CONFIG_DIR, "priors.yaml"))
# The test bed's Majd fits: the friction of every ramp simulation and ramp diagnosis.
RAMP_FRICTION = {"steer": "results/friction/testbed/steer_majd.json", "drive": "results/friction/testbed/drive_majd.json"}

# The ramp runs grouped by pressure, for the pooled diagnoses (diagnose.smk).
RAMP_GROUPS = CAMPAIGN.ramp_groups()

# Beyond the paper (issue 9, Fig. S1): the deflating ramp (config section deflating_ramp).
DEFLATE = config.get("deflating_ramp", {})
DEFLATE_SCHEDULE = DEFLATE.get("schedule", {})

# Beyond the paper (issue 27, Fig. S2): the coupled steer test's real repeats, when present (and
# the real steer stand's Majd fit, their steer friction, is among the fits).
COUPLED_LOGS = ([os.path.join(config["real_data"]["path"], f) for f in config["real_data"].get("steer_coupled", [])]
                if REAL_ON and "majd" in config["friction"]["steer_laws"] else [])

PF = "paper_figures"
# The paper tables the Snakemake report shows (rule table_page), by file stem.
# Numbered: the report sorts its labels as text.
TABLE_NAMES = {"table1_friction": "1. Table I: joint friction", "table2_robot": "2. Table II: the robot's numbers",
               "table_pme": "3. PME (eq. 12) by contact model and pressure", "table_sweep": "4. Hydroelastic sweep"}
if COUPLED_LOGS:
    TABLE_NAMES["table_coupled_rms"] = "5. Coupled steer test (Fig. S2): RMS by model"


##### file names #####

def fit_json(dataset, joint, law):
    return f"results/friction/{dataset}/{joint}_{law}.json"


def fit_jsons(dataset=None):
    """Every friction fit, or those of one dataset (testbed, real)."""
    return [fit_json(*f) for f in FITS if dataset is None or f[0] == dataset]


def friction_comparisons():
    """The model comparisons the uncertainty report reads: the steer laws of each dataset."""
    return ["results/friction/testbed/steer_comparison.csv"] + (["results/friction/real/steer_comparison.csv"] if REAL_ON else [])


def diagnosis_files(name):
    """`name` (diagnosis.json, details.json) of every diagnosis the uncertainty report reads: the
    stand and shell recordings' own, then each ramp pressure's pooled one."""
    return ([f"results/diagnose/{s}/{name}" for s in stems("steer_stand", True) + stems("shell_rock", True)]
            + [f"results/diagnose/pressure/{g}/{name}" for g in RAMP_GROUPS])


def report_figures():
    """The paper figures the uncertainty report links, in its order."""
    return ([f"{PF}/fig5_friction_laws.png", f"{PF}/fig7_testbed_steer_fits.png", f"{PF}/fig8_testbed_drive_fits.png",
             f"{PF}/fig10_shell_dynamics.png", f"{PF}/fig11_hydro_sensitivity.png", f"{PF}/fig13_ramp_pme.png",
             f"{PF}/fig14_ramp_pme_mean.png"] + ([f"{PF}/figS3_hydro_calibration.png"] if SHELL_GROUPS else [])
            + ([f"{PF}/fig7_real_steer_fits.png"] if REAL_ON else []))


def final_targets():
    """The workflow's final targets (the Snakefile's `all`): the paper's figures and tables, the
    replays, the friction figures, the uncertainty report, Fig. S1 and, with the real coupled
    repeats, Fig. S2 and its table."""
    targets = [
        f"{PF}/fig10_shell_dynamics.png", f"{PF}/fig11_hydro_sensitivity.png",
        f"{PF}/fig13_ramp_pme.png", f"{PF}/fig14_ramp_pme_mean.png",
        f"{PF}/table_pme.csv", f"{PF}/table_pme.md", f"{PF}/table_sweep.md", f"{PF}/table2_robot.md",
    ]
    targets += [f"results/replays/{s}.html" for s in REPLAYS] + ["results/replays/meshcat.js", "results/replays/index.html"]
    targets += [f"{PF}/fig5_friction_laws.png", f"{PF}/table1_friction.md",
                f"{PF}/fig7_testbed_steer_fits.png", f"{PF}/fig8_testbed_drive_fits.png"]
    targets += [f"{PF}/corner/corner_{d}_{j}_{l}.png" for d, j, l in FITS]
    if REAL_ON:
        targets += [f"{PF}/fig7_real_steer_fits.png"]
    targets += [f"{PF}/uncertainty_report.html", f"{PF}/figS1_deflating_ramp.png"]
    if COUPLED_LOGS:
        targets += [f"{PF}/figS2_steer_coupled.png", f"{PF}/table_coupled_rms.csv", f"{PF}/table_coupled_rms.md"]
    targets += [f"results/report/{t}.html" for t in TABLE_NAMES]
    if SHELL_GROUPS:
        targets += [f"{PF}/figS3_hydro_calibration.png", f"{PF}/table_hydro_tuned.md", f"{PF}/table_hydro_tuned.csv",
                    HYDRO_TUNED]
    return targets


##### report labels #####

def pressure_label(p):
    """A pressure as the Snakemake report's label: zero-padded ("06.9"), because the report sorts
    labels as text, which would put 20.7 before 6.9."""
    if p in (None, "") or p != p:            # the real logs' (unknown) and the stands' (NaN: no shell)
        return "-"
    return f"{float(p):04.1f}"


def qc_labels(wildcards):
    """The QC plot's labels: kind, pressure (kPa), recording, in the report's sort order."""
    r = REC[wildcards.stem]
    return {"kind": r["kind"], "pressure (kPa)": pressure_label(r["pressure_kpa"]), "recording": wildcards.stem}


##### input functions #####

def get_sidecar(wildcards):
    """The recording's sidecar (kind, pressure, ramp angle, ramp exit), when it has one."""
    return [s for s in [str(Path(REC[wildcards.stem]["src"]).with_suffix(".json"))] if Path(s).is_file()]


def get_stand_recording(wildcards):
    """The ingested stand recording a friction fit of (dataset, joint) is made on."""
    stem = STAND[(wildcards.dataset, wildcards.joint)]
    return {"csv": f"results/ingest/{stem}.csv", "releases": f"results/ingest/{stem}.releases.json"}


def get_stand_fits(wildcards):
    """Every fitted law of one (dataset, joint)."""
    return [fit_json(d, j, l) for d, j, l in FITS if d == wildcards.dataset and j == wildcards.joint]


def get_prior_json(wildcards):
    """Only this model's prior block and its joint's stand calibration: editing another model's
    prior does not rerun this fit."""
    joint = PRIORS[wildcards.joint]
    return json.dumps({wildcards.joint: {wildcards.law: joint[wildcards.law], "stand": joint["stand"]}}, sort_keys=True)


def get_hydro_fit(wildcards):
    """The calibration table, for the tuned hydroelastic model only."""
    return [HYDRO_TUNED] if wildcards.contact == "hydro_tuned" else []


def get_ramp_scales(wildcards):
    """(modulus, dissipation) scales of a ramp run: the sweep's carried-forward setting for
    hydroelastic contact, none for the others (hydro_tuned runs its calibrated values as they are)."""
    if wildcards.contact == "hydroelastic":
        return (config["shell"]["carried_forward"]["modulus_scale"],
                config["shell"]["carried_forward"]["dissipation_scale"])
    return (1.0, 1.0)


def _ingested(stems_):
    return {"csv": [f"results/ingest/{s}.csv" for s in stems_],
            "sidecars": [f"results/ingest/{s}.json" for s in stems_]}


def get_runs_at_pressure(wildcards):
    """The ingested ramp runs of one pressure group, diagnosed together."""
    return _ingested(CAMPAIGN.runs_at(wildcards.group))


def get_other_runs(wildcards):
    """The ingested ramp runs whose pooled diagnosis scores run `stem` out of sample."""
    return _ingested(CAMPAIGN.other_runs(wildcards.stem))
