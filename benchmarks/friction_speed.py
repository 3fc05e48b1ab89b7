"""How long a converged Majd friction posterior takes (issue 7: 5 law parameters + noise, a 50 s
stand log, at least 50 autocorrelation times, under 60 s wall).

    .venv/bin/python benchmarks/friction_speed.py [--repeats 3] [--joint steer]

The recording: the virtual test bed's stand (full test-bed physics: LuGre joint friction, which
no fitted law contains, sensor noise, quantisation, irregular sampling), four hand releases and
about 50 s long, made once with a fixed seed.  Its releases are found as the pipeline finds them
(roboball.ingest.releases).  Timed: `roboball.identify.friction.fit.fit` with the pipeline's settings
(32 walkers, autocorr multiple 50, release angles marginalised), i.e. least squares, RK4 step
choice, emcee to convergence and the summary, in a fresh chain file each run; the median of
`--repeats` runs is printed with each run's steps, tau and convergence flag.
"""
from __future__ import annotations

import argparse
import json
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def make(folder: Path, joint: str) -> tuple[Path, Path]:
    from roboball.atomic import write_json_atomic
    from roboball.ingest.recording import normalise, read_recording, write_recording
    from roboball.ingest.releases.find import require_releases
    from roboball.testbed.campaign import _rest_angle, release_recording
    from roboball.testbed.physics import load_truth, true_robot
    from roboball.testbed.sensors import measure

    kind = f"{joint}_stand"
    truth = load_truth()
    rng = np.random.default_rng(50)
    rest = _rest_angle(kind, true_robot(truth, perturbed=False))
    dense = release_recording(kind, None, [rest - 1.1, rest + 0.8, rest - 0.9, rest + 1.0], 9.5, truth, rng)
    rec = measure(dense, truth["sensors"], rng)
    path = folder / f"{kind}_bench.csv"
    write_recording(path, rec, {"kind": kind, "pressure_kpa": None})
    rec = normalise(read_recording(path))
    rels = require_releases(rec)
    rel_path = folder / f"{kind}_bench.releases.json"
    write_json_atomic(rel_path, {"kind": kind, "releases": [r.as_dict() for r in rels]})
    return path, rel_path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--joint", default="steer", choices=("steer", "drive"))
    args = ap.parse_args(argv)
    from roboball.identify.friction.fit import fit

    print(f"machine: {platform.machine()}, python {platform.python_version()}, median of {args.repeats}")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        rec, rels = make(tmp, args.joint)
        import pandas as pd
        t = pd.read_csv(rec).time_s
        n_rel = len(json.loads(rels.read_text())["releases"])
        print(f"recording: test-bed {args.joint} stand, {t.iloc[-1] - t.iloc[0]:.1f} s, {len(t)} samples, "
              f"{n_rel} releases found")
        walls = []
        for k in range(args.repeats):
            t0 = time.perf_counter()
            res, _ = fit(rec, rels, args.joint, "majd", None, tmp / f"chain{k}.h5", walkers=32,
                         autocorr_multiple=50.0, max_steps=20000, seed=k)
            walls.append(time.perf_counter() - t0)
            c = res["convergence"]
            print(f"run {k}: {walls[-1]:.1f} s wall, converged {c['converged']}, {c['steps']} steps, "
                  f"max tau {c['max_tau']:.1f}, chain/tau {c['chain_over_tau']:.0f}, dt {res['integration']['dt_s']:g} s, "
                  f"rmse {res['fit']['rmse_rad']:.2g} rad")
        print(f"Majd posterior ({args.joint}, 5 parameters + noise + {n_rel} release angles): "
              f"median {statistics.median(walls):.1f} s (runs: {', '.join(f'{w:.1f}' for w in walls)}); target < 60 s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
