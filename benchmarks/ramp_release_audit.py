"""Audit of the ramp release instants against the test bed's ground truth (after `make figures`).

    .venv/bin/python benchmarks/ramp_release_audit.py [--results results] [--raw raw_data]

Every model of Fig. 13/14 is started at the release instant the pipeline detects in the
recording (roboball.ingest.releases, hinge fit on the drive rate) and scored from it.  The test bed
knows when it let go (roboball.testbed.campaign.ramp_release_s).  Per ramp run this prints the
detection error and each model's PME (eq. 12) as the pipeline scored it and as it would be had
the run started at the true instant.  The second figure shifts the simulated trace by the
detection error (a descent from rest is autonomous, and the pipe angle was held still in
between) instead of re-running Drake; samples below the PME speed floor stay out either way.
"""
import argparse
import json
from pathlib import Path

import numpy as np
import pandas as pd

from roboball.pipeline.simulation import pme
from roboball.testbed.campaign import jobs, ramp_release_s
from roboball.testbed.physics import campaign_truth

CONTACTS = ("point", "injected", "hydroelastic", "diagnosed")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--results", default="results")
    args = ap.parse_args()
    res = Path(args.results)
    truth = campaign_truth()
    rows = []
    for job in jobs(truth):
        if job["kind"] != "ramp":
            continue
        stem = Path(job["file"]).stem
        rel = res / "ingest" / f"{stem}.releases.json"
        if not rel.is_file():
            raise SystemExit(f"{rel}: missing; run `make figures` first")
        t_det = json.loads(rel.read_text())["releases"][0]["t_release_s"]
        t_true = ramp_release_s(job["file"], truth)
        err = t_det - t_true
        row = {"run": stem, "pressure_kpa": job["pressure_kpa"], "detected_minus_true_ms": 1e3 * err}
        for contact in CONTACTS:
            trace = res / "ramp" / contact / f"{stem}.trace.csv"
            if not trace.is_file():
                continue
            tr = pd.read_csv(trace)
            tt = tr.time_s.to_numpy()
            w_e = tr.drive_rate_measured_rad_s.to_numpy()
            w_s = tr.drive_rate_sim_rad_s.to_numpy()
            row[f"{contact}_pme"] = pme(w_e, w_s)
            row[f"{contact}_pme_true_start"] = pme(w_e, np.interp(tt + err, tt, w_s))
        rows.append(row)
    df = pd.DataFrame(rows)
    pd.set_option("display.width", 200)
    print(df[["run", "detected_minus_true_ms"]].round(1).to_string(index=False))
    print(f"\ndetection error: median {df.detected_minus_true_ms.median():+.1f} ms, "
          f"range {df.detected_minus_true_ms.min():+.1f} to {df.detected_minus_true_ms.max():+.1f} ms")
    cols = [c for c in df.columns if c.endswith("_pme") or c.endswith("_pme_true_start")]
    mean = df.groupby("pressure_kpa")[cols].mean()
    print("\nmean PME (%) per pressure, as scored / started at the true release:")
    print(" | ".join(["kPa"] + [f"{c:>12}" for c in CONTACTS]))
    for p, r in mean.iterrows():
        cells = [f"{r.get(f'{c}_pme', np.nan):5.1f} / {r.get(f'{c}_pme_true_start', np.nan):5.1f}" for c in CONTACTS]
        print(" | ".join([f"{p:4.1f}"] + [f"{c:>12}" for c in cells]))


if __name__ == "__main__":
    main()
