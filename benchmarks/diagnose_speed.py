"""How long `roboball diagnose` takes on a 40 s recording (issue 6, acceptance 4: under 60 s).

    .venv/bin/python benchmarks/diagnose_speed.py [--repeats 3] [--real] [--kinds]

The recording: the virtual test bed's steer stand, 40 s long, four hand releases (0.8, 0.6,
0.9 and 0.7 rad from rest), with Coulomb friction (0.3 N m) and quadratic drag (0.06 N m
s^2/rad^2) concealed on a viscous joint (0.1 N m s/rad): a case that needs two selection
rounds plus a final one that finds nothing more.  Timed: the whole command in a subprocess
(start-up, reading, selection, Drake simulations of the baseline and augmented model, report
and figures), median of `--repeats` runs.  `--real` also times the real steer-stand log (52 s)
and the real shell log (39 s, one release) with its steer setting unknown (`--steer-joint
unknown`: diagnosed with the joint locked and with the pendulum free, roboball.reduced.shell_steer),
as the pipeline diagnoses it.  `--kinds` also times a 40 s campaign-like recording of each other
kind the reduced models diagnose (four releases, the campaign's truth with every extra of the
test bed: LuGre friction, true masses, the membrane shell): the drive stand, the shell rocking
with its steer joint clamped, and with its pendulum free diagnosed `--steer-joint unknown`
(issue 48, point 3; the free pendulum's run is the coupled Drake experiment with a shell
stiffness and damping and a sideways imbalance, `imbalanced_free_releases`, as the real shell
logs show one).  Every run has the pipeline's pinned numerics
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


# (releases from rest, rad; free response after each, s) of the 40 s recordings of --kinds
KIND_RELEASES = {"drive_stand": ([0.70, -0.55, 0.45, -0.60], 8.0), "shell_rock": ([-0.40, 0.30, -0.22, 0.35], 8.0)}
SHELL_KPA = 13.8
FREE_RELEASES = (0.35, -0.35, 0.25, -0.3)      # rad from rest, the pendulum free


def make_kind(folder: Path, kind: str, free_pendulum: bool = False) -> Path:
    """A 40 s recording of `kind` by the campaign's test bed (seeded); with `free_pendulum` a
    shell rocking with the pendulum free on its steer joint, its sidecar saying `unknown`."""
    from roboball.ingest.recording import write_recording
    from roboball.testbed.campaign import _rest_angle, release_recording
    from roboball.testbed.physics import load_truth, true_robot
    from roboball.testbed.sensors import measure

    if free_pendulum:
        return imbalanced_free_releases(folder / f"{kind}_free.csv", FREE_RELEASES, 0.04, seed=40, free_s=8.0)
    truth = load_truth()
    rng = np.random.default_rng([40, len(kind)])
    offsets, free_s = KIND_RELEASES[kind]
    p_kpa = SHELL_KPA if kind == "shell_rock" else None
    robot = true_robot(truth, perturbed=True)
    dense = release_recording(kind, p_kpa, [_rest_angle(kind, robot) + a for a in offsets], free_s, truth, rng)
    path = folder / f"{kind}.csv"
    write_recording(path, measure(dense, truth["sensors"], rng), {"kind": kind, "pressure_kpa": p_kpa})
    return path


def imbalanced_free_releases(path, releases, delta, seed, k=50.0, c=8.0, free_s=6.0):
    """Shell releases in Drake with the pendulum free and a sideways imbalance of the shell: its
    centre of mass turned by `delta` about the roll axis (com_offset, so that the rest shifts by
    about delta), with a shell stiffness and damping; each release from a 1 s hold at `releases`
    (rad from the model's rest) with the pendulum hanging there (at rest, its centre of mass below
    the joint), 0.5 mrad noise; the sidecar says the steer setting is unknown."""
    import pandas as pd

    from roboball.diagnose.drake import effect_term
    from roboball.ingest.recording import Recording, write_recording
    from roboball.reduced.shell_steer import ShellSteerModel
    from roboball.sim.coupled import coupled_spec
    from roboball.sim.scenarios import simulate
    from roboball.sim.spec import ShellParams
    from roboball.testbed.sensors import min_jerk

    model = ShellSteerModel()
    effects = {"linear_stiffness": {"k": k}, "viscous_damping": {"c": c}, "com_offset": {"delta": delta}}
    spec = coupled_spec("point", ShellParams(), model.majd, extra_terms=[effect_term(model, effects)], dt=1e-3)
    hanging = model.rest + model.steer_rest          # the pendulum's own rest angle, from the vertical
    rate = 100.0
    ts, ys = [np.arange(0.0, 1.0, 1 / rate)], [np.full(100, model.rest + delta)]
    t_now, y_now = 1.0, model.rest + delta
    for rel in releases:
        held = model.rest + delta + rel
        ts += [t_now + np.arange(80) / rate, t_now + 0.8 + np.arange(100) / rate]
        ys += [min_jerk(y_now, held, 80), np.full(100, held)]
        t_now += 1.8
        df = simulate(spec, held, free_s, sample_rate_hz=rate, steer0=hanging - held,
                      rates0={"pipe_rate": 0.0, "steer_rate": 0.0})
        ts.append(t_now + df.time_s.to_numpy()[1:])
        ys.append(df.pipe_angle_rad.to_numpy()[1:])
        t_now, y_now = t_now + float(df.time_s.iloc[-1]), float(ys[-1][-1])
    t = np.concatenate(ts)
    y = np.concatenate(ys) + np.random.default_rng(seed).normal(0.0, 5e-4, len(t))
    write_recording(path, Recording(pd.DataFrame({"time_s": t, "pipe_angle_rad": y}),
                                    {"kind": "shell_rock", "pressure_kpa": 13.8, "steer_joint": "unknown"}))
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
    ap.add_argument("--kinds", action="store_true", help="also 40 s recordings of the drive stand and the shell")
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
        for kind, free, flags in ([("drive_stand", False, ()), ("shell_rock", False, ()),
                                   ("shell_rock", True, ("--steer-joint", "unknown"))] if args.kinds else []):
            p = make_kind(tmp, kind, free)
            span = pd.read_csv(p).time_s
            setting = ", pendulum free, steer setting unknown" if free else (", steer clamped" if kind == "shell_rock" else "")
            targets.append((f"test-bed {kind.replace('_', ' ')}{setting}, {span.iloc[-1] - span.iloc[0]:.0f} s, 4 releases",
                            p, flags))
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
