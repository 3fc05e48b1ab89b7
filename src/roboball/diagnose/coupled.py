"""The coupled steer test scored in Drake (issue 27): the repeats, the pressure, the authors' objective.

* `read_repeats`: the coupled logs (native or recording format), each from its let-go.
* `fit_pressure`: the logs give no pressure.  It is fitted as one unknown shared by the repeats,
  with the injected model (the one the pressure enters through the shell regression zeta(p),
  omega_n(p)): a grid of Drake runs over `PRESSURE_GRID_KPA`, the summed squared error of both
  coordinates interpolated by a cubic spline in p, its minimum and a profile interval
  (SSE - SSE_min <= 3.84 s^2 with s^2 the residual variance per sample, inflated by the
  residual's autocorrelation time: neighbouring samples of a smooth residual are not independent).
  The same grid gives each leave-one-out fold's pressure (the repeats it trains on) at no cost.
* `authors_loss` / `fit_authors_objective`: the authors' own objective (optimize_contact.py,
  authors-code.md): the repeats averaged sample by sample over the shortest one, on the first
  repeat's time base; the model released at rest from the averages' first samples; loss
  mean(exp(-t / 3 s) (phi_model - phi_avg)^2) of the pipe angle.  Minimised over
  [hydro_modulus, dissipation] by Nelder-Mead started FROM the authors' parameters, so that
  our optimum can be no worse than theirs in the same Drake model.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from roboball.errors import RoboballError
from roboball.metrics import residual_tau_int
from roboball.sim.coupled import AUTHORS_NM, coupled_spec, model_spec, predict
from roboball.sim.spec import ShellParams

COORDS = ("pipe_angle_rad", "steer_angle_rad")
# 1 to 5 psi; the shell regression's data span 6.9-20.7 kPa: above it the laws are extrapolated
PRESSURE_GRID_KPA = tuple(np.round(np.linspace(6.9, 34.5, 9), 2))
REGRESSION_SPAN_KPA = (6.9, 20.7)
AUTHORS_TAU_S = 3.0
# The logs start a few samples after the let-go, already moving (pipe 0.18-0.37 rad/s): each
# run starts at the first sample with the rates of a quadratic fitted to the first 0.1 s.
RELEASE_RATE_S = 0.1
# s: a diagnosis needs the swing over and its return (the real repeats last 3.3-5.3 s; the shell
# crosses its rest by about 1.4 s), and a held-out third that still holds part of the swing
MIN_DURATION_S = 2.0


@dataclass
class Repeat:
    """One coupled log from its let-go: time (s, first sample 0) and both coordinates (rad)."""

    name: str
    t: np.ndarray
    pipe: np.ndarray
    steer: np.ndarray

    def coord(self, c: str) -> np.ndarray:
        return self.pipe if c == "pipe_angle_rad" else self.steer

    def release_rates(self) -> dict:
        """Both rates (rad/s) at the first sample: the slope of a quadratic fitted to the first
        RELEASE_RATE_S (at least three samples; fewer: at rest)."""
        m = self.t <= self.t[0] + RELEASE_RATE_S
        if m.sum() < 3:
            return {"pipe_rate": 0.0, "steer_rate": 0.0}
        tau = self.t[m] - self.t[0]
        return {"pipe_rate": float(np.polyfit(tau, self.pipe[m], 2)[1]),
                "steer_rate": float(np.polyfit(tau, self.steer[m], 2)[1])}


def read_repeats(paths) -> list[Repeat]:
    """The coupled logs, each a `Repeat`; a one-line error names a file that is not one."""
    from roboball.ingest.importers import read_any
    out = []
    for path in paths:
        rec = read_any(path, kind="steer_coupled")
        for c in COORDS:
            if not rec.has_signal(c):
                raise RoboballError(f"{path}: field {c}: a steer_coupled recording needs it")
        t = np.asarray(rec.time, dtype=float)
        if len(t) < 2 or not t[-1] - t[0] >= MIN_DURATION_S:
            span = t[-1] - t[0] if len(t) else 0.0
            raise RoboballError(f"{path}: {len(t)} samples over {span:.3g} s from the let-go; a steer_coupled "
                                f"diagnosis needs at least {MIN_DURATION_S:g} s (the swing over and back)")
        out.append(Repeat(Path(path).stem, t - t[0], np.asarray(rec.signal(COORDS[0]), float),
                          np.asarray(rec.signal(COORDS[1]), float)))
    return out


def logged_pressure_of(paths, pressure_kpa: float | None = None) -> float | None:
    """The pressure (kPa) the coupled recordings log, in their sidecars or as `pressure_kpa` for
    all: one value shared by every recording, or None when none logs one.  Repeats of one
    experiment share a pressure: a one-line error names a recording at another, or without one
    beside recordings with one."""
    from roboball.diagnose.data import same_pressure
    from roboball.ingest.importers import read_any
    first = None
    for k, path in enumerate(paths):
        p = read_any(path, kind="steer_coupled", pressure_kpa=pressure_kpa).pressure_kpa
        if k == 0:
            first = (path, p)
        elif not same_pressure(p, first[1]):
            raise RoboballError(f"{path}: pressure {p} kPa, not {first[1]} kPa as {first[0]}: repeats of one "
                                "coupled test share their pressure")
    return first[1] if first else None


def logged_pressure(reps, p_kpa: float) -> "PressureFit":
    """The logged pressure as the repeats' `PressureFit`: every fold at it, nothing fitted."""
    return PressureFit(float(p_kpa), (float(p_kpa), float(p_kpa)), (), [], {r.name: float(p_kpa) for r in reps})


def run(spec, rep: Repeat, built=None) -> dict:
    """The model `spec` released from the repeat's first sample with its release rates, at its
    sample times."""
    return predict(spec, rep.t, float(rep.pipe[0]), float(rep.steer[0]), built=built, rates0=rep.release_rates())


