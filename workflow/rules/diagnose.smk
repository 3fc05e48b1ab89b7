# Stage 4, beyond the paper (issue 6): `roboball diagnose` on the ramp runs, against the paper's
# point model as this pipeline calibrates it (point contact, the Majd friction fitted on the stand
# logs), and the diagnosed model as a fourth contact model, scored out of sample.  A ramp run holds
# one descent, so the runs at one pressure are diagnosed together, each a release of the pooled
# fit whose held-out test leaves one whole run out: `diagnose_ramp_pressure` (all runs at a
# pressure, for the report) and `diagnose_ramp_heldout` (all but one run, whose effects score that
# run in `ramp_diagnosed`).  The real logs are diagnosed one by one against the contract's
# baselines (`diagnose`).


rule diagnose:
    input:
        csv="results/ingest/{stem}.csv",
        sidecar="results/ingest/{stem}.json",
    output:
        json="results/diagnose/{stem}/diagnosis.json",
        predictions="results/diagnose/{stem}/predictions.csv",
        report="results/diagnose/{stem}/report.md",
        details="results/diagnose/{stem}/details.json",
        figures=expand("results/diagnose/{{stem}}/{name}.png", name=("overlay", "regimes", "windows")),
    params:
        code=CODE["diagnose-recording"],
        steer=lambda w: REC[w.stem].get("steer_joint", ""),
    wildcard_constraints: stem="[^/]+"
    log: "results/logs/diagnose/{stem}.log"
    benchmark: "results/benchmarks/diagnose/{stem}.tsv"
    shell:
        "{ROBOBALL} diagnose-recording --recording {input.csv} --steer-joint '{params.steer}' "
        "--out-dir results/diagnose/{wildcards.stem} > {log} 2>&1"


rule diagnose_ramp_pressure:
    input:
        unpack(get_runs_at_pressure),
        **RAMP_FRICTION,
    output:
        json="results/diagnose/pressure/{group}/diagnosis.json",
        predictions="results/diagnose/pressure/{group}/predictions.csv",
        report="results/diagnose/pressure/{group}/report.md",
        details="results/diagnose/pressure/{group}/details.json",
        figures=expand("results/diagnose/pressure/{{group}}/{name}.png", name=("overlay", "regimes", "windows")),
    params: code=CODE["diagnose-recording"], friction=get_ramp_friction_args
    log: "results/logs/diagnose/pressure/{group}.log"
    benchmark: "results/benchmarks/diagnose/pressure/{group}.tsv"
    shell:
        "{ROBOBALL} diagnose-recording --recording {input.csv} {params.friction} --out-dir results/diagnose/pressure/{wildcards.group} > {log} 2>&1"


rule diagnose_ramp_heldout:
    input:
        unpack(get_other_runs),
        **RAMP_FRICTION,
    output:
        json="results/diagnose/heldout/{stem}/diagnosis.json",
        predictions="results/diagnose/heldout/{stem}/predictions.csv",
        report="results/diagnose/heldout/{stem}/report.md",
        details="results/diagnose/heldout/{stem}/details.json",
        figures=expand("results/diagnose/heldout/{{stem}}/{name}.png", name=("overlay", "regimes", "windows")),
    params: code=CODE["diagnose-recording"], friction=get_ramp_friction_args
    log: "results/logs/diagnose/heldout/{stem}.log"
    benchmark: "results/benchmarks/diagnose/heldout/{stem}.tsv"
    shell:
        "{ROBOBALL} diagnose-recording --recording {input.csv} {params.friction} --out-dir results/diagnose/heldout/{wildcards.stem} > {log} 2>&1"


# Every run's descent with the diagnosed model, in one job (a few seconds each; roboball stage
# NAME --each): each run takes its effects from the diagnosis of the other runs at its pressure.
if RAMP:
    rule ramp_diagnosed:
        input:
            csv=expand("results/ingest/{stem}.csv", stem=RAMP),
            releases=expand("results/ingest/{stem}.releases.json", stem=RAMP),
            diagnoses=expand("results/diagnose/heldout/{stem}/diagnosis.json", stem=RAMP),
        output:
            pme=expand("results/ramp/diagnosed/{stem}.csv", stem=RAMP),
            trace=expand("results/ramp/diagnosed/{stem}.trace.csv", stem=RAMP),
        params:
            code=CODE["ramp-diagnosed"],
            each=get_ramp_diagnosed_each,
        log: "results/logs/ramp/diagnosed.log"
        benchmark: "results/benchmarks/ramp/diagnosed.tsv"
        shell: "{ROBOBALL} ramp-diagnosed --each {params.each:q} > {log} 2>&1"
