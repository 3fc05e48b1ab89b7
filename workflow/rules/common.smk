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
from roboball.cli import warm
from roboball.pipeline.allocator import job_preload
from roboball.pipeline.bytecode import compile_package
from roboball.pipeline.numerics import job_environment
from roboball.pipeline.plan import (REPLAYS, STAND_FIGURE, Campaign, hydro_fit_settings, hydro_grid_moduli,
                                    schedule_args, shell_pressure_groups, sweep_cases)


##### configs: checked before any job runs #####

validate(config, "../../configs/schema/config.schema.yaml")
if first_nonfinite(config):   # JSON Schema's bounds cannot refuse NaN
    raise WorkflowError("configs/config.yaml: field '{}': {} is not a finite number".format(*first_nonfinite(config)))

# Relative paths of the config (the campaigns' folders, configs/) are the workflow's, wherever
# Snakemake runs (make figures OUT=DIR runs it in DIR).
BASE = "." if os.path.realpath(workflow.basedir) == os.path.realpath(os.getcwd()) else workflow.basedir
# The robot facts (and every other configs/*.yaml with a schema, e.g. the friction priors) are
# checked before any job runs; every stage then reads this workflow's configs/ folder.
os.environ.setdefault("ROBOBALL_CONFIG_DIR", os.path.abspath(os.path.join(workflow.basedir, "configs")))
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

# The roboball of the environment running Snakemake (the project's .venv), started warm: a job
# is forked from a process that has imported the stages' numeric stack, not started afresh
# (roboball.cli.warm; the server runs in local runs only, else and with ROBOBALL_WARM=0 each
# job starts a fresh process).
ROBOBALL = f"{sys.executable} -m {warm.MODULE} stage"

# Every job runs with mimalloc preloaded: the Drake jobs are 8-17% cheaper, no output changes
# (roboball.pipeline.allocator; ROBOBALL_MALLOC=system to keep glibc's malloc).
_preload = job_preload(os.environ)
if _preload:
    os.environ["LD_PRELOAD"] = _preload

# Every job computes on the numeric code paths every x86-64 machine has (NumPy's baseline, one
# OpenBLAS kernel and thread, Numba for a generic CPU, libm's plain variants), so the results do
# not depend on the CPU (roboball.pipeline.numerics; ROBOBALL_NUMERICS=native to opt out).
os.environ.update(job_environment(os.environ))
# Numba's parallel loops on one thread per job: Snakemake gives each job one core and runs as many
# jobs as there are cores, and a second thread spinning at the loops' ends beside the other job
# cost the ramp diagnoses 11% more CPU for the same bytes (rows are independent).  friction_fit
# sets its own from its `threads`.
os.environ["NUMBA_NUM_THREADS"] = "1"

# The warm server starts with the jobs' environment (set above), after the DAG is built and only
# when jobs will run here; it ends with the run.
onstart:
    if workflow.local_exec:
        warm.start(os.environ)

onsuccess:
    warm.stop(os.environ)

onerror:
    warm.stop(os.environ)

# Each rule's params carry CODE[stage]: a hash of the package source files the stage runs and,
# when it reads them, of the robot facts (roboball.pipeline.codedeps).  Editing a friction law
# reruns the fits and simulations that use it; editing configs/robot.yaml reruns what derives
# from it; a figure module's edit reruns its figures only.
CODE = stage_fingerprints(CONFIG_DIR, cache=".snakemake/roboball-code-fingerprints.json")
# Jobs load the package's modules compiled, not recompiled each time (roboball.pipeline.bytecode).
compile_package()


##### the campaign plan #####

# What runs is planned by the package, where it is tested (roboball.pipeline.plan): the campaigns'
# manifests are read and checked here, before any job, and the plan says what it makes and what it
# skips, each skip with its reason.  Nothing fails because a kind is absent.
try:
    CAMPAIGN = Campaign.from_config(config, base=BASE)
except RoboballError as exc:
    raise WorkflowError(str(exc))
