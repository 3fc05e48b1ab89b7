"""Hydroelastic calibration stages (issue 25): a grid of Drake shell releases over modulus and
dissipation, the fit at each pressure with Drake in the loop, and the table others read
(results/identify/hydro_tuned.csv) with the contact-volume law V(p) through its moduli.

The method is roboball.identify.shell.hydro's; these stages only run Drake and move files."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd

from roboball.atomic import write_csv_atomic
from roboball.errors import RoboballError

STAGES = ("hydro_grid", "hydro_fit", "hydro_summary")


def release_angles(releases: list) -> list[float]:
    """The release angles (rad) in the release files `releases` (sorted by path)."""
    out = []
    for path in sorted(releases):
        with open(path, encoding="utf-8") as fh:
            out += [float(r["y_release"]) for r in json.load(fh)["releases"]]
    if not out:
        raise RoboballError("hydroelastic calibration: the shell recordings hold no release")
    return out


def reference_release(releases: list) -> float:
    """The grid's release angle (rad): the recorded release of median size, over all pressures
    (Drake's zeta and omega_n move by 1-3% between the recorded sizes; the fit at each pressure
    then runs Drake from that pressure's own releases)."""
    angles = release_angles(releases)
    return sorted(angles, key=abs)[len(angles) // 2]


def release_spec(modulus: float, dissipation: float, dt: float, pressure_kpa: float | None = None):
    """The calibration's Drake run: the locked-steer hydroelastic shell at (modulus, dissipation)."""
    from roboball.sim.spec import ShellParams, SimSpec

    return SimSpec(kind="shell_rock", contact="hydroelastic", pressure_kpa=pressure_kpa, dt=dt,
                   shell=ShellParams(hydro_modulus=modulus, hydro_dissipation=dissipation))


def _omega_guess() -> float:
    from roboball.config import load_robot
    return load_robot().omega_n_eq5


def hydro_grid(releases: list, out_csv: str, modulus_pa: float, dissipation_min_s_m: float,
               dissipation_max_s_m: float, n_dissipation: int, duration: float = 9.0, dt: float = 0.001) -> None:
    """One column of the grid: Drake's hydroelastic shell at `modulus_pa`, released from the
    reference release, at `n_dissipation` log-spaced dissipations; zeta and omega_n of each run
    (nan where the decay cannot be extracted, the shell sinks through the ground, or a smaller
    dissipation was already overdamped)."""
    from roboball.errors import SimulationError
    from roboball.pipeline.simulation import drake_decay

    from roboball.identify.shell.hydro import ZETA_MAX

    y0 = reference_release(releases)
    guess = _omega_guess()
    rows = []
    overdamped = False
    for d in np.geomspace(dissipation_min_s_m, dissipation_max_s_m, n_dissipation):
        row = {"zeta": float("nan"), "omega_n_rad_s": float("nan")}
        if overdamped:       # zeta grows with the dissipation: once overdamped, every larger one is too
            print(f"hydro-grid: modulus {modulus_pa:.4g} Pa, dissipation {d:.4g} s/m: not run (overdamped below it)")
        else:
            try:
                row = drake_decay(release_spec(modulus_pa, float(d), dt), y0, duration, guess)
            except SimulationError as exc:  # too soft to hold the robot: a hole in the grid, said in the log
                print(f"hydro-grid: modulus {modulus_pa:.4g} Pa, dissipation {d:.4g} s/m: {exc}")
            overdamped = bool(row["zeta"] >= ZETA_MAX)
        rows.append({"hydro_modulus_pa": modulus_pa, "hydro_dissipation_s_m": float(d), "release_rad": y0,
                     "zeta": row["zeta"], "omega_n_rad_s": row["omega_n_rad_s"]})
    write_csv_atomic(pd.DataFrame(rows), out_csv)


def drake_evaluator(angles: list[float], pressure_kpa: float, duration: float, dt: float):
    """(modulus, dissipation) -> (zeta, omega_n): means over Drake releases from `angles` (nan
    when a release gives no decay or the shell sinks)."""
    from roboball.errors import SimulationError
    from roboball.pipeline.simulation import drake_decay

    guess = _omega_guess()

    def evaluate(modulus: float, dissipation: float) -> tuple[float, float]:
        spec = release_spec(float(modulus), float(dissipation), dt, pressure_kpa)
        try:
            rows = [drake_decay(spec, y, duration, guess) for y in angles]
        except SimulationError as exc:          # too soft: the shell sank; the fit steps back
            print(f"hydro-fit: modulus {modulus:.5g} Pa, dissipation {dissipation:.5g} s/m: {exc}")
            return float("nan"), float("nan")
        z = np.array([r["zeta"] for r in rows])
        w = np.array([r["omega_n_rad_s"] for r in rows])
        ok = np.isfinite(z) & np.isfinite(w)
        if not ok.all():                        # a mean over fewer releases than recorded is another target
            return float("nan"), float("nan")
        print(f"hydro-fit: modulus {modulus:.5g} Pa, dissipation {dissipation:.5g} s/m -> "
              f"zeta {z[ok].mean():.4f}, omega_n {w[ok].mean():.4f} rad/s")
        return float(z[ok].mean()), float(w[ok].mean())

    return evaluate


def hydro_fit(grid_csvs: list, decay_csvs: list, releases: list, pressure_kpa: float, out_csv: str,
              tol: float = 0.01, max_evals: int = 3, draws: int = 400, seed: int = 0,
              duration: float = 9.0, dt: float = 0.001) -> None:
    """Modulus and dissipation at one pressure: the grid's surrogate inverted at the recorded
    zeta and omega_n (mean over the releases at the pressure), corrected with Drake runs from the
    recorded releases, with 95% intervals (roboball.identify.shell.hydro)."""
    from roboball.identify.shell import hydro as hy

    grid = pd.concat([pd.read_csv(p) for p in sorted(grid_csvs)], ignore_index=True)
    pts = pd.concat([pd.read_csv(p) for p in sorted(decay_csvs)], ignore_index=True)
    pts = pts[np.isclose(pts.pressure_kpa, pressure_kpa)]
    target = hy.Target.of(pts)
    sur = hy.Surrogate.fit(grid)
    evaluate = drake_evaluator(release_angles(releases), pressure_kpa, duration, dt)
    cal = hy.calibrate(sur, target, evaluate, tol=tol, max_evals=max_evals)
    iv = hy.intervals(sur, target, cal, draws=draws, seed=seed)
    write_csv_atomic(pd.DataFrame([hy.calibration_row(pressure_kpa, sur, target, cal, iv)]), out_csv)


def hydro_summary(fits: list, out_csv: str, out_law_csv: str) -> None:
    """Every pressure's calibration in one table (results/identify/hydro_tuned.csv, read by the
    tuned contact model and by other stages), and the contact-volume law V(p) fitted through the
    moduli (eq. 10), one row."""
    from roboball.config import load_robot
    from roboball.identify.shell.hydro import volume_law

    table = pd.concat([pd.read_csv(p) for p in fits], ignore_index=True).sort_values("pressure_kpa")
    write_csv_atomic(table.reset_index(drop=True), out_csv)
    write_csv_atomic(pd.DataFrame([volume_law(table, load_robot().weight_n)]), out_law_csv)
