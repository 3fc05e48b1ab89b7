# Stage 5: the paper's figures and tables in paper_figures/ (PNG + PDF), in the paper's order:
# Table I (friction), Table II (robot facts), Fig. 5, 7, 8 (friction), Fig. 10, 11 (shell),
# Fig. 13, 14 (ramp), then the corner plots of every friction posterior.  (Fig. S1 is drawn by
# the deflating-ramp simulation itself, simulate.smk.)


rule table1:
    input:
        fits=fit_jsons(),
        comparison=[f"results/friction/{MAIN_FITS}/steer_comparison.csv"] if MAIN_FITS in STEER_COMPARED else [],
    output:
        csv=f"{PF}/table1_friction.csv",
        md=f"{PF}/table1_friction.md",
    params: code=CODE["table1"]
    log: "results/logs/table1.log"
    shell:
        "{ROBOBALL} table1 --fits {input.fits} --comparison-csv '{input.comparison}' "
        "--out-csv {output.csv} --out-md {output.md} > {log} 2>&1"


rule table2:
    input: robot=os.path.join(CONFIG_DIR, "robot.yaml")
    output:
        csv=f"{PF}/table2_robot.csv",
        md=f"{PF}/table2_robot.md",
    params: code=CODE["table2"]
    log: "results/logs/table2.log"
    shell: "{ROBOBALL} table2 --robot-yaml {input.robot} --out-csv {output.csv} --out-md {output.md} > {log} 2>&1"


rule fig5:
    input: fit_jsons(MAIN_FITS)
    output:
        png=report(f"{PF}/fig5_friction_laws.png", category="2 Friction", caption="../report/fig5.rst",
                   labels={"figure": "Fig. 5", "dataset": str(MAIN_FITS), "joint": "steer, drive", "law": "every law"}),
        pdf=f"{PF}/fig5_friction_laws.pdf",
    params: code=CODE["fig5"]
    log: "results/logs/fig5.log"
    shell: "{ROBOBALL} fig5 --fits {input} --out-png {output.png} > {log} 2>&1"


rule fig_stand:
    input:
        unpack(get_stand_recording),
        fits=get_stand_fits,
    output:
        png=report(f"{PF}/fig{{num}}_{{dataset}}_{{joint}}_fits.png", category="2 Friction", caption="../report/fig78.rst",
                   labels={"figure": "Fig. {num}", "dataset": "{dataset}", "joint": "{joint}", "law": "every law"}),
        pdf=f"{PF}/fig{{num}}_{{dataset}}_{{joint}}_fits.pdf",
    params:
        code=CODE["fig-stand-fits"],
        title=lambda w: f"Fig. {w.num}: {w.joint} stand ({w.dataset}): data and fitted friction simulated in Drake",
    wildcard_constraints: num="7|8", dataset="|".join(DATASETS), joint="steer|drive"
    log: "results/logs/fig{num}_{dataset}_{joint}.log"
    shell:
        "{ROBOBALL} fig-stand-fits --recording {input.csv} --releases {input.releases} --fits {input.fits} "
        "--title '{params.title}' --out-png {output.png} > {log} 2>&1"


rule fig10:
    input:
        points="results/identify/shell_points.csv",
        regression="results/identify/shell_regression.csv",
        sims="results/shell_sim/summary.csv",
    output:
        png=report(f"{PF}/fig10_shell_dynamics.png", category="3 Shell", caption="../report/fig10.rst",
                   labels={"figure": "Fig. 10: shell dynamics"}),
        pdf=f"{PF}/fig10_shell_dynamics.pdf",
    params: code=CODE["fig10"], campaign=SHELL_NAME
    log: "results/logs/fig10.log"
    shell:
        "{ROBOBALL} fig10 --points {input.points} --regression {input.regression} --sims {input.sims} "
        "--out-png {output.png} --campaign {params.campaign:q} > {log} 2>&1"