def rms(pred: dict, rep: Repeat) -> dict:
    """RMS error (rad) of each coordinate."""
    return {c: float(np.sqrt(np.mean((pred[c] - rep.coord(c)) ** 2))) for c in COORDS}


def sse(pred: dict, rep: Repeat) -> float:
    return float(sum(np.sum((pred[c] - rep.coord(c)) ** 2) for c in COORDS))


# ---- the pressure -------------------------------------------------------------------------
@dataclass
class PressureFit:
    """The shared pressure: best value, profile interval, the grid's errors, the folds' values."""

    p_kpa: float
    ci95_kpa: tuple
    grid_kpa: tuple
    sse_grid: list                      # per grid pressure, per repeat (rad^2)
    folds: dict = field(default_factory=dict)      # held-out repeat name -> p fitted without it
    extrapolated: bool = False          # the optimum lies outside the regression's data span


def _spline_min(grid, values) -> tuple[float, np.ndarray, np.ndarray]:
    from scipy.interpolate import CubicSpline
    fine = np.linspace(grid[0], grid[-1], 2001)
    curve = CubicSpline(grid, values)(fine)
    return float(fine[int(np.argmin(curve))]), fine, curve


def fit_pressure(reps: list[Repeat], laws, friction: dict, grid=PRESSURE_GRID_KPA) -> PressureFit:
    """The pressure shared by `reps` (see the module docstring)."""
    grid = np.asarray(grid, dtype=float)
    table, resid_at = [], {}
    for p in grid:
        spec = model_spec("injected", float(p), laws, friction)
        preds = [run(spec, r) for r in reps]
        table.append([sse(pr, r) for pr, r in zip(preds, reps)])
        resid_at[float(p)] = np.concatenate([pr[c] - r.coord(c) for pr, r in zip(preds, reps) for c in COORDS])
    table = np.asarray(table)
    p_best, fine, curve = _spline_min(grid, table.sum(axis=1))
    n = sum(len(COORDS) * len(r.t) for r in reps)
    resid = resid_at[float(grid[int(np.argmin(np.abs(grid - p_best)))])]
    # the residual variance from the best grid run (the spline may dip below zero near a perfect fit)
    s2 = float(table.sum(axis=1).min()) / max(n - 1, 1) * residual_tau_int(resid)
    inside = fine[curve - curve.min() <= 3.84 * s2]
    folds = {}
    if len(reps) > 1:
        for k, r in enumerate(reps):
            keep = [j for j in range(len(reps)) if j != k]
            folds[r.name] = _spline_min(grid, table[:, keep].sum(axis=1))[0]
    lo, hi = REGRESSION_SPAN_KPA
    return PressureFit(p_best, (float(inside.min()), float(inside.max())), tuple(float(g) for g in grid),
                       table.tolist(), folds, extrapolated=not lo <= p_best <= hi)


# ---- the authors' objective -----------------------------------------------------------------
def authors_average(reps: list[Repeat]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t, mean pipe angle, mean steer angle): sample-by-sample over the shortest repeat, on the
    first repeat's (by name) time base, as the authors' plot_these_files.py averages them."""
    reps = sorted(reps, key=lambda r: r.name)
    n = min(len(r.t) for r in reps)
    pipe = np.mean([r.pipe[:n] for r in reps], axis=0)
    steer = np.mean([r.steer[:n] for r in reps], axis=0)
    return reps[0].t[:n], pipe, steer


def authors_loss(params, reps: list[Repeat], friction: dict) -> float:
    """The authors' weighted mean squared pipe-angle error (rad^2) of our Drake model with a
    hydroelastic shell of [hydro_modulus (Pa), dissipation (s/m)] = params."""
    modulus, dissipation = float(params[0]), float(params[1])
    if modulus <= 0 or dissipation < 0:
        return math.inf
    t, pipe, steer = authors_average(reps)
    spec = coupled_spec("hydroelastic", ShellParams(hydro_modulus=modulus, hydro_dissipation=dissipation), friction)
    pred = predict(spec, t, float(pipe[0]), float(steer[0]))["pipe_angle_rad"]
    return float(np.mean(np.exp(-t / AUTHORS_TAU_S) * (pred - pipe) ** 2))


def fit_authors_objective(reps: list[Repeat], friction: dict, max_evals: int = 30, start=AUTHORS_NM) -> dict:
    """Nelder-Mead on the authors' objective from their parameters (modulus scaled by 1e5 Pa so
    both coordinates of the simplex move on the same scale); returns both losses."""
    from scipy.optimize import minimize
    scale = np.array([1e5, 1.0])
    theirs = authors_loss(start, reps, friction)
    res = minimize(lambda x: authors_loss(x * scale, reps, friction), np.asarray(start) / scale,
                   method="Nelder-Mead", options={"maxfev": max_evals, "xatol": 1e-3, "fatol": 1e-7,
                                                  "initial_simplex": _simplex(np.asarray(start) / scale)})
    ours_x = res.x * scale
    ours = float(res.fun)
    if ours > theirs:           # Nelder-Mead keeps its best vertex: the start is one
        ours_x, ours = np.asarray(start, float), theirs
    return {"theirs_params": [float(x) for x in start], "theirs_loss_rad2": theirs,
            "ours_params": [float(x) for x in ours_x], "ours_loss_rad2": ours, "evaluations": int(res.nfev)}


def _simplex(x0: np.ndarray) -> np.ndarray:
    """The start and a step of +50 % in each parameter: with a budget of a few tens of Drake
    runs the simplex has to be able to travel (scipy's default first steps are 5 %)."""
    return np.array([x0, x0 * [1.5, 1.0], x0 * [1.0, 1.5]])
