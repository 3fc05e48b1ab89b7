# Stage 1: validate and normalise every recording, find its releases, QC plot; decay per release.
# Each recording is ingested by its own job, so that an edited or added recording reruns only what
# depends on it; the decays, a fraction of a second each, share one job (roboball stage NAME --each).


rule ingest:
    input:
        src=lambda w: REC[w.stem]["src"],
        sidecar=get_sidecar,
    output:
        csv="results/ingest/{stem}.csv",
        sidecar="results/ingest/{stem}.json",
        releases="results/ingest/{stem}.releases.json",
        qc=report("results/qc/{stem}.png", category="1 Ingest", caption="../report/qc.rst", labels=qc_labels),
        qc_pdf="results/qc/{stem}.pdf",           # written beside the PNG (roboball.figures.style.save)
    params:
        code=CODE["ingest"],
        kind=lambda w: REC[w.stem]["kind"],
        pressure=lambda w: REC[w.stem]["pressure_kpa"],
        angle=lambda w: REC[w.stem]["ramp_angle_deg"],
    log: "results/logs/ingest/{stem}.log"
    benchmark: "results/benchmarks/ingest/{stem}.tsv"
    shell:
        "{ROBOBALL} ingest --src {input.src} --out-csv {output.csv} --out-releases {output.releases} "
        "--qc-png {output.qc} --kind {params.kind} --pressure-kpa '{params.pressure}' --ramp-angle-deg '{params.angle}' "
        "> {log} 2>&1"


if SHELL_ALL:
    rule decay:
        input:
            csv=expand("results/ingest/{stem}.csv", stem=SHELL_ALL),
            releases=expand("results/ingest/{stem}.releases.json", stem=SHELL_ALL),
        output: expand("results/decay/{stem}.csv", stem=SHELL_ALL)
        params:
            code=CODE["decay"],
            each=lambda w, input, output: _each([{"recording": c, "releases": r, "out_csv": o}
                                                 for c, r, o in zip(input.csv, input.releases, output)]),
        log: "results/logs/decay.log"
        benchmark: "results/benchmarks/decay.tsv"
        shell: "{ROBOBALL} decay --each {params.each:q} > {log} 2>&1"
