"""Blind proof of `roboball diagnose`: effects concealed in test-bed recordings, found or not.

    .venv/bin/python benchmarks/diagnose_blind.py [--seed 6] [--workers 2] [--only KIND] [--limit N]
                                                 [--json results.json] [--keep DIR] [--real-like]

`--real-like` runs, instead of the clean cases below, the cases shaped like the real robot's logs
(an estimator's lagging output, single heavily damped releases, logs that start at the let-go,
stands slower than their URDF; benchmarks/real_like.py) and reports them apart.

Each case draws an experiment kind, a concealed effect set (none, one effect, or a pair) and
magnitudes from the ranges below, makes the recording with the virtual test bed
(roboball.testbed; its OWN implementations of the effects, roboball.testbed.effects: LuGre dry
friction with true sticking, a centre of mass moved in the robot description, symbolic
dead-zone backlash, ...; finer time steps than the diagnosis's models; irregular sampling,
noise, quantisation and hand-held phases from roboball.testbed.sensors), writes ONLY the CSV
and its sidecar into an empty temporary folder, and runs `roboball diagnose` on it in a
subprocess.  The diagnosis never sees the truth.  The benchmark restarts itself under the
pipeline's pinned numerics (roboball.pipeline.numerics), so a case's bits do not depend on the CPU.

Every concealed effect must show: the case's recording with and without it differ by an RMS of
at least VISIBLE = 2 sensor noise levels (the diagnosis's own detection limit); a case whose draw
fails is redrawn from the same ranges (`visible_draw`; the rejected draws are printed and kept).

So that "none" means none, every recording matches its baseline's structure apart from the
concealed effects: stands have viscous joint friction of a drawn coefficient (the baseline
fits it), shell runs are rigid point contact with no shell terms, ramp runs are point contact
with Majd friction (Table I) on both joints; the test bed's perturbed masses, hydroelastic
contact and its campaign friction are switched off.

Printed: confusion matrix (rows: concealed effect, columns: reported effect; a case with k
concealed and m reported effects adds k x m counts), exact-set accuracy, false-positive rate on
the null cases, median relative parameter error (every parameter of every concealed effect
that was found), median held-out RMSE drop on the non-null cases, per-kind accuracy, the
candidates refused for materiality alone (concealed ones the diagnosis saw but found too small,
and ones that were not concealed) and the wall time.  Targets (issue 6): exact-set accuracy >= 90%, no effect on null cases, median
parameter error <= 15%, median held-out RMSE drop >= 50%.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

import real_like
from blind_cases import FREE_S, SIGNAL, VISIBLE, confusion, draw_cases, magnitudes, noise_level, score, sensors


def _dense(case: dict):
    """The test bed's noiseless 1 kHz signals of the case (before the sensors), its sidecar
    metadata, and the case's random stream where the sensors take it up."""
    from roboball.testbed.campaign import _rest_angle, ramp_recording, release_recording
    from roboball.testbed.effects import conceal
    from roboball.testbed.physics import load_truth, true_robot

    truth = load_truth()
    rng = np.random.default_rng(case["seed"])
    kind = case["kind"]
    robot = true_robot(truth, perturbed=False)
    terms, systems, robot = conceal(kind, case["effects"], robot)
    meta = {"kind": kind, "pressure_kpa": case.get("pressure_kpa")}
    if kind == "ramp":
        dense, exit_s, _ = ramp_recording(case["pressure_kpa"], truth, rng, extras=(), extra_terms=terms,
                                          extra_systems=systems, robot=robot)
        meta.update(ramp_angle_deg=robot.ramp_angle_deg, ramp_exit_s=exit_s)
    else:
        rest = _rest_angle(kind, robot)
        targets = [rest + a for a in case["releases"]]
        base = {"steer": ("viscous", {"c": case["viscous_c"]})} if kind == "steer_stand" else None
        dense = release_recording(kind, case.get("pressure_kpa"), targets, FREE_S, truth, rng, extras=(),
                                  extra_terms=terms, extra_systems=systems, base_friction=base, robot=robot)
    return dense, meta, rng


