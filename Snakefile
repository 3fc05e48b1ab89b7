# roboball: raw logs -> releases and decay -> regressions -> friction posteriors ->
# Drake simulations of every contact model and the sweep -> paper_figures/.
# Rules are thin: each calls one stage of the roboball package (`roboball stage NAME`).
from snakemake.utils import validate

configfile: "configs/config.yaml"
validate(config, "configs/schema/config.schema.yaml")

include: "workflow/rules/common.smk"
include: "workflow/rules/ingest.smk"
include: "workflow/rules/shell.smk"
# friction.smk: added with the friction fits
include: "workflow/rules/ramp.smk"
include: "workflow/rules/figures.smk"

report: "workflow/report/workflow.rst"


rule all:
    input:
        FIGURES,
