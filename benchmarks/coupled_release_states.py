"""Release states of the coupled steer test: taken from the data, or fitted by simulation?

    .venv/bin/python benchmarks/coupled_release_states.py [--models point injected authors_nm]

The diagnosis contract fits a `steer_coupled` baseline's release states; the coupled stage
(roboball.pipeline.coupled) takes them from each log instead: both angles at the first sample,
both rates from a quadratic over the first 0.1 s (roboball.diagnose.coupled.Repeat).  This script
measures what fitting them would change.  For each model (at the stage's fitted pressure, read
from results/coupled/real/coupled.json) and each real repeat, the four states (pipe and steer angle,
pipe and steer rate) are fitted by least squares of both coordinates in Drake:

* `free`: no bounds;
* `bounded`: each angle within 3 noise levels of its first sample (the logs' own noise,
  roboball.diagnose.sensor_fit.sample_noise) and each rate within 2 standard errors of the
  quadratic's slope: as far as the data leave the state open.

Printed per model and repeat: the states, the RMS of each coordinate and the Drake runs spent.
Needs `make figures` first (the shell regression, the real stand's Majd fit, the coupled
stage's pressure).  About 1-1.5 min per model.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from roboball.diagnose.coupled import RELEASE_RATE_S, read_repeats  # noqa: E402
from roboball.diagnose.sensor_fit import sample_noise  # noqa: E402
from roboball.identify.friction.fitted import read_stand_friction  # noqa: E402
from roboball.sim.coupled import model_spec, predict  # noqa: E402
from roboball.sim.schedule import ShellLaws  # noqa: E402

REAL = ROOT.parent / "shared" / "data" / "roboball_real"
NAMES = ("pipe angle (rad)", "steer angle (rad)", "pipe rate (rad/s)", "steer rate (rad/s)")


def data_state(rep) -> tuple[np.ndarray, np.ndarray]:
    """The stage's release state of `rep` (its first sample and `Repeat.release_rates`) and how
    far the data leave each entry open."""
    m = rep.t <= rep.t[0] + RELEASE_RATE_S
    tau = rep.t[m] - rep.t[0]
    noise = [sample_noise(rep.t, y) for y in (rep.pipe, rep.steer)]
    # the standard error of the quadratic's slope, which release_rates takes as the rate
    slope_se = [n * float(np.sqrt(np.polyfit(tau, y[m], 2, cov="unscaled")[1][1, 1]))
                for n, y in zip(noise, (rep.pipe, rep.steer))]
    rates = rep.release_rates()
    x0 = [rep.pipe[0], rep.steer[0], rates["pipe_rate"], rates["steer_rate"]]
    half = [3 * noise[0], 3 * noise[1], 2 * slope_se[0], 2 * slope_se[1]]
    return np.array(x0, dtype=float), np.array(half, dtype=float)


def fit(spec, rep, x0, half=None):
    """Least squares of both coordinates over the four release states; (x, residual, runs)."""
    from scipy.optimize import least_squares
    runs = [0]
    m = len(rep.t)

    def resid(x):
        runs[0] += 1
        p = predict(spec, rep.t, x[0], x[1], rates0={"pipe_rate": x[2], "steer_rate": x[3]})
        return np.concatenate([p["pipe_angle_rad"] - rep.pipe, p["steer_angle_rad"] - rep.steer])

    r0 = resid(x0)
    bounds = (-np.inf, np.inf) if half is None else (x0 - half, x0 + half)
    sol = least_squares(resid, x0, bounds=bounds, diff_step=[1e-3, 1e-3, 1e-2, 1e-2],
                        x_scale=[0.02, 0.02, 0.2, 0.2], max_nfev=10)
    rms = lambda r: (float(np.sqrt(np.mean(r[:m] ** 2))), float(np.sqrt(np.mean(r[m:] ** 2))))
    return sol.x, rms(r0), rms(sol.fun), runs[0]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--models", nargs="+", default=["point", "injected", "authors_nm"])
    ap.add_argument("--results", default=str(ROOT / "results"))
    args = ap.parse_args(argv)
    res = Path(args.results)
    laws = ShellLaws.from_regression_csv(res / "identify" / "shell_regression.csv")
    friction = read_stand_friction(res / "friction" / "real" / "steer_majd.json")
    p_kpa = json.loads((res / "coupled" / "real" / "coupled.json").read_text())["pressure"]["p_kpa"]
    reps = read_repeats(sorted(REAL.glob("steer_coupled_*.csv")))
    print(f"pressure {p_kpa:.2f} kPa (the coupled stage's); states: " + ", ".join(NAMES))
    for name in args.models:
        spec = model_spec(name, p_kpa, laws, friction)
        for rep in reps:
            x0, half = data_state(rep)
            print(f"{name} {rep.name}: from the data {np.round(x0, 3).tolist()} "
                  f"(open by +-{np.round(half, 4).tolist()})")
            for label, h in (("free", None), ("bounded", half)):
                t0 = time.perf_counter()
                x, before, after, runs = fit(spec, rep, x0, h)
                print(f"  {label:7s} {np.round(x, 3).tolist()}  RMS pipe, steer {before[0]:.4f}, {before[1]:.4f}"
                      f" -> {after[0]:.4f}, {after[1]:.4f} rad  ({runs} runs, {time.perf_counter() - t0:.1f} s)",
                      flush=True)


if __name__ == "__main__":
    main()