for _line in CAMPAIGN.plan_lines(config["friction"]):
    print("roboball plan: " + _line, file=sys.stderr)
REC = CAMPAIGN.recordings
DATASETS = list(CAMPAIGN.datasets)
stems = CAMPAIGN.stems

# Shell releases: every one gets its decay; those of known pressure are regressed and simulated.
SHELL_ALL = stems("shell_rock")
SHELL = CAMPAIGN.known_pressure("shell_rock")
REGRESSION = CAMPAIGN.has_regression()
RAMP = stems("ramp")
# Without a regression only the point contact runs (the others take zeta(p), omega_n(p)).
CONTACTS = config["shell"]["contact_models"] if REGRESSION else []
RAMP_CONTACTS = [c for c in config["ramp"]["contact_models"] if REGRESSION or c == "point"]
SWEEP = sweep_cases(config["shell"]["sweep_factors"]) if REGRESSION else {}
# The hydroelastic calibration (issue 25): its grid's columns (job -> modulus), the shell
# recordings by pressure, and the table the tuned contact model (hydro_tuned) and others read.
HYDRO = hydro_fit_settings(config["shell"])
HYDRO_GRID = hydro_grid_moduli(HYDRO)
SHELL_GROUPS = shell_pressure_groups(REC, SHELL) if REGRESSION else {}
HYDRO_TUNED = "results/identify/hydro_tuned.csv"
if not SHELL_GROUPS:
    CONTACTS = [c for c in CONTACTS if c != "hydro_tuned"]
    RAMP_CONTACTS = [c for c in RAMP_CONTACTS if c != "hydro_tuned"]
REGRESSION_CSV = "results/identify/shell_regression.csv"
# the campaigns whose shell and ramp figures these are, named in their titles
SHELL_NAME = CAMPAIGN.name(CAMPAIGN.dataset_of("shell_rock"))
RAMP_NAME = CAMPAIGN.name(CAMPAIGN.dataset_of("ramp"))

# Friction: every fitted (dataset, joint, law), each on all of that dataset's stand runs of the joint.
FITS = CAMPAIGN.fits(config["friction"])
FIT_DATASETS = list(dict.fromkeys(d for d, _, _ in FITS))
# the dataset of Fig. 5 and of Table I's model comparison: the first with fits
MAIN_FITS = FIT_DATASETS[0] if FIT_DATASETS else None
STEER_COMPARED = [d for d in FIT_DATASETS if any(f[0] == d and f[1] == "steer" for f in FITS)]
STAND_FIGS = [(d, j) for d in FIT_DATASETS for j in ("steer", "drive") if any(f[:2] == (d, j) for f in FITS)]
# the workflow's priors (CONFIG_DIR, checked against their schema above)
PRIORS = load_yaml(os.path.join(CONFIG_DIR, "priors.yaml"))
# The Majd fits of the ramp runs' campaign: the friction of every ramp simulation and ramp
# diagnosis (a joint without a stand runs with Table I's values, and the plan says so).
RAMP_FRICTION = CAMPAIGN.ramp_friction(config["friction"])

# The ramp runs grouped by pressure, for the pooled diagnoses (diagnose.smk): out dir -> the runs
# diagnosed together, all runs at each pressure, then each run's held-out set (the others there).
RAMP_GROUPS = CAMPAIGN.ramp_groups()
RAMP_POOLED = {f"results/diagnose/pressure/{g}": CAMPAIGN.runs_at(g) for g in RAMP_GROUPS}
RAMP_DIAGNOSES = {**RAMP_POOLED, **{f"results/diagnose/heldout/{s}": CAMPAIGN.other_runs(s) for s in RAMP}}
# what `roboball diagnose` writes in its out dir (roboball.diagnose.report.OUTPUT_FILES, held equal by
# tests/pipeline/test_workflow_outputs.py: importing the package here would slow every DAG build)
DIAGNOSIS_FILES = ("diagnosis.json", "predictions.csv", "report.md", "details.json", "overlay.png", "regimes.png",
                   "windows.png")

