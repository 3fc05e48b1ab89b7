"""What else could make the hydroelastic ramp fast, and what each option costs in accuracy.

    .venv/bin/python benchmarks/hydro_speed_options.py [--repeats 3] [--duration 3]
    LD_PRELOAD=/usr/lib/x86_64-linux-gnu/libtcmalloc_minimal.so.4 .venv/bin/python benchmarks/hydro_speed_options.py

Issue 7 asks for a hydroelastic ramp descent at >= 10x real time with PME within 1% of a run at a
quarter of the step.  benchmarks/sim_speed.py measures the pipeline's setting (`tamsi`, the
authors' mesh hint 0.1 m, 1 ms: the largest step within 1%).  This script measures the options
behind that choice, each against its cost:

1. Discrete contact approximation at 1 ms: real-time factor and PME against its own dt/4
   reference, for `lagged` (the fallback), `similar` and `tamsi` (the pipeline's; deprecated in
   Drake, removal announced for after 2026-09-01; still in 1.51.1).  The converged descents are compared too.
2. A coarser compliant mesh (hint 0.12 m: the next coarser sphere mesh, 8 instead of 20 contact
   polygons under the resting shell): real-time factor, ramp PME against the 0.1 m mesh, and the
   damping ratio and frequency of the locked-steer shell test (Fig. 10/11) at 6.9, 13.8 and
   20.7 kPa against the 0.1 m mesh.
3. The memory allocator of this process (glibc malloc unless LD_PRELOAD names another):
   about 30% of a hydroelastic step is malloc/free inside Drake's SAP driver, which allocates a
   new problem (and a context) every step.  Run the script under another allocator to compare;
   the allocator changes no number, only the speed.

Shell terms as in sim_speed.py: zeta 0.10, omega_n 2.75 rad/s at 13.8 kPa, dissipation x0.5.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path


sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from conftest import fit_damped  # noqa: E402  (the damped-sine fit the physics tests use)

from pydrake.systems.analysis import Simulator  # noqa: E402

from roboball.metrics import pme  # noqa: E402
from roboball.sim.convergence import ramp_spec, timed_descent  # noqa: E402
from roboball.sim.plant import build  # noqa: E402
from roboball.sim.scenarios import set_release, simulate  # noqa: E402
from roboball.sim.spec import ShellParams, SimSpec  # noqa: E402


def allocator() -> str:
    maps = Path("/proc/self/maps").read_text()
    for name in ("tcmalloc", "jemalloc", "mimalloc"):
        if name in maps:
            return name
    return "glibc malloc"


def real_time_x(spec: SimSpec, duration: float, repeats: int) -> float:
    built = build(spec, sample_period=0.01)
    walls = []
    for _ in range(repeats):
        sim = Simulator(built.diagram)
        ctx = sim.get_mutable_context()
        set_release(built, ctx, 0.0)
        sim.Initialize()
        t0 = time.perf_counter()
        sim.AdvanceTo(duration)
        walls.append(time.perf_counter() - t0)
    return duration / statistics.median(walls)


def contact_polygons(spec: SimSpec) -> int:
    built = build(spec, sample_period=0.01)
    sim = Simulator(built.diagram)
    ctx = sim.get_mutable_context()
    set_release(built, ctx, 0.0)
    sim.Initialize()
    sim.AdvanceTo(0.2)
    cr = built.plant.get_contact_results_output_port().Eval(built.plant.GetMyContextFromRoot(ctx))
    return sum(cr.hydroelastic_contact_info(i).contact_surface().num_faces() for i in range(cr.num_hydroelastic_contacts()))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--duration", type=float, default=3.0)
    args = ap.parse_args()
    warnings.filterwarnings("ignore")
    print(f"allocator: {allocator()}; real-time factors: median of {args.repeats} runs of {args.duration:g} s, "
          "dt 1 ms, Majd friction on both joints")

    print("\n1. discrete contact approximation (hydroelastic ramp, mesh hint 0.1 m)")
    print(f"{'approximation':<14} {'real_time_x':>11} {'PME vs dt/4':>12} {'w(2 s) rad/s':>13} {'ref w(2 s)':>11}")
    refs = {}
    for approx in ("lagged", "similar", "tamsi"):
        spec = replace(ramp_spec("hydroelastic", 1e-3), approximation=approx)
        w, _ = timed_descent(spec, 2.0)
        w_ref, _ = timed_descent(replace(spec, dt=0.25e-3), 2.0)
        refs[approx] = w_ref
        x = real_time_x(spec, args.duration, args.repeats)
        print(f"{approx:<14} {x:11.1f} {pme(w_ref, w):+11.2f}% {w[-1]:13.3f} {w_ref[-1]:11.3f}")
    for approx in ("similar", "tamsi"):
        print(f"converged descents, {approx} against lagged (both at 0.25 ms): PME {pme(refs['lagged'], refs[approx]):+.2f}%")

    print("\n2. compliant mesh (lagged, 1 ms)")
    base = ramp_spec("hydroelastic", 1e-3)
    w_fine, _ = timed_descent(base, 2.0)
    for hint in (0.1, 0.12):
        spec = replace(base, resolution_hint=hint)
        w, _ = timed_descent(spec, 2.0)
        print(f"hint {hint:.2f} m: {contact_polygons(spec):2d} contact polygons, "
              f"{real_time_x(spec, args.duration, args.repeats):5.1f}x, ramp PME against hint 0.1: {pme(w_fine, w):+.2f}%")
    print("locked-steer shell test (release 0.3 rad, 9 s), hydroelastic, dissipation x0.5:")
    for p, zeta, omega in ((6.9, 0.18, 2.45), (13.8, 0.10, 2.75), (20.7, 0.06, 3.05)):
        fits = {}
        for hint in (0.1, 0.12):
            spec = SimSpec(kind="shell_rock", contact="hydroelastic", pressure_kpa=p, dt=1e-3, resolution_hint=hint,
                           shell=ShellParams(zeta=zeta, omega_n=omega, dissipation_scale=0.5))
            df = simulate(spec, 0.3, 9.0, sample_rate_hz=100)
            fits[hint] = fit_damped(df.time_s, df.pipe_angle_rad)
        a, b = fits[0.1], fits[0.12]
        print(f"  {p:4.1f} kPa: zeta {a['zeta']:.4f} -> {b['zeta']:.4f} ({100 * (b['zeta'] / a['zeta'] - 1):+.1f}%), "
              f"omega_n {a['omega_n']:.3f} -> {b['omega_n']:.3f} rad/s ({100 * (b['omega_n'] / a['omega_n'] - 1):+.1f}%)")


if __name__ == "__main__":
    main()
