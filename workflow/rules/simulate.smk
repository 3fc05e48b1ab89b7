# Stage 3: Drake simulations.  The shell released like each recording under every contact model,
# with the hydroelastic sensitivity sweep (section III-D, Fig. 11); ramp descents of every contact
# model for every recorded run, scored by PME (eq. 12), with the friction posteriors propagated
# through the simulations; the interactive replays; and, beyond the paper (issue 9, Fig. S1), a
# ramp descent while the shell deflates (roboball.sim.schedule_run; config section deflating_ramp);
# and (issue 27, Fig. S2) the coupled steer test of the real repeats against every shell model.


# The shell and ramp simulations run a second or a few each: one job per contact model (sweep
# case) runs all recordings, so that Python, pandas and Drake start once per model, not per run
# (roboball stage NAME --each; the items are the per-recording calls, unchanged).
if SHELL:
    rule shell_sim:
        input:
            releases=expand("results/ingest/{stem}.releases.json", stem=SHELL),
            regression="results/identify/shell_regression.csv",
            hydro_fit=get_hydro_fit,
        output: expand("results/shell_sim/{{contact}}/{stem}.csv", stem=SHELL)
        params:
            code=CODE["shell-sim"],
            each=get_shell_sim_each,
        wildcard_constraints: contact="point|injected|hydroelastic|hydro_tuned"
        log: "results/logs/shell_sim/{contact}.log"
        benchmark: "results/benchmarks/shell_sim/{contact}.tsv"
        shell: "{ROBOBALL} shell-sim --each {params.each:q} > {log} 2>&1"


    rule sweep_sim:
        input:
            releases=expand("results/ingest/{stem}.releases.json", stem=SHELL),
            regression="results/identify/shell_regression.csv",
        output: expand("results/sweep/{{case}}/{stem}.csv", stem=SHELL)
        params:
            code=CODE["shell-sim"],
            each=get_sweep_sim_each,
        log: "results/logs/sweep/{case}.log"
        benchmark: "results/benchmarks/sweep/{case}.tsv"
        shell: "{ROBOBALL} shell-sim --each {params.each:q} > {log} 2>&1"


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


if RAMP:
    rule ramp_sim:
        input:
            csv=expand("results/ingest/{stem}.csv", stem=RAMP),
            releases=expand("results/ingest/{stem}.releases.json", stem=RAMP),
            regression=[REGRESSION_CSV] if REGRESSION else [],
            hydro_fit=get_hydro_fit,
            **RAMP_FRICTION,
        output:
            pme=expand("results/ramp/{{contact}}/{stem}.csv", stem=RAMP),
            trace=expand("results/ramp/{{contact}}/{stem}.trace.csv", stem=RAMP),
        params:
            code=CODE["ramp-sim"],
            each=get_ramp_sim_each,
        wildcard_constraints: contact="point|injected|hydroelastic|hydro_tuned"
        log: "results/logs/ramp/{contact}.log"
        benchmark: "results/benchmarks/ramp/{contact}.tsv"
        shell: "{ROBOBALL} ramp-sim --each {params.each:q} > {log} 2>&1"


# The paper's three contact models, the tuned hydroelastic one and the diagnosed model
# (diagnose.smk), side by side.
rule ramp_summary:
    input:
        expand("results/ramp/{contact}/{stem}.csv", contact=RAMP_CONTACTS, stem=RAMP),
        expand("results/ramp/diagnosed/{stem}.csv", stem=RAMP),
    output: "results/ramp/summary.csv"
    params: code=CODE["summarise"]
    log: "results/logs/ramp_summary.log"
    shell: "{ROBOBALL} summarise --inputs {input} --out-csv {output} > {log} 2>&1"


rule replay:
    input: regression="results/identify/shell_regression.csv"
    output:
        html="results/replays/{scenario}.html",
        scene="results/replays/{scenario}.scene.json",
    params:
        code=CODE["replay"],
        contact=lambda w: REPLAYS[w.scenario][0],
        release=lambda w: REPLAYS[w.scenario][1],
        d=config["shell"]["carried_forward"]["dissipation_scale"],
        length=config["ramp"].get("replay_length_m", 2.0),
    log: "results/logs/replay/{scenario}.log"
    benchmark: "results/benchmarks/replay/{scenario}.tsv"
    shell:
        "{ROBOBALL} replay --kind {wildcards.scenario} --contact {params.contact} --regression {input.regression} "
        "--release {params.release} --dissipation-scale {params.d} --ramp-length-m {params.length} "
        "--out-html {output.html} --out-scene {output.scene} > {log} 2>&1"


# Meshcat's viewer code, once: every replay page in results/replays/ loads it.
rule replay_viewer:
    output: "results/replays/meshcat.js"
    params: code=CODE["replay-viewer"]
    log: "results/logs/replay/viewer.log"
    shell: "{ROBOBALL} replay-viewer --out-js {output} > {log} 2>&1"


