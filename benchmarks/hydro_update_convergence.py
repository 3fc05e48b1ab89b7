"""Does the deflating hydroelastic descent (Fig. S1) converge in its property-update interval?

    .venv/bin/python benchmarks/hydro_update_convergence.py [--regression CSV] [--intervals 0.2 0.1 ...]

Drake cannot take a hydroelastic modulus or dissipation as an input, so the Fig. S1 stage
(roboball.pipeline.deflating) replaces them in the running simulation every `hydro_update_s`
(config: deflating_ramp.hydro_update_s, 0.05 s), at the pressure of each segment's midpoint.
This script runs the Fig. S1 descent (16 deg ramp, 20.7 -> 6.9 kPa over 3 s, the pipeline's
carried-forward hydroelastic scales, Table I friction, as the rule runs it) with several update
intervals and prints the drive rate at 1, 2 and 3 s of each and its difference from the finest.
Needs the shell regression (`make figures` first).  About 1-2 min.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from roboball.pipeline.deflating import descent_spec  # noqa: E402
from roboball.sim.schedule import PressureSchedule, ShellLaws  # noqa: E402
from roboball.sim.schedule_run import simulate_schedule  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--regression", default=str(ROOT / "results/identify/shell_regression.csv"))
    ap.add_argument("--intervals", type=float, nargs="+", default=[0.2, 0.1, 0.05, 0.025, 0.0125], metavar="S")
    args = ap.parse_args()
    cfg = yaml.safe_load((ROOT / "configs/config.yaml").read_text())
    sched_cfg, scales = cfg["deflating_ramp"]["schedule"], cfg["shell"]["carried_forward"]
    duration = float(cfg["deflating_ramp"]["duration_s"])
    laws = ShellLaws.from_regression_csv(args.regression)
    schedule = PressureSchedule(tuple(sched_cfg["time_s"]), tuple(sched_cfg["pressure_kpa"]))
    spec = descent_spec("hydroelastic", float(cfg["ramp"]["dt_s"]), scales["dissipation_scale"],
                        scales["modulus_scale"])
    marks = [t for t in (1.0, 2.0, 3.0) if t <= duration]
    rates = {}
    print(f"hydroelastic descent, {schedule.pressures_kpa[0]:g} -> {schedule.pressures_kpa[-1]:g} kPa over "
          f"{duration:g} s; drive rate (rad/s) at {', '.join(f'{t:g}' for t in marks)} s")
    for h in sorted(args.intervals, reverse=True):
        t0 = time.perf_counter()
        df = simulate_schedule(spec, schedule, laws, 0.0, duration, sample_rate_hz=100.0, hydro_update_s=h)
        t = df.time_s.to_numpy()
        rates[h] = np.array([np.interp(m, t, df.drive_rate_rad_s.to_numpy()) for m in marks])
        print(f"  update every {h:<7g} s: {'  '.join(f'{w:.4f}' for w in rates[h])}   "
              f"({time.perf_counter() - t0:.1f} s wall)")
    finest = rates[min(rates)]
    print(f"relative to the finest ({min(rates):g} s), percent:")
    for h, w in rates.items():
        print(f"  update every {h:<7g} s: {'  '.join(f'{100 * (a / b - 1):+.3f}' for a, b in zip(w, finest))}")


if __name__ == "__main__":
    main()
