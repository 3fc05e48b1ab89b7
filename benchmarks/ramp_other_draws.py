"""The ramp diagnosis on other draws of the ramp campaign (after `make figures`).

    .venv/bin/python benchmarks/ramp_other_draws.py --seed 777 [--seed 778 ...] [--keep DIR]

The committed campaign (raw_data/) is one draw of the virtual test bed: its ramp runs' start
angles, release instants, sensor noise, dropouts and stamps come from the seed in truth.yaml.
This script redraws ONLY the ramp runs from another seed (same physics, same truth), in a copy
of the repository whose results/ and Snakemake records start as this checkout's (so the stand
and shell stages are not redone), reruns the pipeline, and prints per pressure the effects the
pooled and held-out ramp diagnoses name, and the mean PME (eq. 12) and mean absolute error of
the diagnosed model and of the other models of Figs. 13/14 (the paper's three and the calibrated
hydroelastic shell).  It answers: does the diagnosed model beat every other model because of the
physics it found, or because of one draw's noise?

Needs `make figures` run here first; takes about 4-5 min per seed on 2 cores.
"""
from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import pandas as pd

from roboball.testbed.campaign import jobs, make_file
from roboball.testbed.physics import campaign_truth

REPO = Path(__file__).resolve().parents[1]
OTHERS = ("point", "injected", "hydroelastic", "hydro_tuned")
# What the membrane campaign's ramp runs hide from the calibrated point model (the skin's flat and
# hysteresis loss, besides the contact's damping, LuGre friction and the true masses) reads on the
# committed draw as the shell's breakaway and a loss growing with speed (docs/diagnosis.md,
# "Ramp runs").
NAMED = "stiction+quadratic_drag"


def redraw_ramps(raw: Path, seed: int) -> None:
    truth = campaign_truth()
    truth["seed"] = seed
    todo = [j for j in jobs(truth) if j["kind"] == "ramp"]
    with ProcessPoolExecutor(2) as pool:
        list(pool.map(make_file, todo, [str(raw)] * len(todo), [truth] * len(todo)))


def copy_checkout(work: Path) -> None:
    for name in ("Snakefile", "workflow", "configs", "raw_data", "results", ".snakemake"):
        src = REPO / name
        if not src.exists():
            raise SystemExit(f"{src}: missing; run `make figures` in {REPO} first")
        (shutil.copytree(src, work / name, symlinks=True) if src.is_dir() else shutil.copy2(src, work / name))
    # the real logs are found at ../shared from the copy, as from the checkout
    shared = (REPO / ".." / "shared").resolve()
    if shared.is_dir() and not (work.parent / "shared").exists():
        (work.parent / "shared").symlink_to(shared)


def effects(path: Path) -> str:
    js = json.loads(path.read_text())
    return "+".join(m["effect"] for m in js["missing_physics"]) or "none"


def one_seed(seed: int, keep: Path | None) -> list[dict]:
    base = Path(tempfile.mkdtemp(prefix=f"ramp_draw_{seed}_"))
    work = base / "repo"
    work.mkdir()
    copy_checkout(work)
    redraw_ramps(work / "raw_data", seed)
    t0 = time.time()
    snakemake = str(Path(sys.executable).with_name("snakemake"))
    r = subprocess.run([snakemake, "--cores", "2", "--rerun-triggers", "mtime", "input", "params", "code"],
                       cwd=work, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"seed {seed}: snakemake failed:\n{r.stderr[-3000:]}")
    table = pd.read_csv(work / "paper_figures" / "table_pme.csv")
    rows = []
    for p in campaign_truth()["campaign"]["pressures_kpa"]:
        at_p = table[table.pressure_kpa == p].set_index("contact")
        at, mape = at_p["pme_mean_percent"], at_p["mape_mean_percent"]
        held = [effects(f) for f in sorted((work / "results/diagnose/heldout").glob(f"ramp_{p}kpa_r*/diagnosis.json"))]
        rows.append(dict(seed=seed, pressure_kpa=p,
                         pooled=effects(work / f"results/diagnose/pressure/ramp_{p}kpa/diagnosis.json"),
                         heldout_named=sum(h == NAMED for h in held),
                         heldout_others=" ".join(sorted({h for h in held if h != NAMED})) or "-",
                         heldout=len(held), **{f"pme_{c}": at[c] for c in ("diagnosed", *OTHERS)},
                         **{f"mape_{c}": mape[c] for c in ("diagnosed", *OTHERS)},
                         best=abs(at["diagnosed"]) < min(abs(at[c]) for c in OTHERS),
                         best_mape=mape["diagnosed"] < min(mape[c] for c in OTHERS)))
    print(f"seed {seed}: pipeline rerun in {time.time() - t0:.0f} s", flush=True)
    if keep:
        shutil.copytree(work / "paper_figures", keep / f"seed{seed}_paper_figures")
    shutil.rmtree(base)
    return rows


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seed", type=int, action="append", required=True, help="a seed for the ramp runs (repeatable)")
    ap.add_argument("--keep", default=None, help="keep each seed's paper_figures under this folder")
    args = ap.parse_args()
    keep = Path(args.keep) if args.keep else None
    if keep:
        keep.mkdir(parents=True, exist_ok=True)
    rows = [row for s in args.seed for row in one_seed(s, keep)]
    df = pd.DataFrame(rows)
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(df.round(2).to_string(index=False))
    print(f"diagnosed |PME| below every other model's: {int(df.best.sum())} of {len(df)} (seed, pressure) pairs; "
          f"mean |error| below: {int(df.best_mape.sum())} of {len(df)}; "
          f"{NAMED} named in {int((df.pooled == NAMED).sum())} of {len(df)} pooled "
          f"and {int(df.heldout_named.sum())} of {int(df.heldout.sum())} held-out diagnoses")


if __name__ == "__main__":
    main()