# Every replay in one self-contained page (the viewer compressed once): the Snakemake report
# embeds results as data URIs, which Chromium opens only under 2 MiB.
rule replay_gallery:
    input:
        # the ramp first: it is the experiment the paper scores
        scenes=expand("results/replays/{scenario}.scene.json", scenario=sorted(REPLAYS, key=lambda s: s != "ramp")),
        viewer="results/replays/meshcat.js",
    output:
        report("results/replays/index.html", category="5 Replays", caption="../report/replay.rst",
               labels={"replays": "every kind: stands, shell rock, ramp"})
    params: code=CODE["replay-gallery"]
    log: "results/logs/replay/gallery.log"
    shell: "{ROBOBALL} replay-gallery --scenes {input.scenes} --viewer {input.viewer} --out-html {output} > {log} 2>&1"


rule figS1_deflating_ramp:
    input:
        regression="results/identify/shell_regression.csv",
        schedule=[DEFLATE_SCHEDULE["csv"]] if "csv" in DEFLATE_SCHEDULE else [],
    output:
        png=report(f"{PF}/figS1_deflating_ramp.png", category="6 Beyond the paper", caption="../report/figS1.rst",
                   labels={"figure": "Fig. S1: deflating ramp"}),
        pdf=f"{PF}/figS1_deflating_ramp.pdf",
        csv="results/deflating/figS1_traces.csv",
    params:
        code=CODE["deflating-ramp"],
        schedule=schedule_args(DEFLATE_SCHEDULE),
        duration=DEFLATE.get("duration_s", 3.0),
        contacts=" ".join(DEFLATE.get("contact_models", ["injected", "hydroelastic"])),
        geometry=DEFLATE.get("injected_geometry", "planar"),
        hydro_update=DEFLATE.get("hydro_update_s", 0.05),
        d=config["shell"]["carried_forward"]["dissipation_scale"],
        m=config["shell"]["carried_forward"]["modulus_scale"],
        dt=config["ramp"]["dt_s"],
    resources:
        mem_mb=2000,
        runtime=15,
        cpus_per_task=1,
    log: "results/logs/figS1_deflating_ramp.log"
    benchmark: "results/benchmarks/figS1_deflating_ramp.tsv"
    shell:
        "{ROBOBALL} deflating-ramp --regression {input.regression} {params.schedule} --duration {params.duration} "
        "--contacts {params.contacts} --geometry {params.geometry} --hydro-update-s {params.hydro_update} "
        "--dissipation-scale {params.d} --modulus-scale {params.m} --dt {params.dt} "
        "--out-png {output.png} --out-csv {output.csv} > {log} 2>&1"


if COUPLED_SETS:
    rule figS2_steer_coupled:
        # Beyond the paper (issue 27): every set of coupled steer repeats (the real robot's three,
        # the campaign's at each logged pressure) against every shell model, our fit of the
        # authors' objective (pressure not logged) and the held-out diagnosed model
        # (roboball.pipeline.coupled), in one job (roboball stage NAME --each).  The steer
        # friction is each campaign's own stand Majd fit.
        input:
            # read as recorded (their ingest checks them and draws their QC plots first)
            recordings=[REC[s]["src"] for s in COUPLED],
            ingested=[f"results/ingest/{s}.csv" for s in COUPLED],
            regression=sorted({coupled_laws(d) for d, _, _ in COUPLED_SETS.values()}),
            friction=sorted({fit_json(d, "steer", "majd") for d, _, _ in COUPLED_SETS.values()}),
            hydro_fit=[HYDRO_TUNED] if SHELL_GROUPS else [],
        output:
            png=[report(coupled_outputs(n)["png"], category="6 Beyond the paper", caption="../report/figS2.rst",
                        labels={"figure": f"Fig. S2: coupled steer test, {coupled_label(d, p)}"})
                 for n, (d, _, p) in COUPLED_SETS.items()],
            pdf=[coupled_outputs(n)["pdf"] for n in COUPLED_SETS],
            table_csv=[coupled_outputs(n)["table_csv"] for n in COUPLED_SETS],
            table_md=[coupled_outputs(n)["table_md"] for n in COUPLED_SETS],
            traces=[coupled_outputs(n)["traces"] for n in COUPLED_SETS],
            summary=[coupled_outputs(n)["summary"] for n in COUPLED_SETS],
        params:
            code=CODE["steer-coupled"],
            each=get_steer_coupled_each,
        resources:
            mem_mb=1500,
            runtime=20,
            cpus_per_task=1,
        log: "results/logs/figS2_steer_coupled.log"
        benchmark: "results/benchmarks/figS2_steer_coupled.tsv"
        shell: "{ROBOBALL} steer-coupled --each {params.each:q} > {log} 2>&1"
