# Stage 6: the reports.  The parameter-uncertainty report (HTML beside the paper figures) and the
# Snakemake report's front page; each figure rule tags its own output for the Snakemake report
# (`report(...)`, one caption per result in workflow/report/).

report: "../report/workflow.rst"


rule uncertainty_report:
    input:
        fits=fit_jsons(),
        comparisons=friction_comparisons(),
        regression=[REGRESSION_CSV] if REGRESSION else [],
        pme=[f"{PF}/table_pme.csv"] if RAMP else [],
        sweep=[f"{PF}/table_sweep.md"] if REGRESSION else [],
        diagnoses=diagnosis_files("diagnosis.json"),
        # read beside each diagnosis.json: the candidates supported by the data but below materiality
        details=diagnosis_files("details.json"),
        figures=report_figures(),
        # the posteriors the ramp simulations draw friction from: the PME recommendation rests on them
        ramp_friction=list(RAMP_FRICTION.values()),
    output:
        report(f"{PF}/uncertainty_report.html", category="0 Report", caption="../report/uncertainty.rst",
               labels={"report": "parameter uncertainty"})
    params: code=CODE["uncertainty-report"]
    log: "results/logs/uncertainty_report.log"
    shell:
        "{ROBOBALL} uncertainty-report --fits {input.fits} --comparisons {input.comparisons} "
        "--regression '{input.regression}' --pme-table '{input.pme}' --sweep-md '{input.sweep}' "
        "--figures {input.figures} --diagnoses {input.diagnoses} --ramp-friction {input.ramp_friction} --out-html {output} > {log} 2>&1"


# The paper's tables as pages of the Snakemake report (the Markdown beside the CSV, rendered).
rule table_page:
    input: f"{PF}/{{table}}.md"
    output:
        report("results/report/{table}.html", category="7 Tables", caption="../report/tables.rst",
               labels=lambda w: {"table": TABLE_NAMES[w.table]})
    params: code=CODE["table-page"]
    wildcard_constraints: table="|".join(TABLE_NAMES)
    log: "results/logs/table_page/{table}.log"
    shell: "{ROBOBALL} table-page --md {input} --out-html {output} > {log} 2>&1"
