"""Calibrate the virtual robot against every public real log, Drake in the loop, and hold each out.

    .venv/bin/python benchmarks/testbed_calibrate.py [--stages S1,S2,...] [--evals N] [--report]

The twin (`roboball.testbed`, `load_truth(real=True)`) runs each real log's own experiment
exactly as `roboball-testbed replay` does (`roboball.testbed.replay.simulate_log`: the same
releases, the same columns), so the numbers here are the replay's.  The cost of a set of logs
is the sum over their angle columns of (RMS / target)^2, the targets being issue 46's
acceptance levels (stand 0.05 rad, shell log 0.01 rad, coupled repeats 0.05 rad each
coordinate): a log counts in proportion to how far it is from its target.

Parameters (SI; the start S0 is the same for every fit, full or held out):

* steer joint (the stand log): LuGre F_c, F_s (N m), v_s (rad/s), viscous (N m s/rad) and the
  rotor's reflected inertia (kg m^2).  S0: the campaign's friction, no rotor.
* shell (the shell log and the coupled repeats): the bedliner's set tension (N/m) and loss
  peak, the shell's polar excess (m), the pipe assembly's sideways imbalance (m).  S0: the
  campaign's bedliner (1200 N/m, 0.4); the excess and imbalance at an earlier attempt's values
  (1.84 cm, -2.03 cm), which came from a fit to all five logs (so the held-out folds do not
  start blind in those two numbers; docs/testbed.md says so).  The flat's set pressure is held
  at 8.5 kPa (not fitted: budget).
* nuisance (each log's unknowns): the coupled repeats' shared pressure (kPa), the shell log's
  pressure (kPa) and its pendulum's angle at the release from plumb (rad).

Stages (each writes results/testbed_calibration/<stage>.json and is skipped when that exists:
rerun to resume; every Drake evaluation is also cached there, so an interrupted stage replays
its finished evaluations at no cost):

* stand: steer parameters on the stand log;
* shell: shell parameters and all nuisance values on the shell log and the three repeats, the
  steer parameters from `stand`;
* out_<log>: the same fits without that log (out_stand: steer parameters on the repeats, the
  shell from `shell`; out_dynamic_data: shell and the repeats' pressure on the repeats, then the
  left-out log's own nuisance values fitted on it alone; out_<repeat>: shell and nuisance on the
  shell log and the other two repeats, the left-out repeat predicted at the shared pressure);
* --report: the table (in sample, held out, before) to benchmarks/testbed_calibration.json.
* shell_held (not in the default stages, not the twin): the `shell` fit again from the committed
  calibration, the shell log's pendulum let go from a hold (held at a joint angle, let go a lead
  time before the shell: docs/testbed.md, the shell log's let-go) instead of hanging still;
  out_held_<log>: each log held out of it (`held_fold`).

Nelder-Mead (SciPy, bounded) in scaled coordinates, --evals evaluations per fit (default 50).
The committed JSON came from: --stages stand --evals 60; --stages shell --evals 120;
--stages out_steering_static_stand_response --evals 80; the other out_ stages --evals 100;
then --report.
An evaluation costs about 4 s (stand), 3 s (shell log) and 3 s per repeat on one core.
"""
from __future__ import annotations

import argparse
import copy
import hashlib
import json
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))
REAL = ROOT.parent / "shared" / "data" / "roboball_real"
WORK = ROOT / "results" / "testbed_calibration"
OUT = ROOT / "benchmarks" / "testbed_calibration.json"

from roboball.errors import RoboballError  # noqa: E402
from roboball.testbed.physics import load_truth  # noqa: E402
from roboball.testbed.replay import read_log, rms_by_column, simulate_log  # noqa: E402

STAND = "steering_static_stand_response"
SHELL = "dynamic_data"
COUPLED = ("steer_coupled_20250429_165825", "steer_coupled_20250429_165853", "steer_coupled_20250429_165914")
LOGS = (STAND, SHELL) + COUPLED
TARGET_RAD = {STAND: 0.05, SHELL: 0.01, **{c: 0.05 for c in COUPLED}}
ANGLES = ("pend_angle", "ball_roll.position", "roll_joint.position")
FAILED_COST = 1e4

