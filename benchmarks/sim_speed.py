"""Real-time factor of each scenario and contact model (median of N runs).

    .venv/bin/python benchmarks/sim_speed.py [--repeats 3] [--duration 5]

Real-time factor = simulated seconds / wall seconds (build time excluded, reported apart).
Shell terms for injected/hydroelastic use zeta = 0.10, omega_n = 2.75 rad/s at 13.8 kPa;
friction is Table I Majd on both joints where the joint exists.
"""
import argparse
import platform
import statistics
import time

from roboball.sim.plant import ShellParams, SimSpec, build
from roboball.sim.scenarios import simulate

CASES = [
    ("steer_stand", "point", 0.8), ("drive_stand", "point", 0.6),
    ("shell_rock", "point", 0.3), ("shell_rock", "injected", 0.3), ("shell_rock", "hydroelastic", 0.3),
    ("ramp", "point", 0.0), ("ramp", "injected", 0.0), ("ramp", "hydroelastic", 0.0),
]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--duration", type=float, default=5.0)
    ap.add_argument("--dt", type=float, default=1e-3)
    args = ap.parse_args()
    print(f"machine: {platform.machine()}, {platform.processor() or 'cpu'}, python {platform.python_version()}, "
          f"dt = {args.dt} s, {args.duration} s simulated, median of {args.repeats}")
    print(f"{'scenario':<12} {'contact':<13} {'build_s':>8} {'wall_s':>8} {'real_time_x':>12}")
    for kind, contact, release in CASES:
        spec = SimSpec(kind=kind, contact=contact, friction={"steer": "majd", "drive": "majd"}, dt=args.dt,
                       pressure_kpa=13.8, shell=ShellParams(zeta=0.10, omega_n=2.75, dissipation_scale=0.5))
        walls, builds = [], []
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            built = build(spec, sample_period=0.01)
            t1 = time.perf_counter()
            simulate(spec, release, args.duration, built=built)
            t2 = time.perf_counter()
            builds.append(t1 - t0)
            walls.append(t2 - t1)
        w = statistics.median(walls)
        print(f"{kind:<12} {contact:<13} {statistics.median(builds):8.3f} {w:8.3f} {args.duration / w:12.1f}")


if __name__ == "__main__":
    main()
