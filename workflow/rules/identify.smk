# Stage 2: identification.  The shell's damping ratio and natural frequency against pressure
# (Fig. 10 data), and joint friction on the stand logs: least squares, then emcee posteriors
# (HDF5 chains, resumable) and the model comparison of each joint's laws.


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


# The hydroelastic calibration (issue 25, roboball.pipeline.hydro): Drake's hydroelastic shell
# over a grid of moduli (one job per modulus) and dissipations, released like the recordings;
# then at each pressure the modulus and dissipation that reproduce the recorded zeta and
# omega_n, with Drake in the loop, and 95% intervals; the table and the contact-volume law V(p).
# A campaign whose shell releases cannot give a regression (one pressure, or none logged): its
# releases' mean zeta and omega_n, the same at every pressure, for the coupled test (Fig. S2).
rule shell_constant_laws:
    input: lambda w: [f"results/decay/{s}.csv" for s in stems("shell_rock", w.dataset)]
    output: "results/identify/{dataset}_shell_laws.csv"
    params: code=CODE["shell-constant-laws"]
    log: "results/logs/{dataset}_shell_laws.log"
    shell: "{ROBOBALL} shell-constant-laws --decay-csvs {input} --out-table {output} > {log} 2>&1"


rule hydro_grid:
    input: expand("results/ingest/{stem}.releases.json", stem=SHELL)
    output: "results/hydro/grid/{col}.csv"
    params:
        code=CODE["hydro-grid"],
        modulus=lambda w: HYDRO_GRID[w.col],
        d=HYDRO["dissipation_s_m"],
        n=HYDRO["n_dissipation"],
        duration=config["shell"]["sim_duration_s"],
        dt=config["shell"]["dt_s"],
    log: "results/logs/hydro/grid_{col}.log"
    benchmark: "results/benchmarks/hydro/grid_{col}.tsv"
    shell:
        "{ROBOBALL} hydro-grid --releases {input} --modulus-pa {params.modulus} --dissipation-min-s-m {params.d[0]} "
        "--dissipation-max-s-m {params.d[1]} --n-dissipation {params.n} --duration {params.duration} --dt {params.dt} "
        "--out-csv {output} > {log} 2>&1"


rule hydro_fit:
    input:
        grid=expand("results/hydro/grid/{col}.csv", col=list(HYDRO_GRID)),
        decay=lambda w: [f"results/decay/{s}.csv" for s in SHELL_GROUPS[w.group]],
        releases=lambda w: [f"results/ingest/{s}.releases.json" for s in SHELL_GROUPS[w.group]],
    output: "results/hydro/fit/{group}.csv"
    params:
        code=CODE["hydro-fit"],
        pressure=lambda w: float(REC[SHELL_GROUPS[w.group][0]]["pressure_kpa"]),
        tol=HYDRO["tol"],
        evals=HYDRO["max_drake_evals"],
        draws=HYDRO["draws"],
        seed=config["seed"],
        duration=config["shell"]["sim_duration_s"],
        dt=config["shell"]["dt_s"],
    log: "results/logs/hydro/fit_{group}.log"
    benchmark: "results/benchmarks/hydro/fit_{group}.tsv"
    shell:
        "{ROBOBALL} hydro-fit --grid-csvs {input.grid} --decay-csvs {input.decay} --releases {input.releases} "
        "--pressure-kpa {params.pressure} --tol {params.tol} --max-evals {params.evals} --draws {params.draws} "
        "--seed {params.seed} --duration {params.duration} --dt {params.dt} --out-csv {output} > {log} 2>&1"


rule hydro_summary:
    input: expand("results/hydro/fit/{group}.csv", group=list(SHELL_GROUPS))
    output:
        table=HYDRO_TUNED,
        law="results/identify/hydro_volume_law.csv",
    params: code=CODE["hydro-summary"]
    log: "results/logs/hydro/summary.log"
    shell: "{ROBOBALL} hydro-summary --fits {input} --out-csv {output.table} --out-law-csv {output.law} > {log} 2>&1"


rule friction_fit:
    input: unpack(get_stand_recording)
    output:
        json="results/friction/{dataset}/{joint}_{law}.json",
        samples="results/friction/{dataset}/{joint}_{law}.samples.csv",
    params:
        code=CODE["friction-fit"],
        prior=get_prior_json,
        chain="results/friction/{dataset}/{joint}_{law}.h5",
        walkers=config["friction"]["walkers"],
        multiple=config["friction"]["autocorr_multiple"],
        max_steps=config["friction"]["max_steps"],
        seed=config["seed"],
    wildcard_constraints: dataset="|".join(DATASETS), joint="steer|drive", law="viscous|coulomb_viscous|majd"
    # The compiled reduced model can simulate the walkers' releases in parallel threads (Numba),
    # but a fit keeps two threads only 1.0-1.5 busy (measured: 94-153% load), so two cores held by
    # one fit sat half idle for 100 s of a 650 s run; one thread each, the chains are the same
    # bit for bit.  The test bed's Majd fits gate every ramp simulation: first in the queue.
    threads: 1
    priority: 10
    log: "results/logs/friction/{dataset}/{joint}_{law}.log"
    benchmark: "results/benchmarks/friction/{dataset}/{joint}_{law}.tsv"
    shell:
        "NUMBA_NUM_THREADS={threads} {ROBOBALL} friction-fit --recording {input.csv} --releases {input.releases} --joint {wildcards.joint} "
        "--law {wildcards.law} --prior-json '{params.prior}' --chain {params.chain} --walkers {params.walkers} "
        "--autocorr-multiple {params.multiple} --max-steps {params.max_steps} --seed {params.seed} "
        "--out-json {output.json} --out-samples {output.samples} > {log} 2>&1"


rule friction_comparison:
    input: get_stand_fits
    output: "results/friction/{dataset}/{joint}_comparison.csv"
    params: code=CODE["friction-comparison"]
    log: "results/logs/friction/{dataset}/{joint}_comparison.log"
    shell: "{ROBOBALL} friction-comparison --fits {input} --out-csv {output} > {log} 2>&1"
