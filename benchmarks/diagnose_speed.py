"""How long `roboball diagnose` takes on a 40 s recording (issue 6, acceptance 4: under 60 s).

    .venv/bin/python benchmarks/diagnose_speed.py [--repeats 3] [--real]

The recording: the virtual test bed's steer stand, 40 s long, four hand releases (0.8, 0.6,
0.9 and 0.7 rad from rest), with Coulomb friction (0.3 N m) and quadratic drag (0.06 N m
s^2/rad^2) concealed on a viscous joint (0.1 N m s/rad): a case that needs two selection
rounds plus a final one that finds nothing more.  Timed: the whole command in a subprocess
(start-up, reading, selection, Drake simulations of the baseline and augmented model, report
and figures), median of `--repeats` runs.  `--real` also times the real steer-stand log (52 s)
and the real shell log (39 s, one release) with the pendulum free on its steer joint, as the
pipeline diagnoses it (roboball.reduced.shell_steer).
"""
from __future__ import annotations

import argparse
import json
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "roboball_real" / "steering_static_stand_response.csv"   # ../shared beside the checkout
REAL_SHELL = REAL.with_name("dynamic_data.csv")


def make(folder: Path) -> Path:
    from roboball.ingest.recording import write_recording
    from roboball.testbed.campaign import _rest_angle, release_recording
    from roboball.testbed.effects import conceal
    from roboball.testbed.physics import load_truth, true_robot
    from roboball.testbed.sensors import measure

    truth = load_truth()
    rng = np.random.default_rng(40)
    effects = {"coulomb_friction": {"tau_c": 0.3}, "quadratic_drag": {"c2": 0.06}}
    terms, systems, robot = conceal("steer_stand", effects, true_robot(truth, perturbed=False))
    rest = _rest_angle("steer_stand", robot)
    dense = release_recording("steer_stand", None, [rest - 0.8, rest + 0.6, rest - 0.9, rest + 0.7], 7.3, truth, rng,
                              extras=(), extra_terms=terms, extra_systems=systems,
                              base_friction={"steer": ("viscous", {"c": 0.1})}, robot=robot)
    rec = measure(dense, truth["sensors"], rng)
    path = folder / "speed.csv"
    write_recording(path, rec, {"kind": "steer_stand", "pressure_kpa": None})
    return path


def time_one(path: Path, out: Path, flags=()) -> tuple[float, dict]:
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "roboball.cli", "diagnose", str(path), "--out", str(out), *flags],
                          capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"diagnose failed: {proc.stderr.strip()}")
    return wall, json.loads((out / "diagnosis.json").read_text())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--real", action="store_true")
    args = ap.parse_args(argv)
    print(f"machine: {platform.machine()}, python {platform.python_version()}, median of {args.repeats}")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        path = make(tmp)
        import pandas as pd
        t = pd.read_csv(path).time_s
        targets = [(f"test-bed steer stand, {t.iloc[-1] - t.iloc[0]:.0f} s, 4 releases", path, ())]
        if args.real and REAL.exists():
            targets.append(("real steer-stand log (52 s, 3 releases)", REAL, ()))
        if args.real and REAL_SHELL.exists():
            targets.append(("real shell log (39 s, 1 release), pendulum free", REAL_SHELL, ("--steer-joint", "free")))
        for label, p, flags in targets:
            walls = []
            for k in range(args.repeats):
                wall, js = time_one(p, tmp / f"out{k}", flags)
                walls.append(wall)
            found = ", ".join(m["effect"] for m in js["missing_physics"]) or "nothing"
            print(f"{label}: median {statistics.median(walls):.1f} s (runs: {', '.join(f'{w:.1f}' for w in walls)}); "
                  f"verdict {js['verdict']}, found {found}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
