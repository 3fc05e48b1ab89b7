# Stage 5: paper figures and tables in paper_figures/ (PNG + PDF).
PF = "paper_figures"
FIGURES = [
    f"{PF}/fig10_shell_dynamics.png", f"{PF}/fig11_hydro_sensitivity.png",
    f"{PF}/fig13_ramp_pme.png", f"{PF}/fig14_ramp_pme_mean.png",
    f"{PF}/table_pme.csv", f"{PF}/table_pme.md", f"{PF}/table_sweep.md", f"{PF}/table2_robot.md",
]


rule table2:
    input: robot=os.path.join(os.environ["ROBOBALL_CONFIG_DIR"], "robot.yaml")
    output:
        csv=f"{PF}/table2_robot.csv",
        md=f"{PF}/table2_robot.md",
    params: code=CODE["table2"]
    log: "results/logs/table2.log"
    shell: "{ROBOBALL} table2 --robot-yaml {input.robot} --out-csv {output.csv} --out-md {output.md} > {log} 2>&1"


rule fig10:
    input:
        points="results/identify/shell_points.csv",
        regression="results/identify/shell_regression.csv",
        sims="results/shell_sim/summary.csv",
    output:
        png=report(f"{PF}/fig10_shell_dynamics.png", category="3 Shell", caption="../report/fig10.rst"),
        pdf=f"{PF}/fig10_shell_dynamics.pdf",
    params: code=CODE["fig10"], campaign=config.get("campaign", "")
    log: "results/logs/fig10.log"
    shell:
        "{ROBOBALL} fig10 --points {input.points} --regression {input.regression} --sims {input.sims} "
        "--out-png {output.png} --campaign {params.campaign:q} > {log} 2>&1"


rule fig11:
    input:
        sweep="results/sweep/summary.csv",
        points="results/identify/shell_points.csv",
    output:
        png=report(f"{PF}/fig11_hydro_sensitivity.png", category="3 Shell", caption="../report/fig11.rst"),
        pdf=f"{PF}/fig11_hydro_sensitivity.pdf",
        table=f"{PF}/table_sweep.csv",
        md=f"{PF}/table_sweep.md",
    params:
        code=CODE["fig11"],
        m=config["shell"]["carried_forward"]["modulus_scale"],
        d=config["shell"]["carried_forward"]["dissipation_scale"],
        campaign=config.get("campaign", ""),
    log: "results/logs/fig11.log"
    shell:
        "{ROBOBALL} fig11 --sweep {input.sweep} --points {input.points} --out-png {output.png} "
        "--out-table {output.table} --out-md {output.md} --carried-modulus {params.m} --carried-dissipation {params.d} "
        "--campaign {params.campaign:q} > {log} 2>&1"


rule fig13_14:
    input: "results/ramp/summary.csv"
    output:
        fig13=report(f"{PF}/fig13_ramp_pme.png", category="4 Ramp", caption="../report/fig13.rst"),
        fig14=report(f"{PF}/fig14_ramp_pme_mean.png", category="4 Ramp", caption="../report/fig14.rst"),
        pdfs=[f"{PF}/fig13_ramp_pme.pdf", f"{PF}/fig14_ramp_pme_mean.pdf"],
        csv=f"{PF}/table_pme.csv",
        md=f"{PF}/table_pme.md",
    params: code=CODE["fig13-14"], campaign=config.get("campaign", "")
    log: "results/logs/fig13_14.log"
    shell:
        "{ROBOBALL} fig13-14 --summary {input} --out13 {output.fig13} --out14 {output.fig14} "
        "--out-csv {output.csv} --out-md {output.md} --campaign {params.campaign:q} > {log} 2>&1"


rule replay:
    input: regression="results/identify/shell_regression.csv"
    output: report("results/replays/{scenario}.html", category="5 Replays", caption="../report/replay.rst")
    params:
        code=CODE["replay"],
        contact=lambda w: REPLAYS[w.scenario][0],
        release=lambda w: REPLAYS[w.scenario][1],
        d=config["shell"]["carried_forward"]["dissipation_scale"],
    log: "results/logs/replay/{scenario}.log"
    benchmark: "results/benchmarks/replay/{scenario}.tsv"
    shell:
        "{ROBOBALL} replay --kind {wildcards.scenario} --contact {params.contact} --regression {input.regression} "
        "--release {params.release} --dissipation-scale {params.d} --out-html {output} > {log} 2>&1"


FIGURES += [f"results/replays/{s}.html" for s in REPLAYS]
