# roboball: raw logs -> releases and decay -> regressions -> friction posteriors ->
# Drake simulations of every contact model and the sweep -> paper_figures/.
# Rules are thin: each calls one stage of the roboball package (`roboball stage NAME`).
from snakemake.utils import validate

configfile: "configs/config.yaml"
validate(config, "configs/schema/config.schema.yaml")
from roboball.config import first_nonfinite   # JSON Schema's bounds cannot refuse NaN
if first_nonfinite(config):
    raise WorkflowError("configs/config.yaml: field '{}': {} is not a finite number".format(*first_nonfinite(config)))

# The robot facts (and every other configs/*.yaml with a schema, e.g. the friction priors) are
# checked before any job runs; every stage then reads this workflow's configs/ folder.
import os
import sys
os.environ.setdefault("ROBOBALL_CONFIG_DIR", os.path.abspath("configs"))
# matplotlib's configuration and font cache per environment, not the user's shared ones: a cache
# written by another matplotlib can make the PDFs embed another DejaVu Sans file (same pixels,
# other bytes), and a personal matplotlibrc would restyle the figures.  In the environment when it
# is writable, else beside the results.
_mpl = os.path.join(sys.prefix, "matplotlib-config")
if not (os.access(sys.prefix, os.W_OK) or os.path.isdir(_mpl)):
    _mpl = os.path.abspath(os.path.join("results", ".matplotlib-config"))
os.environ["MPLCONFIGDIR"] = _mpl
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