# name: (truth path, start S0, initial simplex step, bounds, log-scaled)
PARAMS = {
    "F_c": (("joint_friction", "steer", "F_c"), 0.42, 0.25, (0.01, 3.0), False),
    "F_s": (("joint_friction", "steer", "F_s"), 0.62, 0.25, (0.01, 3.0), False),
    "v_s": (("joint_friction", "steer", "v_s"), 0.05, 0.03, (0.005, 0.5), False),
    "viscous": (("joint_friction", "steer", "viscous"), 0.12, 0.06, (0.0, 1.0), False),
    "rotor": (("twin", "steer_rotor_inertia_kg_m2"), 0.0, 0.04, (0.0, 0.2), False),
    "set_tension": (("shell", "bedliner", "set_tension_n_m"), 1200.0, 0.4, (200.0, 2.0e4), True),
    "loss_peak": (("shell", "bedliner", "hysteresis_loss_peak"), 0.4, 0.1, (0.02, 0.95), False),
    "excess": (("shell", "profile_excess_m"), 0.0184, 0.005, (0.0, 0.05), False),
    "imbalance": (("twin", "pipe_com_y_m"), -0.0203, 0.005, (-0.05, 0.0), False),
    "p_coupled": (("logs", "steer_coupled", "pressure_kpa"), 9.5, 2.0, (4.0, 25.0), False),
    "p_shell": (("logs", "dynamic_data", "pressure_kpa"), 13.8, 2.0, (4.0, 25.0), False),
    "steer_offset_shell": (("logs", "dynamic_data", "steer_offset_rad"), 0.0, 0.1, (-0.6, 0.6), False),
    # the flat's set pressure: held at SET_AT_KPA by the calibration (budget); testbed_shell_log frees it
    "set_at": (("shell", "set_at_kpa"), 8.5, 2.0, (3.0, 25.0), False),
}
# not the calibration's: the shell log's pendulum held at a joint angle and let go a lead time
# before the shell (the replay's pendulum_at_let_go), for the shell_held stage
HELD = {"held_joint": (("logs", "dynamic_data", "held_joint_rad"), 1.0, 0.1, (0.4, 1.6), False),
        "lead": (("logs", "dynamic_data", "lead_s"), 0.3, 0.05, (0.02, 1.0), False)}
HELD_START = {"held_joint": 1.082, "lead": 0.3739, "set_tension": 7318.0, "loss_peak": 0.3822, "excess": 0.01484,
              "imbalance": -0.0109, "p_shell": 5.064}
STEER = ("F_c", "F_s", "v_s", "viscous", "rotor")
SHELL_LAW = ("set_tension", "loss_peak", "excess", "imbalance")
# what the shell_held fit and its folds free: the shell's law, both pressures and the hold
HELD_NAMES = SHELL_LAW + ("p_coupled", "p_shell", "held_joint", "lead")
SET_AT_KPA = 8.5


def base_truth() -> dict:
    """The test bed's own robot's truth with the new physics' fixed values and the real logs' section."""
    t = load_truth()
    t["shell"]["set_at_kpa"] = SET_AT_KPA
    t["logs"] = {"steer_coupled": {}, "dynamic_data": {}}
    return t


def with_params(truth: dict, theta: dict) -> dict:
    out = copy.deepcopy(truth)
    for name, value in theta.items():
        path = PARAMS[name][0]
        d = out
        for k in path[:-1]:
            d = d.setdefault(k, {})
        d[path[-1]] = float(value)
    return out


def s0() -> dict:
    return {n: p[1] for n, p in PARAMS.items()}


_LOGS = {}


def log_of(name):
    if name not in _LOGS:
        _LOGS[name] = read_log(REAL / f"{name}.csv")
    return _LOGS[name]


