# Beyond the paper (issue 9): Fig. S1, a ramp descent while the shell deflates, next to the
# runs at constant start and end pressure (roboball.sim.pressure; config section deflating_ramp).
DEFLATE = config.get("deflating_ramp", {})
_sched = DEFLATE.get("schedule", {})


rule figS1_deflating_ramp:
    input:
        regression="results/identify/shell_regression.csv",
        schedule=[_sched["csv"]] if "csv" in _sched else [],
    output:
        png=report(f"{PF}/figS1_deflating_ramp.png", category="6 Beyond the paper", caption="../report/figS1.rst"),
        pdf=f"{PF}/figS1_deflating_ramp.pdf",
        csv="results/deflating/figS1_traces.csv",
    params:
        code=CODE["deflating-ramp"],
        schedule=schedule_args(_sched),
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


FIGURES += [f"{PF}/figS1_deflating_ramp.png"]
