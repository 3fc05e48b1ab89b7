# roboball: raw logs -> releases and decay -> regressions -> friction posteriors ->
# Drake simulations of every contact model and the sweep -> paper_figures/.
# Rules are thin: each calls one stage of the roboball package (`roboball stage NAME`).
from snakemake.utils import validate

configfile: "configs/config.yaml"
validate(config, "configs/schema/config.schema.yaml")

# The robot facts (and every other configs/*.yaml with a schema, e.g. the friction priors) are
# checked before any job runs; every stage then reads this workflow's configs/ folder.
import os
import sys
os.environ.setdefault("ROBOBALL_CONFIG_DIR", os.path.abspath("configs"))
# matplotlib's font cache per environment, not the user's shared one: a cache written by another
# matplotlib can make the PDFs embed another DejaVu Sans file (same pixels, other bytes).
os.environ.setdefault("MPLCONFIGDIR", os.path.join(sys.prefix, "matplotlib-config"))
from roboball.checks import check_config_dir
from roboball.errors import RoboballError
try:
    check_config_dir(os.environ["ROBOBALL_CONFIG_DIR"], exclude=("config.yaml",))
except RoboballError as exc:
    raise WorkflowError(str(exc))

include: "workflow/rules/common.smk"
include: "workflow/rules/ingest.smk"
include: "workflow/rules/shell.smk"
include: "workflow/rules/ramp.smk"
include: "workflow/rules/figures.smk"
include: "workflow/rules/friction.smk"
include: "workflow/rules/beyond.smk"

report: "workflow/report/workflow.rst"


rule all:
    input:
        FIGURES,
