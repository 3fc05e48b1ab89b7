"""How fast can Drake's hydroelastic sphere rock? The ceiling behind acceptance 2 of issue 25.

    .venv/bin/python benchmarks/hydro_frequency_ceiling.py [--pressure-kpa 6.9] [--hints 0.1 0.05]
                                                          [--moduli 1e4 9.5e3 9e3 8.75e3 8.5e3 8e3]

Drake's hydroelastic sphere has no roll stiffness of its own (its pressure field is centred on
the sphere's centre, so the contact force passes through it); it rocks faster than eq. 5 only by
sinking, which shortens the lever from the contact to the centre. The calibration
(`roboball.identify.shell.hydro`) stops at its grid's softest modulus (configs/config.yaml,
shell.hydro_fit). This script goes below that floor, to where the shell sinks past half its radius
and the run stops (roboball.sim.scenarios.MAX_SINK_FRACTION), at the pipeline's mesh hint (0.1 m,
the authors') and finer ones, from the recorded releases at one pressure, with the dissipation the
calibration fitted there (omega_n hardly depends on it). It prints zeta and omega_n (means over the
releases, extracted by the recordings' own code), the depth the robot rests at, and the fastest
omega_n found against every pressure's recorded omega_n and its 10% band.

Needs `make figures` first (results/ingest, results/identify/hydro_tuned.csv). About 2-3 min.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from roboball.config import load_robot  # noqa: E402
from roboball.errors import SimulationError  # noqa: E402
from roboball.pipeline.hydro import release_angles, release_spec  # noqa: E402
from roboball.pipeline.simulation import drake_decay  # noqa: E402


def _releases(pressure_kpa: float) -> list[float]:
    """The recorded release angles at one pressure, read as the calibration reads them."""
    paths = sorted((ROOT / "results/ingest").glob(f"shell_rock_{pressure_kpa:g}kpa_r*.releases.json"))
    if not paths:
        sys.exit(f"hydro_frequency_ceiling: no releases at {pressure_kpa:g} kPa in results/ingest (run make figures)")
    return release_angles(paths)


def _spec(modulus: float, dissipation: float, hint: float, pressure_kpa: float | None = None):
    """The calibration's Drake release (roboball.pipeline.hydro.release_spec) at mesh hint `hint` (m)."""
    spec = release_spec(modulus, dissipation, 1e-3, pressure_kpa)
    spec.resolution_hint = hint
    return spec


def _rest_depth_mm(modulus: float, dissipation: float, hint: float) -> float:
    """The depth (mm) the robot held still on the ground rests at in its contact (nan when the
    contact does not hold it within the sinking limit)."""
    from roboball.sim.plant import build
    from roboball.sim.scenarios import set_release

    built = build(_spec(modulus, dissipation, hint))
    context = built.diagram.CreateDefaultContext()
    settled: dict = {}
    set_release(built, context, 0.0, settled=settled)   # upright: the run's own settling presses it in
    sink = float(next(iter(settled.values())))
    return 1e3 * sink if sink > 0.0 else float("nan")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pressure-kpa", type=float, default=6.9)
    ap.add_argument("--hints", type=float, nargs="+", default=[0.1, 0.05], metavar="M")
    ap.add_argument("--moduli", type=float, nargs="+", default=[1e4, 9.5e3, 9e3, 8.75e3, 8.5e3, 8e3], metavar="PA")
    args = ap.parse_args()
    table = pd.read_csv(ROOT / "results/identify/hydro_tuned.csv")
    row = table[np.isclose(table.pressure_kpa, args.pressure_kpa)]
    if row.empty:
        sys.exit(f"hydro_frequency_ceiling: {args.pressure_kpa:g} kPa is not a calibrated pressure")
    dissipation = float(row.hydro_dissipation_s_m.iloc[0])
    angles = _releases(args.pressure_kpa)
    guess = load_robot().omega_n_eq5
    print(f"releases at {args.pressure_kpa:g} kPa: {', '.join(f'{a:+.3f}' for a in angles)} rad; "
          f"dissipation {dissipation:.3g} s/m (the calibration's fit there)")
    print("| mesh hint (m) | modulus (Pa) | rests (mm deep) | zeta | omega_n (rad/s) | wall (s) |")
    print("|---|---|---|---|---|---|")
    best: dict = {}                 # mesh hint -> its fastest run
    for hint in args.hints:
        for modulus in sorted(args.moduli, reverse=True):
            t0 = time.perf_counter()
            spec = _spec(modulus, dissipation, hint, args.pressure_kpa)
            try:
                depth = _rest_depth_mm(modulus, dissipation, hint)
                runs = [drake_decay(spec, a, 9.0, guess) for a in angles]
            except SimulationError as exc:
                print(f"| {hint:g} | {modulus:.4g} | - | sinks: {str(exc).split('(')[0].strip()} | - | "
                      f"{time.perf_counter() - t0:.1f} |")
                break           # softer ones sink too
            z = float(np.mean([r["zeta"] for r in runs]))
            w = float(np.mean([r["omega_n_rad_s"] for r in runs]))
            print(f"| {hint:g} | {modulus:.4g} | {depth:.0f} | {z:.3f} | {w:.3f} | {time.perf_counter() - t0:.1f} |")
            if np.isfinite(w) and w > best.get(hint, {}).get("omega", 0.0):
                best[hint] = {"omega": w, "modulus": modulus, "depth": depth}
    if not best:
        sys.exit("hydro_frequency_ceiling: no run gave a decay")
    print(f"\nthe fastest run of each mesh (robot radius {1e3 * load_robot().radius:.0f} mm), against every "
          "pressure's recorded omega_n (the 10% band starts at 0.9 x recorded):")
    hints = sorted(best, reverse=True)
    print("| p (kPa) | omega_n recorded (rad/s) | 10% band from | "
          + " | ".join(f"hint {h:g} m: {best[h]['omega']:.3f} at {best[h]['modulus']:.4g} Pa, "
                       f"{best[h]['depth']:.0f} mm deep" for h in hints) + " |")
    print("|---|---|---|" + "---|" * len(hints))
    for _, r in table.iterrows():
        rec = float(r.omega_n_recorded_rad_s)
        print(f"| {r.pressure_kpa:g} | {rec:.3f} | {0.9 * rec:.3f} | "
              + " | ".join(f"{100 * (best[h]['omega'] / rec - 1):+.1f}%" for h in hints) + " |")


if __name__ == "__main__":
    main()
