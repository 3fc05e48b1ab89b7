# roboball: raw logs -> releases and decay -> regressions -> friction posteriors ->
# Drake simulations of every contact model and the sweep -> paper_figures/.
# Rules are thin: each calls one stage of the roboball package (`roboball stage NAME`).
# The configs are checked, and the campaign planned, in workflow/rules/common.smk before any rule
# is defined; the rule files follow in pipeline order, and `rule all` asks common.smk for the
# targets, so no rule file depends on another's definitions.

import os

# beside this Snakefile, wherever the run's outputs go (make figures OUT=DIR runs Snakemake in DIR)
configfile: os.path.join(workflow.basedir, "configs", "config.yaml")


include: "workflow/rules/common.smk"
include: "workflow/rules/ingest.smk"
include: "workflow/rules/identify.smk"
include: "workflow/rules/simulate.smk"
include: "workflow/rules/diagnose.smk"
include: "workflow/rules/figures.smk"
include: "workflow/rules/report.smk"


rule all:
    input:
        final_targets(),