class Cache:
    """Every evaluation (log, parameters) -> RMS per column, kept on disk (resume)."""

    def __init__(self, path: Path):
        self.path = path
        self.d = {}
        if path.is_file():
            for line in path.read_text().splitlines():
                if line.strip():
                    r = json.loads(line)
                    self.d[r["key"]] = r["rms"]

    @staticmethod
    def key(log: str, truth: dict) -> str:
        return hashlib.sha256(json.dumps([log, truth], sort_keys=True).encode()).hexdigest()[:24]

    def rms(self, log: str, truth: dict) -> dict | None:
        k = self.key(log, truth)
        if k not in self.d:
            lg = log_of(log)
            try:
                rows, pred = simulate_log(lg, truth)
                r = rms_by_column(lg, rows, pred)
            except (RoboballError, RuntimeError, ValueError) as exc:
                r = {"error": str(exc).splitlines()[0][:200]}
            self.d[k] = r
            with self.path.open("a") as fh:
                fh.write(json.dumps({"key": k, "log": log, "rms": r}) + "\n")
        r = self.d[k]
        return None if "error" in r else r


def log_cost(r: dict | None, log: str) -> float:
    if r is None:
        return FAILED_COST
    return sum((r[c] / TARGET_RAD[log]) ** 2 for c in ANGLES if c in r)


def fit(cache: Cache, logs, names, fixed: dict, evals: int, label: str, start: dict | None = None) -> dict:
    """Nelder-Mead over `names` (from S0, or from `start` where it gives a value) on `logs`, the
    other parameters at `fixed`."""
    start = {**s0(), **(start or {})}
    x0 = np.zeros(len(names))

    def theta_of(x):
        th = dict(fixed)
        for xi, n in zip(x, names):
            _, _, step, (lo, hi), logscale = PARAMS[n]
            v0 = start[n]
            v = v0 * np.exp(step * xi) if logscale else v0 + step * xi
            th[n] = float(np.clip(v, lo, hi))
        return th

    best = {"cost": np.inf}
    n_eval = [0]

    def cost(x):
        th = theta_of(x)
        tr = with_params(base_truth(), th)
        c = sum(log_cost(cache.rms(lg, tr), lg) for lg in logs)
        n_eval[0] += 1
        if c < best["cost"]:
            best.update(cost=c, theta=th)
            print(f"  {label} eval {n_eval[0]}: cost {c:.2f} " + ", ".join(f"{n} {th[n]:.4g}" for n in names), flush=True)
        return c

    for n in names:
        if n not in start:
            raise KeyError(n)
    simplex = np.vstack([x0] + [np.eye(len(names))[i] for i in range(len(names))])
    minimize(cost, x0, method="Nelder-Mead", options=dict(maxfev=evals, initial_simplex=simplex, xatol=1e-3, fatol=1e-3))
    return best


def rms_all(cache: Cache, theta: dict, logs=LOGS) -> dict:
    tr = with_params(base_truth(), theta)
    return {lg: cache.rms(lg, tr) for lg in logs}


def stage_file(name: str) -> Path:
    return WORK / f"{name}.json"


def done(name: str):
    f = stage_file(name)
    return json.loads(f.read_text()) if f.is_file() else None


def save(name: str, obj: dict) -> None:
    stage_file(name).write_text(json.dumps(obj, indent=2, sort_keys=True))


