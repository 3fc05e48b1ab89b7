# Stage 3: joint friction on the stand logs: least squares, then emcee posteriors (HDF5 chains,
# resumable), model comparison; Table I, Fig. 5, 7, 8, corner plots.  The testbed's steer and
# drive stands, and the real steer-stand log when present.
import json

# the workflow's priors (ROBOBALL_CONFIG_DIR, checked against their schema by the Snakefile)
PRIORS = __import__("roboball.config", fromlist=["load_yaml"]).load_yaml(
    os.path.join(os.environ["ROBOBALL_CONFIG_DIR"], "priors.yaml"))
STAND = {("testbed", "steer"): "steer_stand_r1", ("testbed", "drive"): "drive_stand_r1",
         ("real", "steer"): "real_steer_stand"}
FITS = [("testbed", j, law) for j, law in FRICTION_MODELS]
if REAL_ON:
    FITS += [("real", "steer", law) for law in config["friction"]["steer_laws"]]


def fit_json(dataset, joint, law):
    return f"results/friction/{dataset}/{joint}_{law}.json"


rule friction_fit:
    input:
        csv=lambda w: f"results/ingest/{STAND[(w.dataset, w.joint)]}.csv",
        releases=lambda w: f"results/ingest/{STAND[(w.dataset, w.joint)]}.releases.json",
    output:
        json="results/friction/{dataset}/{joint}_{law}.json",
        samples="results/friction/{dataset}/{joint}_{law}.samples.csv",
    params:
        code=CODE["friction-fit"],
        # Only this model's prior block: editing another model's prior does not rerun this fit.
        prior=lambda w: json.dumps(PRIORS[w.joint][w.law], sort_keys=True),
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
    input: lambda w: [fit_json(d, j, l) for d, j, l in FITS if d == w.dataset and j == w.joint]
    output: "results/friction/{dataset}/{joint}_comparison.csv"
    params: code=CODE["friction-comparison"]
    log: "results/logs/friction/{dataset}/{joint}_comparison.log"
    shell: "{ROBOBALL} friction-comparison --fits {input} --out-csv {output} > {log} 2>&1"


rule table1:
    input:
        fits=[fit_json(*f) for f in FITS],
        comparison="results/friction/testbed/steer_comparison.csv",
    output:
        csv=f"{PF}/table1_friction.csv",
        md=f"{PF}/table1_friction.md",
    params: code=CODE["table1"]
    log: "results/logs/table1.log"
    shell:
        "{ROBOBALL} table1 --fits {input.fits} --comparison-csv {input.comparison} "
        "--out-csv {output.csv} --out-md {output.md} > {log} 2>&1"


rule fig5:
    input: [fit_json(*f) for f in FITS if f[0] == "testbed"]
    output:
        png=report(f"{PF}/fig5_friction_laws.png", category="2 Friction", caption="../report/fig5.rst"),
        pdf=f"{PF}/fig5_friction_laws.pdf",
    params: code=CODE["fig5"]
    log: "results/logs/fig5.log"
    shell: "{ROBOBALL} fig5 --fits {input} --out-png {output.png} > {log} 2>&1"


rule fig_stand:
    input:
        csv=lambda w: f"results/ingest/{STAND[(w.dataset, w.joint)]}.csv",
        releases=lambda w: f"results/ingest/{STAND[(w.dataset, w.joint)]}.releases.json",
        fits=lambda w: [fit_json(d, j, l) for d, j, l in FITS if d == w.dataset and j == w.joint],
    output:
        png=report(f"{PF}/fig{{num}}_{{dataset}}_{{joint}}_fits.png", category="2 Friction", caption="../report/fig78.rst"),
        pdf=f"{PF}/fig{{num}}_{{dataset}}_{{joint}}_fits.pdf",
    params:
        code=CODE["fig-stand-fits"],
        title=lambda w: f"Fig. {w.num}: {w.joint} stand ({w.dataset}): data and fitted friction simulated in Drake",
    wildcard_constraints: num="7|8", dataset="testbed|real", joint="steer|drive"
    log: "results/logs/fig{num}_{dataset}_{joint}.log"
    shell:
        "{ROBOBALL} fig-stand-fits --recording {input.csv} --releases {input.releases} --fits {input.fits} "
        "--title '{params.title}' --out-png {output.png} > {log} 2>&1"


rule corner:
    input: "results/friction/{dataset}/{joint}_{law}.json"
    output:
        png=report(f"{PF}/corner/corner_{{dataset}}_{{joint}}_{{law}}.png", category="2 Friction", caption="../report/corner.rst"),
        pdf=f"{PF}/corner/corner_{{dataset}}_{{joint}}_{{law}}.pdf",
    params: code=CODE["corner-plot"]
    wildcard_constraints: dataset="testbed|real", joint="steer|drive", law="viscous|coulomb_viscous|majd"
    log: "results/logs/corner/{dataset}_{joint}_{law}.log"
    shell: "{ROBOBALL} corner-plot --fit {input} --out-png {output.png} > {log} 2>&1"


FIGURES += [f"{PF}/fig5_friction_laws.png", f"{PF}/table1_friction.md",
            f"{PF}/fig7_testbed_steer_fits.png", f"{PF}/fig8_testbed_drive_fits.png"]
FIGURES += [f"{PF}/corner/corner_{d}_{j}_{l}.png" for d, j, l in FITS]
if REAL_ON:
    FIGURES += [f"{PF}/fig7_real_steer_fits.png"]


COMPARISONS = ["results/friction/testbed/steer_comparison.csv"] + (["results/friction/real/steer_comparison.csv"] if REAL_ON else [])


rule uncertainty_report:
    input:
        fits=[fit_json(*f) for f in FITS],
        comparisons=COMPARISONS,
        regression="results/identify/shell_regression.csv",
        pme=f"{PF}/table_pme.csv",
        sweep=f"{PF}/table_sweep.md",
        diagnoses=[f"results/diagnose/{s}/diagnosis.json" for s in stems("steer_stand", True) + stems("shell_rock", True)]
                  + [f"results/diagnose/pressure/{g}/diagnosis.json" for g in RAMP_GROUPS],
        # read beside each diagnosis.json: the candidates supported by the data but below materiality
        details=[f"results/diagnose/{s}/details.json" for s in stems("steer_stand", True) + stems("shell_rock", True)]
                + [f"results/diagnose/pressure/{g}/details.json" for g in RAMP_GROUPS],
        figures=[f"{PF}/fig5_friction_laws.png", f"{PF}/fig7_testbed_steer_fits.png", f"{PF}/fig8_testbed_drive_fits.png",
                 f"{PF}/fig10_shell_dynamics.png", f"{PF}/fig11_hydro_sensitivity.png", f"{PF}/fig13_ramp_pme.png",
                 f"{PF}/fig14_ramp_pme_mean.png"] + ([f"{PF}/fig7_real_steer_fits.png"] if REAL_ON else []),
    output: report(f"{PF}/uncertainty_report.html", category="0 Report", caption="../report/uncertainty.rst")
    params: code=CODE["uncertainty-report"]
    log: "results/logs/uncertainty_report.log"
    shell:
        "{ROBOBALL} uncertainty-report --fits {input.fits} --comparisons {input.comparisons} "
        "--regression {input.regression} --pme-table {input.pme} --sweep-md {input.sweep} "
        "--figures {input.figures} --diagnoses {input.diagnoses} --out-html {output} > {log} 2>&1"


FIGURES += [f"{PF}/uncertainty_report.html"]
