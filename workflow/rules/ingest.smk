# Stage 1: validate and normalise every recording, find its releases, QC plot; decay per release.


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


rule decay:
    input:
        csv="results/ingest/{stem}.csv",
        releases="results/ingest/{stem}.releases.json",
    output: "results/decay/{stem}.csv"
    params: code=CODE["decay"]
    log: "results/logs/decay/{stem}.log"
    benchmark: "results/benchmarks/decay/{stem}.tsv"
    shell:
        "{ROBOBALL} decay --recording {input.csv} --releases {input.releases} --out-csv {output} > {log} 2>&1"