def run_stage(name: str, cache: Cache, evals: int) -> dict:
    if done(name):
        print(f"{name}: done (results/testbed_calibration/{name}.json)")
        return done(name)
    t0 = time.time()
    start = s0()
    if name == "stand":
        b = fit(cache, [STAND], STEER, {}, evals, name)
        out = {"theta": {n: b["theta"][n] for n in STEER}}
    elif name == "shell":
        steer = need("stand")["theta"]
        names = SHELL_LAW + ("p_coupled", "p_shell", "steer_offset_shell")
        b = fit(cache, [SHELL, *COUPLED], names, steer, evals, name)
        out = {"theta": b["theta"]}
        out["in_sample"] = rms_all(cache, b["theta"])
    elif name == "shell_held":
        # the committed calibration's shell fit again, the shell log's pendulum let go from a hold;
        # from the law and hold the shell log alone gives with the calibrated joint
        # (testbed_shell_log.py --driven: held_stand), the repeats' pressure as calibrated
        PARAMS.update(HELD)
        cal = json.loads(OUT.read_text())["calibrated"]
        start = {**{k: v for k, v in cal.items() if k != "steer_offset_shell"}, **HELD_START}
        b = fit(cache, [SHELL, *COUPLED], HELD_NAMES, {k: start[k] for k in STEER}, evals, name, start=start)
        out = {"theta": b["theta"], "in_sample": rms_all(cache, b["theta"])}
    elif name.startswith("out_held_"):
        out = held_fold(name[len("out_held_"):], cache, evals)
    elif name == "out_" + STAND:
        shell = need("shell")["theta"]
        fixed = {k: v for k, v in shell.items() if k not in STEER}
        b = fit(cache, list(COUPLED), STEER, fixed, evals, name)
        out = {"theta": b["theta"], "held_out": rms_all(cache, b["theta"], [STAND])[STAND]}
    elif name == "out_" + SHELL:
        steer = need("stand")["theta"]
        names = SHELL_LAW + ("p_coupled",)
        b = fit(cache, list(COUPLED), names, {**steer, "p_shell": start["p_shell"],
                                              "steer_offset_shell": start["steer_offset_shell"]}, evals, name)
        # the left-out log's own unknowns (its pressure, its pendulum at the release), fitted on it alone
        fixed = {k: v for k, v in b["theta"].items() if k not in ("p_shell", "steer_offset_shell")}
        nb = fit(cache, [SHELL], ("p_shell", "steer_offset_shell"), fixed, max(12, evals // 3), name + " nuisance")
        out = {"theta": nb["theta"], "held_out": rms_all(cache, nb["theta"], [SHELL])[SHELL]}
    elif name.startswith("out_steer_coupled"):
        left = name[4:]
        steer = need("stand")["theta"]
        names = SHELL_LAW + ("p_coupled", "p_shell", "steer_offset_shell")
        b = fit(cache, [SHELL, *[c for c in COUPLED if c != left]], names, steer, evals, name)
        out = {"theta": b["theta"], "held_out": rms_all(cache, b["theta"], [left])[left]}
    else:
        raise SystemExit(f"unknown stage {name}")
    out["seconds"] = round(time.time() - t0, 1)
    out["evals"] = evals
    save(name, out)
    print(f"{name}: {out.get('in_sample') or out.get('held_out')} ({out['seconds']} s)", flush=True)
    return out


def held_fold(left: str, cache: Cache, evals: int) -> dict:
    """`left` held out of the shell_held fit.  Every fold starts from S0 and the hold's own start
    (HELD: 1 rad, 0.3 s), not from a fit that saw the left-out log; the steer parameters are the
    committed calibration's (the stand's).  The stand's fold refits them on the repeats with
    shell_held's law; the shell log's fits the law on the repeats, then the log's own unknowns
    (pressure, hold) on it alone; a repeat's fits the law, the hold and both pressures on the
    others."""
    PARAMS.update(HELD)
    steer = {k: json.loads(OUT.read_text())["calibrated"][k] for k in STEER}
    if left == STAND:
        fixed = {k: v for k, v in need("shell_held")["theta"].items() if k not in STEER}
        b = fit(cache, list(COUPLED), STEER, fixed, evals, "out_held_" + left)
    elif left == SHELL:
        b = fit(cache, list(COUPLED), SHELL_LAW + ("p_coupled",), steer, evals, "out_held_" + left)
        b = fit(cache, [SHELL], ("p_shell", "held_joint", "lead"), b["theta"], max(12, evals // 3),
                "out_held_" + left + " nuisance")
    elif left in COUPLED:
        b = fit(cache, [SHELL, *[c for c in COUPLED if c != left]], HELD_NAMES, steer, evals, "out_held_" + left)
    else:
        raise SystemExit(f"unknown log {left}")
    return {"theta": b["theta"], "held_out": rms_all(cache, b["theta"], [left])[left]}


def need(stage: str) -> dict:
    d = done(stage)
    if d is None:
        raise SystemExit(f"stage {stage} has not run yet (run it first: --stages {stage})")
    return d


def stands_and_ramp(truth: dict) -> dict:
    """The calibrated twin put down at its locked-steer rest with the pendulum hanging (8 s),
    and let go on the ramp (2 m, 4 s), at every campaign pressure: where it comes to rest
    (rad), its largest lean (rad), its last 0.5 s's drift (rad); the ramp's largest sideways
    lean (rad) and peak drive rate (rad/s)."""
    from roboball.testbed.physics import true_robot
    from roboball.testbed.run import coupled_release, run_free

    rest = true_robot(truth).shell_rest_angle
    t = np.linspace(0.0, 8.0, 801)
    out = {}
    for p in truth["campaign"]["pressures_kpa"]:
        pipe = coupled_release(p, t, rest, -rest, None, truth=truth)["pipe_angle_rad"]
        df, _, _ = run_free("ramp", 0.0, 4.0, p, truth, ramp_length_m=truth["campaign"]["ramp"]["length_m"])
        out[str(p)] = {"rest_pipe_angle_rad": float(pipe[-1]), "largest_lean_rad": float(np.max(np.abs(pipe))),
                       "drift_last_0_5_s_rad": float(abs(pipe[-1] - pipe[-51])),
                       "ramp_largest_lean_rad": float(np.max(np.abs(df["pipe_angle_rad"]))),
                       "ramp_peak_drive_rate_rad_s": float(np.max(df["drive_rate_rad_s"]))}
        print(f"{p} kPa: at rest {pipe[-1]:+.3f} rad (largest {out[str(p)]['largest_lean_rad']:.3f}); ramp lean "
              f"{out[str(p)]['ramp_largest_lean_rad']:.3f} rad, peak drive rate {out[str(p)]['ramp_peak_drive_rate_rad_s']:.2f} rad/s",
              flush=True)
    return out


def report(cache: Cache) -> dict:
    shell = need("shell")
    theta = shell["theta"]
    table = {}
    for lg in LOGS:
        fold = done("out_" + lg)
        table[lg] = {"target_rad": TARGET_RAD[lg], "in_sample": shell["in_sample"][lg],
                     "held_out": fold["held_out"] if fold else None}
    # before: the test bed's own robot (no new physics; the campaign's until it was the twin's),
    # the shell log at its calibration pressure
    # 13.8 kPa, the repeats at 6.9 kPa (its best pressure, docs/testbed.md)
    camp = load_truth()
    camp["logs"] = {"steer_coupled": {"pressure_kpa": 6.9}, "dynamic_data": {"pressure_kpa": 13.8}}
    for lg in LOGS:
        table[lg]["campaign_robot"] = cache.rms(lg, camp)
    out = {"calibrated": theta, "set_at_kpa": SET_AT_KPA, "logs": table,
           "folds": {lg: (done("out_" + lg) or {}).get("theta") for lg in LOGS},
           "stands_and_ramp": stands_and_ramp(with_params(base_truth(), theta))}
    OUT.write_text(json.dumps(out, indent=2, sort_keys=True) + "\n")
    print(f"wrote {OUT.relative_to(ROOT)}")
    print("log | target (rad) | in sample | held out | the campaign's robot   (RMS rad: angle columns)")
    for lg, row in table.items():
        def f(r):
            return "-" if r is None else " / ".join(f"{r[c]:.3f}" for c in ANGLES if c in r)
        print(f"{lg} | {row['target_rad']} | {f(row['in_sample'])} | {f(row['held_out'])} | {f(row['campaign_robot'])}")
    print("calibrated: " + ", ".join(f"{n} {v:.4g}" for n, v in theta.items()))
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stages", default="stand,shell," + ",".join("out_" + lg for lg in LOGS))
    ap.add_argument("--evals", type=int, default=50)
    ap.add_argument("--report", action="store_true")
    args = ap.parse_args()
    if not all((REAL / f"{lg}.csv").is_file() for lg in LOGS):
        print(f"the five real logs are not all in {REAL}")
        return 1
    WORK.mkdir(parents=True, exist_ok=True)
    cache = Cache(WORK / "evaluations.jsonl")
    if not args.report:
        for st in [s for s in args.stages.split(",") if s]:
            run_stage(st, cache, args.evals)
    else:
        report(cache)
    return 0


if __name__ == "__main__":
    sys.exit(main())
