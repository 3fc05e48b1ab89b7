# Stage 2: shell identification (Fig. 10 data) and shell simulations of each contact model,
# plus the hydroelastic sensitivity sweep (section III-D, Fig. 11).

rule shell_regression:
    input: expand("results/decay/{stem}.csv", stem=SHELL)
    output:
        points="results/identify/shell_points.csv",
        table="results/identify/shell_regression.csv",
    params: code=CODE["shell-regression"]
    log: "results/logs/shell_regression.log"
    benchmark: "results/benchmarks/shell_regression.tsv"
    shell:
        "{ROBOBALL} shell-regression --decay-csvs {input} --out-points {output.points} "
        "--out-table {output.table} > {log} 2>&1"


rule shell_sim:
    input:
        releases="results/ingest/{stem}.releases.json",
        regression="results/identify/shell_regression.csv",
    output: "results/shell_sim/{contact}/{stem}.csv"
    params:
        code=CODE["shell-sim"],
        duration=config["shell"]["sim_duration_s"],
        dt=config["shell"]["dt_s"],
    wildcard_constraints: contact="point|injected|hydroelastic"
    log: "results/logs/shell_sim/{contact}/{stem}.log"
    benchmark: "results/benchmarks/shell_sim/{contact}/{stem}.tsv"
    shell:
        "{ROBOBALL} shell-sim --releases {input.releases} --regression {input.regression} --contact {wildcards.contact} "
        "--duration {params.duration} --dt {params.dt} --out-csv {output} > {log} 2>&1"


rule sweep_sim:
    input:
        releases="results/ingest/{stem}.releases.json",
        regression="results/identify/shell_regression.csv",
    output: "results/sweep/{case}/{stem}.csv"
    params:
        code=CODE["shell-sim"],
        scales=lambda w: SWEEP[w.case],
        duration=config["shell"]["sim_duration_s"],
        dt=config["shell"]["dt_s"],
    log: "results/logs/sweep/{case}/{stem}.log"
    benchmark: "results/benchmarks/sweep/{case}/{stem}.tsv"
    shell:
        "{ROBOBALL} shell-sim --releases {input.releases} --regression {input.regression} --contact hydroelastic "
        "--modulus-scale {params.scales[0]} --dissipation-scale {params.scales[1]} "
        "--duration {params.duration} --dt {params.dt} --out-csv {output} > {log} 2>&1"


rule shell_summary:
    input:
        sims=expand("results/shell_sim/{contact}/{stem}.csv", contact=CONTACTS, stem=SHELL),
    output: "results/shell_sim/summary.csv"
    params: code=CODE["summarise"]
    log: "results/logs/shell_summary.log"
    shell: "{ROBOBALL} summarise --inputs {input.sims} --out-csv {output} > {log} 2>&1"


rule sweep_summary:
    input:
        expand("results/shell_sim/hydroelastic/{stem}.csv", stem=SHELL),
        expand("results/sweep/{case}/{stem}.csv", case=list(SWEEP), stem=SHELL),
    output: "results/sweep/summary.csv"
    params: code=CODE["summarise"]
    log: "results/logs/sweep_summary.log"
    shell: "{ROBOBALL} summarise --inputs {input} --out-csv {output} > {log} 2>&1"