# Beyond the paper (issue 9, Fig. S1): the deflating ramp (config section deflating_ramp).
DEFLATE = config.get("deflating_ramp", {})
DEFLATE_SCHEDULE = DEFLATE.get("schedule", {})

# Beyond the paper (issue 27, Fig. S2): the coupled steer test of each set of repeats (a campaign's
# repeats at one logged pressure, or those whose pressure was not logged: roboball.pipeline.plan),
# with that campaign's steer-stand Majd fit; its shell laws are the regression, else that
# campaign's shell releases held constant (a pressure-free law: the repeats' pressure is then not fitted).
COUPLED_SETS = CAMPAIGN.coupled_plan(config["friction"])[0]
COUPLED = [s for _, stems_, _ in COUPLED_SETS.values() for s in stems_]
PF = config.get("figures_dir", "paper_figures")


##### file names #####

def fit_json(dataset, joint, law):
    return f"results/friction/{dataset}/{joint}_{law}.json"


def fit_jsons(dataset=None):
    """Every friction fit, or those of one dataset (testbed, real, a user's campaign)."""
    return [fit_json(*f) for f in FITS if dataset is None or f[0] == dataset]


def friction_comparisons():
    """The model comparisons the uncertainty report reads: the steer laws of each dataset."""
    return [f"results/friction/{d}/steer_comparison.csv" for d in STEER_COMPARED]


def diagnosis_files(name):
    """`name` (diagnosis.json, details.json) of every diagnosis the uncertainty report reads: the
    stand and shell recordings' own, then each ramp pressure's pooled one."""
    return ([f"results/diagnose/{s}/{name}" for s in CAMPAIGN.diagnosed_stems()]
            + [f"results/diagnose/pressure/{g}/{name}" for g in RAMP_GROUPS])


def coupled_outputs(name):
    """The files of one set of coupled repeats (COUPLED_SETS): Fig. S2 and its table in the
    figures, suffixed by the set's name, and its traces and summary under results/coupled/."""
    return {"png": f"{PF}/figS2_steer_coupled_{name}.png", "pdf": f"{PF}/figS2_steer_coupled_{name}.pdf",
            "table_csv": f"{PF}/table_coupled_rms_{name}.csv", "table_md": f"{PF}/table_coupled_rms_{name}.md",
            "traces": f"results/coupled/{name}/traces.csv", "summary": f"results/coupled/{name}/coupled.json"}


def stand_figure(dataset, joint):
    return f"{PF}/fig{STAND_FIGURE[joint]}_{dataset}_{joint}_fits.png"


def report_figures():
    """The paper figures the uncertainty report links, in its order."""
    out = [f"{PF}/fig5_friction_laws.png"] if FITS else []
    out += [stand_figure(d, j) for d, j in STAND_FIGS if d == MAIN_FITS]
    if REGRESSION:
        out += [f"{PF}/fig10_shell_dynamics.png", f"{PF}/fig11_hydro_sensitivity.png"]
    if RAMP:
        out += [f"{PF}/fig13_ramp_pme.png", f"{PF}/fig14_ramp_pme_mean.png"]
    if SHELL_GROUPS:
        out += [f"{PF}/figS3_hydro_calibration.png"]
    return out + [stand_figure(d, j) for d, j in STAND_FIGS if d != MAIN_FITS]


