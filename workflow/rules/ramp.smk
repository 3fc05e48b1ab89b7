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
        seed=lambda w: config["seed"] + RAMP.index(w.stem),
    wildcard_constraints: contact="point|injected|hydroelastic"
    log: "results/logs/ramp/{contact}/{stem}.log"
    benchmark: "results/benchmarks/ramp/{contact}/{stem}.tsv"
    shell:
        "{ROBOBALL} ramp-sim --recording {input.csv} --releases {input.releases} --regression {input.regression} "
        "--contact {wildcards.contact} --friction-steer {input.steer} --friction-drive {input.drive} "
        "--modulus-scale {params.scales[0]} --dissipation-scale {params.scales[1]} --dt {params.dt} "
        "--posterior-draws {params.draws} --seed {params.seed} --out-csv {output.pme} --out-trace {output.trace} > {log} 2>&1"


# Beyond the paper (issue 6): `roboball diagnose` on every ramp run (and on the real logs, see
# friction.smk's report), and the diagnosed model as a fourth contact model, scored out of sample:
# each run's effects come from the diagnoses of the other runs at its pressure.
rule diagnose:
    input:
        csv="results/ingest/{stem}.csv",
        sidecar="results/ingest/{stem}.json",
    output:
        json="results/diagnose/{stem}/diagnosis.json",
        predictions="results/diagnose/{stem}/predictions.csv",
        report="results/diagnose/{stem}/report.md",
    params: code=CODE["diagnose-recording"]
    log: "results/logs/diagnose/{stem}.log"
    benchmark: "results/benchmarks/diagnose/{stem}.tsv"
    shell: "{ROBOBALL} diagnose-recording --recording {input.csv} --out-dir results/diagnose/{wildcards.stem} > {log} 2>&1"


def other_runs(stem):
    """The other ramp runs at the same pressure (all runs at it when there is only this one)."""
    same = [s for s in RAMP if REC[s]["pressure_kpa"] == REC[stem]["pressure_kpa"]]
    return [s for s in same if s != stem] or same


rule ramp_diagnosed:
    input:
        csv="results/ingest/{stem}.csv",
        releases="results/ingest/{stem}.releases.json",
        diagnoses=lambda w: [f"results/diagnose/{s}/diagnosis.json" for s in other_runs(w.stem)],
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