rule fig11:
    input:
        sweep="results/sweep/summary.csv",
        points="results/identify/shell_points.csv",
    output:
        png=report(f"{PF}/fig11_hydro_sensitivity.png", category="3 Shell", caption="../report/fig11.rst",
                   labels={"figure": "Fig. 11: hydroelastic sensitivity"}),
        pdf=f"{PF}/fig11_hydro_sensitivity.pdf",
        table=f"{PF}/table_sweep.csv",
        md=f"{PF}/table_sweep.md",
    params:
        code=CODE["fig11"],
        m=config["shell"]["carried_forward"]["modulus_scale"],
        d=config["shell"]["carried_forward"]["dissipation_scale"],
        campaign=SHELL_NAME,
    log: "results/logs/fig11.log"
    shell:
        "{ROBOBALL} fig11 --sweep {input.sweep} --points {input.points} --out-png {output.png} "
        "--out-table {output.table} --out-md {output.md} --carried-modulus {params.m} --carried-dissipation {params.d} "
        "--campaign {params.campaign:q} > {log} 2>&1"


rule fig13_14:
    input: "results/ramp/summary.csv"
    output:
        fig13=report(f"{PF}/fig13_ramp_pme.png", category="4 Ramp", caption="../report/fig13.rst",
                     labels={"figure": "Fig. 13: PME by pressure"}),
        fig14=report(f"{PF}/fig14_ramp_pme_mean.png", category="4 Ramp", caption="../report/fig14.rst",
                     labels={"figure": "Fig. 14: PME over all pressures"}),
        pdfs=[f"{PF}/fig13_ramp_pme.pdf", f"{PF}/fig14_ramp_pme_mean.pdf"],
        csv=f"{PF}/table_pme.csv",
        md=f"{PF}/table_pme.md",
    params:
        code=CODE["fig13-14"],
        campaign=RAMP_NAME,
        hydro=lambda w: " ".join(f"{k.split('_')[0]} x{v:g}" for k, v in config["shell"]["carried_forward"].items()
                                 if v != 1.0) or "eq. 10-11",
    log: "results/logs/fig13_14.log"
    shell:
        "{ROBOBALL} fig13-14 --summary {input} --out13 {output.fig13} --out14 {output.fig14} "
        "--out-csv {output.csv} --out-md {output.md} --campaign {params.campaign:q} "
        "--hydro-setting {params.hydro:q} > {log} 2>&1"


# Beyond the paper (issue 25): the hydroelastic calibration, its Drake grid, the contact-volume
# law V(p) through the fitted moduli and the authors' values.
rule figS3_hydro_calibration:
    input:
        table=HYDRO_TUNED,
        law="results/identify/hydro_volume_law.csv",
        grid=expand("results/hydro/grid/{col}.csv", col=list(HYDRO_GRID)),
        regression="results/identify/shell_regression.csv",
    output:
        png=report(f"{PF}/figS3_hydro_calibration.png", category="6 Beyond the paper", caption="../report/figS3.rst",
                   labels={"figure": "Fig. S3: hydroelastic calibration"}),
        pdf=f"{PF}/figS3_hydro_calibration.pdf",
        md=f"{PF}/table_hydro_tuned.md",
        csv=f"{PF}/table_hydro_tuned.csv",
    params:
        code=CODE["figs2"],
        authors=json.dumps(config["shell"].get("authors_hydro", [])),
        campaign=SHELL_NAME,
    log: "results/logs/figS3_hydro_calibration.log"
    shell:
        "{ROBOBALL} figs2 --table {input.table} --law {input.law} --grid-csvs {input.grid} "
        "--regression {input.regression} --authors-json '{params.authors}' --campaign {params.campaign:q} "
        "--out-png {output.png} --out-md {output.md} --out-csv {output.csv} > {log} 2>&1"


rule corner:
    input: "results/friction/{dataset}/{joint}_{law}.json"
    output:
        png=report(f"{PF}/corner/corner_{{dataset}}_{{joint}}_{{law}}.png", category="2 Friction", caption="../report/corner.rst",
                   labels={"figure": "corner plot", "dataset": "{dataset}", "joint": "{joint}", "law": "{law}"}),
        pdf=f"{PF}/corner/corner_{{dataset}}_{{joint}}_{{law}}.pdf",
    params: code=CODE["corner-plot"]
    wildcard_constraints: dataset="|".join(DATASETS), joint="steer|drive", law="viscous|coulomb_viscous|majd"
    log: "results/logs/corner/{dataset}_{joint}_{law}.log"
    shell: "{ROBOBALL} corner-plot --fit {input} --out-png {output.png} > {log} 2>&1"
