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


rule ramp_summary:
    input: expand("results/ramp/{contact}/{stem}.csv", contact=RAMP_CONTACTS, stem=RAMP)
    output: "results/ramp/summary.csv"
    params: code=CODE["summarise"]
    log: "results/logs/ramp_summary.log"
    shell: "{ROBOBALL} summarise --inputs {input} --out-csv {output} > {log} 2>&1"