def _write(dense, meta, rng, folder: Path, case: dict | None = None) -> Path:
    from roboball.ingest.recording import write_recording
    from roboball.testbed.sensors import measure

    if case is not None and "sensor" in case:       # a real-like case (real_like.py)
        rec = real_like.sense(dense, case, rng)
    else:
        rec = measure(dense, sensors(case or {}), rng)
    path = folder / "recording.csv"
    write_recording(path, rec, meta)
    return path


def make_recording(case: dict, folder: Path) -> Path:
    """The test bed plays the experimenter: the recording and its sidecar, nothing else."""
    return _write(*_dense(case), folder, case)


def visibility(case: dict, dense=None) -> dict:
    """{effect: RMS change of the recorded signal, in sensor noise levels, when the case loses
    that effect}."""
    sig = SIGNAL[case["kind"]]
    if dense is None:
        dense = _dense(case)[0]
    t, y = dense.time_s.to_numpy(), dense[sig].to_numpy()
    if "sensor" in case:                            # a real-like case (real_like.py)
        noise = real_like.noise_level(case)
    else:
        noise = noise_level(case["kind"], case)
    out = {}
    for e in case["effects"]:
        other = _dense(dict(case, effects={k: v for k, v in case["effects"].items() if k != e}))[0]
        y2 = np.interp(t, other.time_s.to_numpy(), other[sig].to_numpy())
        out[e] = round(float(np.sqrt(np.mean((y - y2) ** 2)) / noise), 2)
    return out


def visible_draw(case: dict, attempts: int = 20):
    """The case with magnitudes every concealed effect shows at (redrawn when needed), its
    noiseless signals, and the rejected draws."""
    rejected = []
    for attempt in range(attempts + 1):
        dense, meta, rng = _dense(case)
        vis = visibility(case, dense)
        if all(v >= VISIBLE for v in vis.values()):
            return dict(case, visibility=vis, rejected=rejected), (dense, meta, rng)
        rejected.append({"effects": case["effects"], "visibility": vis})
        index = int(case["id"].rsplit("-", 1)[1])
        redraw = np.random.default_rng([case.get("draw_seed", 0), index, attempt + 1])
        if "group" in case:                         # a real-like case (real_like.py)
            case = dict(case, effects=real_like.redraw(case, redraw))
        else:
            case = dict(case, effects=magnitudes(case["kind"], tuple(case["effects"]), redraw))
    raise RuntimeError(f"{case['id']}: no draw of {sorted(case['effects'])} in {attempts} shows in the recording")


def run_case(case: dict, keep: str | None = None) -> dict:
    t0 = time.perf_counter()
    case, made = visible_draw(case)
    with tempfile.TemporaryDirectory(prefix="blind_") as tmp:
        folder = Path(tmp) / "in"
        folder.mkdir()
        csv = _write(*made, folder, case)
        t_made = time.perf_counter() - t0
        assert sorted(p.name for p in folder.iterdir()) == ["recording.csv", "recording.json"]
        out = Path(tmp) / "out"
        t1 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "roboball.cli", "diagnose", str(csv), "--out", str(out)],
                              capture_output=True, text=True, env={**os.environ, "PYTHONHASHSEED": "0"})
        t_diag = time.perf_counter() - t1
        result = dict(case, returncode=proc.returncode, stderr=proc.stderr.strip()[-500:],
                      make_s=round(t_made, 1), diagnose_s=round(t_diag, 1))
        if proc.returncode == 0:
            result["diagnosis"] = json.loads((out / "diagnosis.json").read_text())
            details = json.loads((out / "details.json").read_text())
            result["immaterial"] = [i["effect"] for i in details.get("immaterial") or []]
        if keep:
            dest = Path(keep) / case["id"]
            shutil.rmtree(dest, ignore_errors=True)
            shutil.copytree(tmp, dest)
    return result


