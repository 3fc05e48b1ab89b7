"""Where in a ramp descent each model's eq. 12 PME comes from: the first moments after the
let-go against the rest of the descent.

    .venv/bin/python benchmarks/ramp_pme_phases.py [--results results] [--split-s 0.3]

Eq. 12 is a signed mean of relative errors, and the samples right after the let-go, where the
robot is slow, weigh as much as the fast ones near the ramp's end.  For every contact model and
pressure this prints the mean over the runs of eq. 12 on all scored samples (Figs. 13/14), on
those in the first `--split-s` seconds after the release, and on the rest, with the early
samples' share of the scored ones.  It reads the traces the workflow writes
(results/ramp/<contact>/<run>.trace.csv: measured and simulated drive rate on the scored window)
and eq. 12's own sample rule (roboball.metrics.relative_errors); needs `make figures` first.
About a second.
"""
from __future__ import annotations

import argparse
import re
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from roboball.metrics import SPEED_FLOOR_RAD_S, relative_errors  # noqa: E402

RUN = re.compile(r"ramp_(?P<p>[0-9.]+)kpa_r\d+$")


def phases(trace: Path, split_s: float) -> dict:
    """Eq. 12 (percent) of one run on all its scored samples, before and after `split_s`."""
    d = pd.read_csv(trace)
    t = d["time_s"].to_numpy()
    w_e = d["drive_rate_measured_rad_s"].to_numpy()
    w_s = d["drive_rate_sim_rad_s"].to_numpy()
    early = t < split_s
    rel = {k: 100.0 * relative_errors(w_e[m], w_s[m], SPEED_FLOOR_RAD_S)      # eq. 12's samples of each
           for k, m in (("all", np.ones_like(early)), ("early", early), ("late", ~early))}
    return {**{k: r.mean() if r.size else np.nan for k, r in rel.items()},
            "early_share": rel["early"].size / rel["all"].size}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", type=Path, default=ROOT / "results")
    ap.add_argument("--split-s", type=float, default=0.3, help="the early phase: seconds after the release")
    args = ap.parse_args()
    rows = defaultdict(list)
    for trace in sorted((args.results / "ramp").glob("*/*.trace.csv")):
        m = RUN.match(trace.name[: -len(".trace.csv")])
        if m:
            rows[(trace.parent.name, float(m["p"]))].append(phases(trace, args.split_s))
    if not rows:
        sys.exit(f"{args.results / 'ramp'}: no ramp traces (run make figures first)")
    print(f"eq. 12 PME (%), mean over runs; early: the first {args.split_s:g} s after the release")
    print(f"{'contact':<14} {'p (kPa)':>7} {'runs':>4} {'all':>7} {'early':>7} {'rest':>7} {'early share':>11}")
    for (contact, p), runs in sorted(rows.items()):
        mean = {k: float(np.mean([r[k] for r in runs])) for k in runs[0]}
        print(f"{contact:<14} {p:>7.1f} {len(runs):>4} {mean['all']:>+7.2f} {mean['early']:>+7.2f} "
              f"{mean['late']:>+7.2f} {mean['early_share']:>11.2f}")


if __name__ == "__main__":
    main()
