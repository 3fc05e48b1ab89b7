"""How long `roboball diagnose` takes on a 40 s recording (issue 6, acceptance 4: under 60 s).

    .venv/bin/python benchmarks/diagnose_speed.py [--repeats 3] [--real]

The recording: the virtual test bed's steer stand, 40 s long, four hand releases (0.8, 0.6,
0.9 and 0.7 rad from rest), with Coulomb friction (0.3 N m) and quadratic drag (0.06 N m
s^2/rad^2) concealed on a viscous joint (0.1 N m s/rad): a case that needs two selection
rounds plus a final one that finds nothing more.  Timed: the whole command in a subprocess
(start-up, reading, selection, Drake simulations of the baseline and augmented model, report
and figures), median of `--repeats` runs.  `--real` also times the real steer-stand log (52 s)
and the real shell log (39 s, one release) with its steer setting unknown (`--steer-joint
unknown`: diagnosed with the joint locked and with the pendulum free, roboball.reduced.shell_steer),
as the pipeline diagnoses it.  Every run has the pipeline's pinned numerics
(roboball.pipeline.numerics; ROBOBALL_NUMERICS=native leaves the environment as it is), and the
child's CPU time is printed beside its wall time: on a shared machine the wall time says more
about the other jobs than about the diagnosis.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import resource
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


def time_one(path: Path, out: Path, flags=()) -> tuple[float, float, dict]:
    """Wall and CPU time (s) of one `roboball diagnose` in a subprocess, and its diagnosis.json."""
    from roboball.pipeline.numerics import job_environment
    env = {**os.environ, **job_environment(os.environ)}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "roboball.cli", "diagnose", str(path), "--out", str(out), *flags],
                          capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"diagnose failed: {proc.stderr.strip()}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, json.loads((out / "diagnosis.json").read_text())


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
            targets.append(("real shell log (39 s, 1 release), steer setting unknown", REAL_SHELL,
                            ("--kind", "shell_rock", "--steer-joint", "unknown")))
        for label, p, flags in targets:
            walls, cpus = [], []
            for k in range(args.repeats):
                wall, cpu, js = time_one(p, tmp / f"out{k}", flags)
                walls.append(wall)
                cpus.append(cpu)
            found = ", ".join(m["effect"] for m in js["missing_physics"]) or "nothing"
            print(f"{label}: median {statistics.median(walls):.1f} s (runs: {', '.join(f'{w:.1f}' for w in walls)}; "
                  f"CPU {', '.join(f'{c:.1f}' for c in cpus)} s); verdict {js['verdict']}, found {found}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
