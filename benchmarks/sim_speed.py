"""Real-time factor of each scenario and contact model, and the ramp's time-step convergence study.

    .venv/bin/python benchmarks/sim_speed.py [--repeats 3] [--duration 5] [--dt 0.001]
                                             [--study-dts-ms 0.5,1,2,4,10] [--study-duration 2]
                                             [--compare-sampled] [--skip-table | --skip-study]

Real-time factor = simulated seconds / wall seconds (build time excluded, reported apart).
Shell terms for injected/hydroelastic use zeta = 0.10, omega_n = 2.75 rad/s at 13.8 kPa;
friction is Table I Majd on both joints where the joint exists.

Convergence study (issue 7): for each contact model, a ramp descent at each step dt against a
reference at dt/4, scored by eq. 12's PME with the reference as the measured speed
(roboball.sim.convergence).  Then, per contact model, the largest studied step whose PME is
within 1% of its reference, and the real-time factor of a ramp descent at that step (median of
--repeats runs of --duration s) against the target: hydroelastic 10x, point 50x.
"""
import argparse
import platform
import statistics
import time
from dataclasses import replace

from roboball.errors import RoboballError
from roboball.sim.convergence import STUDY_PRESSURE_KPA, STUDY_SHELL, step_study, ramp_spec, timed_descent
from roboball.sim.plant import build
from roboball.sim.scenarios import simulate
from roboball.sim.spec import SimSpec

CASES = [
    ("steer_stand", "point", 0.8), ("drive_stand", "point", 0.6),
    ("shell_rock", "point", 0.3), ("shell_rock", "injected", 0.3), ("shell_rock", "hydroelastic", 0.3),
    ("ramp", "point", 0.0), ("ramp", "injected", 0.0), ("ramp", "hydroelastic", 0.0),
]
TARGET_X = {"hydroelastic": 10.0, "point": 50.0}
TOL_PERCENT = 1.0


def _timed(spec, release, args):
    """Median build and wall times of --repeats runs."""
    walls, builds = [], []
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        built = build(spec, sample_period=0.01)
        t1 = time.perf_counter()
        simulate(spec, release, args.duration, built=built)
        t2 = time.perf_counter()
        builds.append(t1 - t0)
        walls.append(t2 - t1)
    return statistics.median(builds), statistics.median(walls)


def speed_table(args):
    head = f"{'scenario':<12} {'contact':<13} {'build_s':>8} {'wall_s':>8} {'real_time_x':>12}"
    if args.compare_sampled:
        head += f" {'sampled_ports_x':>16} {'speed-up':>9}"
    print(head)
    for kind, contact, release in CASES:
        spec = SimSpec(kind=kind, contact=contact, friction={"steer": "majd", "drive": "majd"}, dt=args.dt,
                       pressure_kpa=STUDY_PRESSURE_KPA, shell=STUDY_SHELL)
        b, w = _timed(spec, release, args)
        line = f"{kind:<12} {contact:<13} {b:8.3f} {w:8.3f} {args.duration / w:12.1f}"
        if args.compare_sampled:     # Drake's default: every output port computed and stored each step
            _, ws = _timed(replace(spec, sampled_output_ports=True), release, args)
            line += f" {args.duration / ws:16.1f} {ws / w:8.2f}x"
        print(line)


def convergence(args):
    dts = [float(x) * 1e-3 for x in args.study_dts_ms.split(",")]
    print(f"\nramp time-step convergence: {args.study_duration:g} s descent from rest, PME (eq. 12) of a run at dt "
          f"against a reference at dt/4; within {TOL_PERCENT:g}% passes")
    print(f"{'contact':<13} {'dt_ms':>6} {'ref_dt_ms':>9} {'real_time_x':>12} {'pme_vs_ref_%':>13}")
    verdicts = []
    for contact in ("point", "injected", "hydroelastic"):
        good = []
        for dt in dts:
            try:
                (r,) = step_study(contact, [dt], duration=args.study_duration)
            except RoboballError as exc:
                print(f"{contact:<13} {dt * 1e3:6.2f} {dt * 250:9.3f} {'-':>12} {'failed':>13}  ({str(exc)[:80]})")
                continue
            print(f"{contact:<13} {dt * 1e3:6.2f} {r.ref_dt_s * 1e3:9.3f} {r.real_time_x:12.1f} "
                  f"{r.pme_vs_ref_percent:+13.2f}{'' if r.within(TOL_PERCENT) else '  over'}")
            if r.within(TOL_PERCENT):
                good.append(dt)
        if contact in TARGET_X:
            verdicts.append((contact, max(good) if good else None))
    print(f"\nlargest studied step within {TOL_PERCENT:g}% and its real-time factor "
          f"(median of {args.repeats} runs of {args.duration:g} s):")
    for contact, dt in verdicts:
        if dt is None:
            print(f"{contact:<13} no studied step is within {TOL_PERCENT:g}%")
            continue
        xs = [args.duration / timed_descent(ramp_spec(contact, dt), args.duration)[1] for _ in range(args.repeats)]
        x = statistics.median(xs)
        ok = "met" if x >= TARGET_X[contact] else "NOT met"
        print(f"{contact:<13} dt {dt * 1e3:g} ms: {x:.1f}x real time ({', '.join(f'{v:.1f}' for v in xs)}); "
              f"target {TARGET_X[contact]:g}x: {ok}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--duration", type=float, default=5.0)
    ap.add_argument("--dt", type=float, default=1e-3)
    ap.add_argument("--study-dts-ms", default="0.5,1,2,4,10")
    ap.add_argument("--study-duration", type=float, default=2.0)
    ap.add_argument("--skip-table", action="store_true", help="only the convergence study")
    ap.add_argument("--skip-study", action="store_true", help="only the speed table")
    ap.add_argument("--compare-sampled", action="store_true",
                    help="also time each case with Drake's sampled output ports (its default), in the same run")
    args = ap.parse_args()
    print(f"machine: {platform.machine()}, {platform.processor() or 'cpu'}, python {platform.python_version()}, "
          f"dt = {args.dt} s, {args.duration} s simulated, median of {args.repeats}")
    if not args.skip_table:
        speed_table(args)
    if not args.skip_study:
        convergence(args)


if __name__ == "__main__":
    main()