def main(argv=None) -> int:
    from roboball.pipeline.numerics import run_pinned
    run_pinned()    # the pipeline's numeric paths, so a case scores the same on every machine
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=6)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--only", default=None, help="only cases of this kind")
    ap.add_argument("--limit", type=int, default=None)
    ap.add_argument("--json", default=None, help="write every case and the scores here")
    ap.add_argument("--keep", default=None, help="keep each case's recording and diagnosis under this folder")
    ap.add_argument("--real-like", action="store_true", help="the real-like cases (real_like.py), reported apart")
    args = ap.parse_args(argv)
    if args.real_like:
        cases = real_like.draw_cases(args.seed)
    else:
        cases = draw_cases(args.seed)
    if args.only:
        cases = [c for c in cases if c["kind"] == args.only]
    if args.limit:
        cases = cases[: args.limit]
    t0 = time.perf_counter()
    results = []
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        for r in pool.map(run_case, cases, [args.keep] * len(cases)):
            results.append(r)
            d = r.get("diagnosis")
            rep = ", ".join(m["effect"] for m in d["missing_physics"]) if d else f"FAILED: {r['stderr']}"
            redrawn = f"; {len(r['rejected'])} draw(s) before did not show" if r.get("rejected") else ""
            small = f"; below materiality: {', '.join(r['immaterial'])}" if r.get("immaterial") else ""
            print(f"{r['id']:<16} concealed {sorted(r['effects']) or '-'}; reported {rep or '-'}"
                  f" [{d['verdict'] if d else '-'}] ({r['make_s']:.0f} + {r['diagnose_s']:.0f} s{redrawn}){small}",
                  flush=True)
    wall = time.perf_counter() - t0
    if args.real_like:
        s = real_like.report(results, wall, args.workers, args.seed)
        if args.json:
            Path(args.json).write_text(json.dumps(dict(scores={k: v for k, v in s.items() if k != "rows"},
                                                       rows=s["rows"], cases=results, wall_s=wall, seed=args.seed),
                                                  indent=1, default=float))
        return 0
    s = score(results)
    print()
    print(confusion(s["rows"]))
    print()
    fmt = lambda x: "n/a" if x is None else f"{x:.1%}"
    print(f"cases: {s['n']} (seed {args.seed}), wall time {wall / 60:.1f} min with {args.workers} workers")
    print(f"exact-set accuracy:            {fmt(s['exact_set_accuracy'])}   (target >= 90%)")
    print(f"false-positive rate, nulls:    {fmt(s['null_false_positive_rate'])}   (target 0%)")
    print(f"median parameter error:        {fmt(s['median_parameter_error'])}   (target <= 15%)")
    print(f"median held-out RMSE drop:     {fmt(s['median_heldout_rmse_drop'])}   (target >= 50%, non-null cases)")
    print("exact-set accuracy by kind:    " + ", ".join(f"{k} {fmt(v)}" for k, v in s["per_kind"].items()))
    print("parameter error by effect:     " + ", ".join(f"{e} {fmt(med)} (max {fmt(mx)}, {n})"
                                                       for e, (med, mx, n) in s["parameter_error_by_effect"].items()))
    redrawn = [r for r in results if r.get("rejected")]
    print(f"redrawn (a concealed effect changed the recording by < {VISIBLE:g} noise levels): {len(redrawn)} cases"
          + "".join(f"\n    {r['id']}: " + "; ".join(
              ", ".join(f"{e} {x['effects'][e]} showed {v:g}" for e, v in x["visibility"].items())
              for x in r["rejected"]) for r in redrawn))
    vis = [v for r in results for v in r.get("visibility", {}).values()]
    if vis:
        print(f"visibility of concealed effects: min {min(vis):.1f}, median {statistics.median(vis):.1f} noise levels")
    tally = s["immaterial"]
    print(f"supported but below materiality (not reported): {len(tally['concealed'])} concealed and missed"
          f" {tally['concealed'] or ''}, {len(tally['not_concealed'])} not concealed {tally['not_concealed'] or ''}")
    times = [x["seconds"] for x in s["rows"] if x["seconds"] is not None]
    if times:
        print(f"diagnose time per case:        median {statistics.median(times):.0f} s, max {max(times):.0f} s")
    if args.json:
        Path(args.json).write_text(json.dumps(dict(scores={k: v for k, v in s.items() if k != "rows"}, rows=s["rows"],
                                                   cases=results, wall_s=wall, seed=args.seed), indent=1,
                                              default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