def final_targets():
    """The workflow's final targets (the Snakefile's `all`): what the plan makes of the campaigns
    (roboball.pipeline.plan): the paper's figures and tables, the replays, the friction figures,
    the uncertainty report, Fig. S1 and, with coupled repeats, Fig. S2 and its table."""
    targets = [f"{PF}/table2_robot.md"]
    targets += [f"results/decay/{s}.csv" for s in SHELL_ALL]
    if REGRESSION:
        targets += [f"{PF}/fig10_shell_dynamics.png", f"{PF}/fig11_hydro_sensitivity.png", f"{PF}/table_sweep.md"]
        targets += [f"results/replays/{s}.html" for s in REPLAYS]
        targets += ["results/replays/meshcat.js", "results/replays/index.html", f"{PF}/figS1_deflating_ramp.png"]
    if RAMP:
        targets += [f"{PF}/fig13_ramp_pme.png", f"{PF}/fig14_ramp_pme_mean.png", f"{PF}/table_pme.csv",
                    f"{PF}/table_pme.md"]
    if FITS:
        targets += [f"{PF}/fig5_friction_laws.png", f"{PF}/table1_friction.md"]
    targets += [stand_figure(d, j) for d, j in STAND_FIGS]
    targets += [f"{PF}/corner/corner_{d}_{j}_{l}.png" for d, j, l in FITS]
    targets += [f"{PF}/uncertainty_report.html"]
    for name in COUPLED_SETS:
        out = coupled_outputs(name)
        targets += [out["png"], out["table_csv"], out["table_md"]]
    targets += [f"results/report/{t}.html" for t in TABLE_NAMES]
    if SHELL_GROUPS:
        targets += [f"{PF}/figS3_hydro_calibration.png", f"{PF}/table_hydro_tuned.md", f"{PF}/table_hydro_tuned.csv",
                    HYDRO_TUNED]
    return targets


##### report labels #####

def pressure_label(p):
    """A pressure as the Snakemake report's label: zero-padded ("06.9"), because the report sorts
    labels as text, which would put 20.7 before 6.9."""
    try:
        p = float(p)
    except (TypeError, ValueError):         # "" (a stand: no shell) or "unknown" (a real log's)
        return "-"
    return "-" if p != p else f"{p:04.1f}"


def coupled_label(dataset, p):
    """A set of coupled repeats in the report: its campaign and pressure, padded as
    `pressure_label` pads it so that the report lists 6.9 kPa before 10.3 kPa."""
    return f"{CAMPAIGN.name(dataset)}, " + ("pressure not logged" if p is None else f"{pressure_label(p)} kPa")


# The paper tables the Snakemake report shows (rule table_page), by file stem.
# Numbered: the report sorts its labels as text.
TABLE_NAMES = {}
if FITS:
    TABLE_NAMES["table1_friction"] = "1. Table I: joint friction"
TABLE_NAMES["table2_robot"] = "2. Table II: the robot's numbers"
if RAMP:
    TABLE_NAMES["table_pme"] = "3. PME (eq. 12) by contact model and pressure"
if REGRESSION:
    TABLE_NAMES["table_sweep"] = "4. Hydroelastic sweep"
for _name, (_d, _, _p) in COUPLED_SETS.items():
    TABLE_NAMES[f"table_coupled_rms_{_name}"] = (
        f"5. Coupled steer test (Fig. S2), {coupled_label(_d, _p)}: RMS by model")


def qc_labels(wildcards):
    """The QC plot's labels: kind, pressure (kPa), recording, in the report's sort order."""
    r = REC[wildcards.stem]
    return {"kind": r["kind"], "pressure (kPa)": pressure_label(r["pressure_kpa"]), "recording": wildcards.stem}


##### input functions #####

def get_sidecar(wildcards):
    """The recording's sidecar (kind, pressure, ramp angle, ramp exit), when it has one."""
    return [s for s in [str(Path(REC[wildcards.stem]["src"]).with_suffix(".json"))] if Path(s).is_file()]


def get_stand_recording(wildcards):
    """The ingested stand runs a friction fit of (dataset, joint) is made on, fitted together."""
    runs = CAMPAIGN.stand_stems(wildcards.dataset, wildcards.joint)
    return {"csv": [f"results/ingest/{s}.csv" for s in runs],
            "releases": [f"results/ingest/{s}.releases.json" for s in runs]}


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


##### the batched rules' items (roboball stage NAME --each) #####

def _each(items):
    return json.dumps(items, sort_keys=True)


