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
    wildcard_constraints: dataset="testbed|real", joint="steer|drive", law="viscous|coulomb_viscous|majd"
    # The compiled reduced model simulates the walkers' releases in parallel threads (Numba), and
    # the test bed's Majd fits gate every ramp simulation: both cores, and first in the queue.
    threads: 2
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
