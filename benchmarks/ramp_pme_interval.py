"""How far the diagnosed ramp model's eq. 12 PME moves across its own parameters' 95% intervals.

    .venv/bin/python benchmarks/ramp_pme_interval.py [--results results]

Figs. 13 and 14 score the diagnosed model of each ramp run with the effects of the pooled
diagnosis of the *other* runs at its pressure (results/diagnose/heldout/<run>), at their fitted
values.  This script reruns that Drake descent (roboball.pipeline.diagnosis.diagnosed_descent, the
pipeline's own, on the ingested recording) with every diagnosed parameter at the low end of its
95% interval, then every one at the high end (a bracket, not a joint interval: with a breakaway
and a drag both ends of both lose less, or more), and prints each run's PME and mean |error|, then
the mean PME per pressure at the fitted value and at the two ends.  It shows whether a difference
in PME between models is larger than what the diagnosis itself leaves open.  Needs `make figures`
first.  About 10 s.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from roboball.ingest.recording import read_recording  # noqa: E402
from roboball.metrics import speed_errors  # noqa: E402
from roboball.pipeline.diagnosis import baseline_friction, consensus_effects, diagnosed_descent  # noqa: E402


def descent(rec, releases: Path, effects: dict, friction: dict) -> dict:
    """Eq. 12's scores of the diagnosed model with `effects` on one recorded run."""
    _, w_e, w_s, _ = diagnosed_descent(rec, str(releases), effects, friction)
    return speed_errors(w_e, w_s)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", type=Path, default=ROOT / "results")
    args = ap.parse_args()
    held = sorted((args.results / "diagnose" / "heldout").glob("ramp_*/diagnosis.json"))
    if not held:
        raise SystemExit(f"{args.results}/diagnose/heldout: no ramp diagnoses; run `make figures` first")
    per_pressure: dict[float, list] = {}
    for dj in held:
        stem = dj.parent.name
        js = json.loads(dj.read_text())
        rec = read_recording(args.results / "ingest" / f"{stem}.csv")     # what the pipeline scores
        releases = args.results / "ingest" / f"{stem}.releases.json"
        effects, friction = consensus_effects([str(dj)]), baseline_friction([str(dj)])
        scores = {"fitted": descent(rec, releases, effects, friction)}
        for end, i in (("low", 0), ("high", 1)):
            ends = {m["effect"]: {k: ci[i] for k, ci in m["ci95"].items()} for m in js["missing_physics"]}
            scores[end] = descent(rec, releases, {e: {**p, **ends.get(e, {})} for e, p in effects.items()}, friction)
        per_pressure.setdefault(rec.pressure_kpa, []).append([scores[k]["pme_percent"] for k in ("fitted", "low", "high")])
        named = ", ".join(f"{e}({', '.join(f'{k}={v:.3g}' for k, v in p.items())})" for e, p in effects.items())
        print(f"{stem:18s} {named}: PME fitted {scores['fitted']['pme_percent']:+.2f}%, "
              f"at the interval's low / high end {scores['low']['pme_percent']:+.2f} / {scores['high']['pme_percent']:+.2f}%; "
              f"mean |error| {scores['fitted']['mape_percent']:.2f} / {scores['low']['mape_percent']:.2f} / "
              f"{scores['high']['mape_percent']:.2f}%", flush=True)
    print("mean PME per pressure (%): fitted [low end, high end]")
    for p in sorted(per_pressure):
        m = np.mean(per_pressure[p], axis=0)
        print(f"  {p:5.1f} kPa: {m[0]:+.2f} [{m[1]:+.2f}, {m[2]:+.2f}]")


if __name__ == "__main__":
    main()