def _shell_sim_each(input, output, **call):
    """One shell_sim call per shell recording, with the job's `call` arguments."""
    return _each([{"releases": r, "regression": input.regression, "duration": config["shell"]["sim_duration_s"],
                   "dt": config["shell"]["dt_s"], "out_csv": o, **call}
                  for r, o in zip(input.releases, output)])


def get_shell_sim_each(wildcards, input, output):
    """The shell simulations of one contact model."""
    return _shell_sim_each(input, output, contact=wildcards.contact, hydro_fit=" ".join(input.hydro_fit))


def get_sweep_sim_each(wildcards, input, output):
    """The hydroelastic shell simulations at one sweep case's scales."""
    modulus, dissipation = SWEEP[wildcards.case]
    return _shell_sim_each(input, output, contact="hydroelastic", modulus_scale=modulus,
                           dissipation_scale=dissipation)


def get_ramp_sim_each(wildcards, input, output):
    """One ramp_sim call per ramp run with the contact model of the job, the campaign's Majd fits
    and its posterior draws."""
    modulus, dissipation = get_ramp_scales(wildcards)
    friction = {f"friction_{j}": input[j] for j in ("steer", "drive") if j in RAMP_FRICTION}
    return _each([{"recording": c, "releases": r, "regression": " ".join(input.regression),
                   "contact": wildcards.contact, "hydro_fit": " ".join(input.hydro_fit), **friction,
                   "modulus_scale": modulus, "dissipation_scale": dissipation, "dt": config["ramp"]["dt_s"],
                   "posterior_draws": config["ramp"]["posterior_draws"], "seed": config["seed"],
                   "out_csv": pme, "out_trace": trace}
                  for c, r, pme, trace in zip(input.csv, input.releases, output.pme, output.trace)])


def coupled_laws(dataset):
    """The shell laws a set of coupled repeats runs with: the regression, else its campaign's."""
    return REGRESSION_CSV if REGRESSION else f"results/identify/{dataset}_shell_laws.csv"


def get_steer_coupled_each(wildcards, input, output):
    """One steer-coupled call per set of coupled repeats: its recordings as recorded, its
    campaign's shell laws and steer Majd fit, its logged pressure, its files."""
    items = []
    for name, (d, stems_, p) in COUPLED_SETS.items():
        out = coupled_outputs(name)
        item = {"recordings": [REC[s]["src"] for s in stems_], "regression": coupled_laws(d),
                "friction_steer": fit_json(d, "steer", "majd"), "hydro_fit": " ".join(input.hydro_fit),
                "nm_evals": config.get("steer_coupled", {}).get("nm_evals", 30), "campaign": CAMPAIGN.name(d),
                "out_json": out["summary"], "out_csv": out["traces"], "out_png": out["png"],
                "table_csv": out["table_csv"], "table_md": out["table_md"]}
        if p is not None:
            item["pressure_kpa"] = p
        items.append(item)
    return _each(items)


def get_diagnose_ramp_each(wildcards, input, output):
    """One diagnose-recording call per ramp diagnosis (RAMP_DIAGNOSES), with the Majd fits; a
    pressure's only run is diagnosed once, its held-out diagnosis copied from the pooled one."""
    friction = {f"friction_{j}": input[j] for j in ("steer", "drive") if j in RAMP_FRICTION}
    pooled = {tuple(runs): d for d, runs in RAMP_POOLED.items()}
    items = []
    for d, runs in RAMP_DIAGNOSES.items():
        same = pooled.get(tuple(runs), d)
        items.append({"recording": _ingested(runs)["csv"], "out_dir": d, **friction,
                      **({"same_as": same} if same != d else {})})
    return _each(items)


def get_ramp_diagnosed_each(wildcards, input, output):
    """One ramp_diagnosed call per ramp run, with the diagnosis that held that run out."""
    return _each([{"recording": c, "releases": r, "diagnoses": [d], "dt": config["ramp"]["dt_s"],
                   "out_csv": pme, "out_trace": trace}
                  for c, r, d, pme, trace in zip(input.csv, input.releases, input.diagnoses, output.pme, output.trace)])
