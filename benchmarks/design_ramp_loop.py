"""Closing the loop on the campaign's own ramp runs: does the ramp `roboball design` names decide
what the three runs at a pressure left undecided, where another run on the user's ramp does not?

    .venv/bin/python benchmarks/design_ramp_loop.py [--pressures 6.9 10.3 ...] [--json out.json] [--keep DIR]

Run after `make figures` (it reads results/ingest/ramp_*.csv and the pooled diagnoses
results/diagnose/pressure/ramp_<p>kpa).  For each pressure: `roboball design` on the pooled
diagnosis; the test bed (the campaign's own truth, roboball.testbed.physics.campaign_truth: the
twin whose ramp runs hide the flat's start-up resistance and a hysteresis rolling loss, neither
a vocabulary law) makes one more run at that pressure on the ramp the design ranks first for
each undecided choice, and, as the control, one more on the user's own ramp (16 deg); each is
diagnosed together with the three runs, with the pipeline's fitted friction as in the pooled
diagnosis.  Printed per pressure: each choice's state before and after (an effect's listed
alternatives; a parameter's 95% interval, poorly pinned when wider than half its value).
"""
from __future__ import annotations

import argparse
import copy
import json
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PRESSURES = (6.9, 10.3, 13.8, 17.2, 20.7)


def make_run(angle: float, p_kpa: float, name: str, out: Path) -> Path:
    """One test-bed ramp run at `angle` deg, the campaign's truth, its own random stream `name`."""
    from roboball.config import RobotFacts
    from roboball.ingest.recording import write_recording
    from roboball.testbed.campaign import _rng, ramp_recording
    from roboball.testbed.physics import campaign_truth, true_robot
    from roboball.testbed.sensors import measure

    truth = campaign_truth()
    robot = true_robot(truth)
    data = copy.deepcopy(robot.data)
    data["experiments"]["ramp_angle_deg"] = float(angle)
    robot = RobotFacts(data, source=f"{robot.source}, a ramp of {angle:g} deg")
    rng = _rng(truth["seed"], name)
    dense, exit_s, _ = ramp_recording(p_kpa, truth, rng, robot=robot)
    meta = {"kind": "ramp", "pressure_kpa": p_kpa, "source": "roboball virtual test bed", "run": name,
            "ramp_angle_deg": float(angle), "ramp_exit_s": exit_s}
    return write_recording(out, measure(dense, truth["sensors"], rng), meta)


def _roboball(*args) -> None:
    subprocess.run([sys.executable, "-m", "roboball.cli", *map(str, args)], cwd=REPO, check=True,
                   stdout=subprocess.DEVNULL)


def state(folder: Path) -> dict:
    """Each effect's listed alternatives and each parameter's 95% interval in a diagnosis."""
    d = json.loads((folder / "diagnosis.json").read_text())
    out = {"verdict": d["verdict"], "effects": {}}
    for m in d["missing_physics"]:
        out["effects"][m["effect"]] = {"alternatives": [a["effect"] for a in m.get("alternatives") or []],
                                       "ci95": m.get("ci95", {}), "parameters": m["parameters"]}
    return out


def pressure(p: float, work: Path) -> dict:
    pooled = REPO / "results" / "diagnose" / "pressure" / f"ramp_{p:g}kpa"
    runs = [REPO / "results" / "ingest" / f"ramp_{p:g}kpa_r{r}.csv" for r in (1, 2, 3)]
    setup = json.loads((pooled / "details.json").read_text())["model_setup"]
    friction = []
    for joint, params in setup["friction"].items():
        f = work / f"{joint}.json"
        f.write_text(json.dumps(params))
        friction += [f"--friction-{joint}", f]
    _roboball("design", pooled, "--out", work / "design")
    design = json.loads((work / "design" / "design.json").read_text())
    angles = sorted({c["best"]["ramp_angle_deg"] for c in design["choices"] if c["best"]})
    user = float(setup["ramp_angle_deg"])
    row = {"pressure_kpa": p, "before": state(pooled), "choices": [
        {"choice": c["choice"], "best_deg": c["best"]["ramp_angle_deg"], "separation": c["best"]["separation"],
         "users_ramp_separation": (c["user_like"] or {}).get("separation")} for c in design["choices"] if c["best"]],
        "after": {}}
    for angle in angles + ([user] if user not in angles else []):
        run = make_run(angle, p, f"design_loop_{p:g}kpa_{angle:g}deg", work / f"ramp_{p:g}kpa_{angle:g}deg.csv")
        out = work / f"joint_{angle:g}deg"
        _roboball("diagnose", *runs, run, *friction, "--no-drake", "--out", out)
        row["after"][f"{angle:g}"] = state(out)
    return row


def _line(label: str, s: dict) -> str:
    parts = []
    for e, v in s["effects"].items():
        ci = "; ".join(f"{k} [{a:.3g}, {b:.3g}]" for k, (a, b) in v["ci95"].items())
        alt = f", or {' / '.join(v['alternatives'])}" if v["alternatives"] else ""
        parts.append(f"{e} ({ci}{alt})")
    return f"  {label:24s} {s['verdict']:11s} " + "; ".join(parts)


def main() -> int:
    from roboball.pipeline.numerics import run_pinned
    run_pinned()    # the pipeline's numeric paths, as the pooled diagnoses were made
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--pressures", type=float, nargs="+", default=PRESSURES)
    ap.add_argument("--json", default=None)
    ap.add_argument("--keep", default=None, help="keep every run and diagnosis in this folder")
    a = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for p in a.pressures:
            work = Path(a.keep or tmp) / f"{p:g}kpa"
            work.mkdir(parents=True, exist_ok=True)
            row = pressure(p, work)
            rows.append(row)
            print(f"{p:g} kPa: " + "; ".join(f"{c['choice']}: {c['best_deg']:g} deg ({c['separation']:.3g} noise levels; "
                                             f"the user's ramp {c['users_ramp_separation']:.3g})" for c in row["choices"]))
            print(_line("three runs", row["before"]))
            for angle, s in row["after"].items():
                print(_line(f"+ a run on {angle} deg", s))
            sys.stdout.flush()
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
