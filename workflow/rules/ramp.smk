# Stage 4: ramp descents of every contact model for every recorded run, scored by PME (eq. 12),
# with the friction posteriors propagated through the simulations.

rule ramp_sim:
    input:
        csv="results/ingest/{stem}.csv",
        releases="results/ingest/{stem}.releases.json",
        regression="results/identify/shell_regression.csv",
        steer="results/friction/testbed/steer_majd.json",
        drive="results/friction/testbed/drive_majd.json",
    output:
        pme="results/ramp/{contact}/{stem}.csv",
        trace="results/ramp/{contact}/{stem}.trace.csv",
    params:
        code=CODE["ramp-sim"],
        scales=lambda w: (config["shell"]["carried_forward"]["modulus_scale"],
                          config["shell"]["carried_forward"]["dissipation_scale"]) if w.contact == "hydroelastic" else (1.0, 1.0),
        dt=config["ramp"]["dt_s"],
        draws=config["ramp"]["posterior_draws"],
        seed=config["seed"],
    wildcard_constraints: contact="point|injected|hydroelastic"
    log: "results/logs/ramp/{contact}/{stem}.log"
    benchmark: "results/benchmarks/ramp/{contact}/{stem}.tsv"
    shell:
        "{ROBOBALL} ramp-sim --recording {input.csv} --releases {input.releases} --regression {input.regression} "
        "--contact {wildcards.contact} --friction-steer {input.steer} --friction-drive {input.drive} "
        "--modulus-scale {params.scales[0]} --dissipation-scale {params.scales[1]} --dt {params.dt} "
        "--posterior-draws {params.draws} --seed {params.seed} --out-csv {output.pme} --out-trace {output.trace} > {log} 2>&1"


# Beyond the paper (issue 6): `roboball diagnose` on the ramp runs, against the paper's point model
# as this pipeline calibrates it (point contact, the Majd friction fitted on the stand logs), and
# the diagnosed model as a fourth contact model, scored out of sample.  A ramp run holds one
# descent, so the runs at one pressure are diagnosed together, each a release of the pooled fit
# whose held-out test leaves one whole run out: `diagnose_ramp_pressure` (all runs at a pressure,
# for the report) and `diagnose_ramp_heldout` (all but one run, whose effects score that run).
# The real logs are diagnosed one by one against the contract's baselines (`diagnose`).
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
    params: code=CODE["diagnose-recording"]
    wildcard_constraints: stem="[^/]+"
    log: "results/logs/diagnose/{stem}.log"
    benchmark: "results/benchmarks/diagnose/{stem}.tsv"
    shell: "{ROBOBALL} diagnose-recording --recording {input.csv} --out-dir results/diagnose/{wildcards.stem} > {log} 2>&1"


RAMP_GROUPS = CAMPAIGN.ramp_groups()
runs_at, other_runs = CAMPAIGN.runs_at, CAMPAIGN.other_runs


RAMP_FRICTION = {"steer": "results/friction/testbed/steer_majd.json", "drive": "results/friction/testbed/drive_majd.json"}


rule diagnose_ramp_pressure:
    input:
        csv=lambda w: [f"results/ingest/{s}.csv" for s in runs_at(w.group)],
        sidecars=lambda w: [f"results/ingest/{s}.json" for s in runs_at(w.group)],
        **RAMP_FRICTION,
    output:
        json="results/diagnose/pressure/{group}/diagnosis.json",
        predictions="results/diagnose/pressure/{group}/predictions.csv",
        report="results/diagnose/pressure/{group}/report.md",
        details="results/diagnose/pressure/{group}/details.json",
        figures=expand("results/diagnose/pressure/{{group}}/{name}.png", name=("overlay", "regimes", "windows")),
    params: code=CODE["diagnose-recording"]
    log: "results/logs/diagnose/pressure/{group}.log"
    benchmark: "results/benchmarks/diagnose/pressure/{group}.tsv"
    shell:
        "{ROBOBALL} diagnose-recording --recording {input.csv} --friction-steer {input.steer} "
        "--friction-drive {input.drive} --out-dir results/diagnose/pressure/{wildcards.group} > {log} 2>&1"


rule diagnose_ramp_heldout:
    input:
        csv=lambda w: [f"results/ingest/{s}.csv" for s in other_runs(w.stem)],
        sidecars=lambda w: [f"results/ingest/{s}.json" for s in other_runs(w.stem)],
        **RAMP_FRICTION,
    output:
        json="results/diagnose/heldout/{stem}/diagnosis.json",
        predictions="results/diagnose/heldout/{stem}/predictions.csv",
        report="results/diagnose/heldout/{stem}/report.md",
        details="results/diagnose/heldout/{stem}/details.json",
        figures=expand("results/diagnose/heldout/{{stem}}/{name}.png", name=("overlay", "regimes", "windows")),
    params: code=CODE["diagnose-recording"]
    log: "results/logs/diagnose/heldout/{stem}.log"
    benchmark: "results/benchmarks/diagnose/heldout/{stem}.tsv"
    shell:
        "{ROBOBALL} diagnose-recording --recording {input.csv} --friction-steer {input.steer} "
        "--friction-drive {input.drive} --out-dir results/diagnose/heldout/{wildcards.stem} > {log} 2>&1"


rule ramp_diagnosed:
    input:
        csv="results/ingest/{stem}.csv",
        releases="results/ingest/{stem}.releases.json",
        diagnoses="results/diagnose/heldout/{stem}/diagnosis.json",
    output:
        pme="results/ramp/diagnosed/{stem}.csv",
        trace="results/ramp/diagnosed/{stem}.trace.csv",
    params:
        code=CODE["ramp-diagnosed"],
        dt=config["ramp"]["dt_s"],
    log: "results/logs/ramp/diagnosed/{stem}.log"
    benchmark: "results/benchmarks/ramp/diagnosed/{stem}.tsv"
    shell:
        "{ROBOBALL} ramp-diagnosed --recording {input.csv} --releases {input.releases} --diagnoses {input.diagnoses} "
        "--dt {params.dt} --out-csv {output.pme} --out-trace {output.trace} > {log} 2>&1"


rule ramp_summary:
    input:
        expand("results/ramp/{contact}/{stem}.csv", contact=RAMP_CONTACTS, stem=RAMP),
        expand("results/ramp/diagnosed/{stem}.csv", stem=RAMP),
    output: "results/ramp/summary.csv"
    params: code=CODE["summarise"]
    log: "results/logs/ramp_summary.log"
    shell: "{ROBOBALL} summarise --inputs {input} --out-csv {output} > {log} 2>&1"
