# Stage 1: validate and normalise every recording, find its releases, QC plot; decay per release.
# A recording takes a fraction of a second; starting Python with pandas, SciPy and matplotlib takes
# over a second: one job reads them all, one call per recording (roboball stage NAME --each).


rule ingest:
    input:
        src=[REC[s]["src"] for s in REC],
        sidecars=get_sidecars,
    output:
        csv=expand("results/ingest/{stem}.csv", stem=REC),
        sidecar=expand("results/ingest/{stem}.json", stem=REC),
        releases=expand("results/ingest/{stem}.releases.json", stem=REC),
        qc=[report(f"results/qc/{s}.png", category="1 Ingest", caption="../report/qc.rst", labels=qc_labels(s))
            for s in REC],
        qc_pdf=expand("results/qc/{stem}.pdf", stem=REC),     # written beside each PNG (roboball.figures.style.save)
    params:
        code=CODE["ingest"],
        each=get_ingest_each,
    log: "results/logs/ingest.log"
    benchmark: "results/benchmarks/ingest.tsv"
    shell: "{ROBOBALL} ingest --each {params.each:q} > {log} 2>&1"


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
