# Stage 4, beyond the paper (issue 6): `roboball diagnose` on the ramp runs, against the paper's
# point model as this pipeline calibrates it (point contact, the Majd friction fitted on the stand
# logs), and the diagnosed model as a fourth contact model, scored out of sample.  A ramp run holds
# one descent, so the runs at one pressure are diagnosed together, each a release of the pooled
# fit whose held-out test leaves one whole run out: at each pressure all its runs (for the report,
# results/diagnose/pressure/) and, for each run, all but that run (results/diagnose/heldout/,
# whose effects score that run in `ramp_diagnosed`); rule `diagnose_ramp` makes them all.  The
# real logs are diagnosed one by one against the contract's baselines (`diagnose`).


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


# Every ramp diagnosis in one job (roboball stage NAME --each): each takes 2-3 s, about what a
# process's start-up and the compiled loops' loading cost, and the pooled and held-out diagnoses
# read the same runs.  An edited run reruns all of them (about a minute), as it reruns every ramp_sim.
if RAMP:
    rule diagnose_ramp:
        input:
            **_ingested(RAMP),
            **RAMP_FRICTION,
        output: [f"{d}/{name}" for d in RAMP_DIAGNOSES for name in DIAGNOSIS_FILES]
        params: code=CODE["diagnose-recording"], each=get_diagnose_ramp_each
        log: "results/logs/diagnose/ramp.log"
        benchmark: "results/benchmarks/diagnose/ramp.tsv"
        shell: "{ROBOBALL} diagnose-recording --each {params.each:q} > {log} 2>&1"


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
