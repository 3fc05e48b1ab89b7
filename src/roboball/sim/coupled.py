"""The coupled steer test in Drake (issue 27): every shell model, named in one place.

The robot stands on flat ground, the drive joint held, the pendulum free on its steer joint with
the stand-fitted steer friction (the Majd fit of the real steer stand, with its reflected rotor
inertia delta_i), and the shell rocks in the steer direction from the recording's first sample
(the let-go).  What differs between the models is the shell only:

| model | shell |
|---|---|
| `point` | rigid point contact, no shell terms |
| `injected` | eq. 6-9 with zeta(p), omega_n(p) of the pipeline's shell regression |
| `hydroelastic` | eq. 10 modulus and eq. 11 dissipation at p |
| `hydro_half` | the paper's tuned hydroelastic: eq. 10/11 with the dissipation halved |
| `authors_nm` | the authors' Nelder-Mead fit to these repeats, [1.55201e5 Pa, 0.405 s/m] |
| `authors_hand` | the authors' hand-tuned pair for these repeats, [1.2e5 Pa, 0.75 s/m] |

`MODELS` is the list every consumer iterates (the pipeline stage, its figure and table); a new
shell model (e.g. a calibrated hydroelastic one) is one more entry here: a name, a label, whether
it needs the pressure, and a function of (pressure, shell laws) to `ShellParams`.  The pipeline's
own calibrated hydroelastic shell (`hydro_tuned`, Fig. S3) depends on a results table, so the
stage adds it with `calibrated` when the calibration exists.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from roboball.sim.scenarios import simulate
from roboball.sim.schedule import ShellLaws
from roboball.sim.spec import ShellParams, SimSpec

# The authors' published hydroelastic pairs for the coupled repeats (authors-code.md):
# [hydro_modulus Pa, dissipation s/m].
AUTHORS_NM = (1.55201e5, 0.405)
AUTHORS_HAND = (1.2e5, 0.75)
TUNED_DISSIPATION_SCALE = 0.5      # the paper's tuned hydroelastic model (section III-D)
# 2 ms: every model's trajectory within 1.5 mrad of its 1 ms run over 5 s (docs/coupled.md;
# tests/sim/test_coupled_scenario.py), at half the cost.
DT_S = 2e-3


@dataclass(frozen=True)
class ShellModel:
    """One shell model of the coupled test: `shell(p_kpa, laws)` -> (contact, ShellParams)."""

    name: str
    label: str
    needs_pressure: bool
    shell: Callable


def _injected(p, laws):
    return "injected", ShellParams(zeta=float(laws.zeta(p)), omega_n=float(laws.omega_n(p)))


def _hydro(p, laws, scale=1.0):
    return "hydroelastic", ShellParams(zeta=float(laws.zeta(p)), omega_n=float(laws.omega_n(p)),
                                       dissipation_scale=scale)


def fixed_hydro(modulus_pa: float, dissipation_s_m: float):
    """A hydroelastic shell of given [hydro_modulus, dissipation] (no pressure)."""
    return lambda p, laws: ("hydroelastic", ShellParams(hydro_modulus=float(modulus_pa),
                                                        hydro_dissipation=float(dissipation_s_m)))


MODELS = (
    ShellModel("point", "point contact", False, lambda p, laws: ("point", ShellParams())),
    ShellModel("injected", "injected (eq. 6-9)", True, _injected),
    ShellModel("hydroelastic", "hydroelastic (eq. 10/11)", True, _hydro),
    ShellModel("hydro_half", "hydroelastic, x0.5 dissipation (paper's tuned)", True,
               lambda p, laws: _hydro(p, laws, TUNED_DISSIPATION_SCALE)),
    ShellModel("authors_nm", "authors' Nelder-Mead [1.55e5 Pa, 0.405 s/m]", False, fixed_hydro(*AUTHORS_NM)),
    ShellModel("authors_hand", "authors' hand-tuned [1.2e5 Pa, 0.75 s/m]", False, fixed_hydro(*AUTHORS_HAND)),
)
MODEL_NAMES = tuple(m.name for m in MODELS)
CALIBRATED = "hydro_tuned"


def calibrated(at: Callable) -> ShellModel:
    """The pipeline's calibrated hydroelastic shell: `at(p_kpa)` -> (hydro_modulus Pa,
    dissipation s/m), the calibration's values at p (roboball.pipeline.simulation.tuned_at)."""
    def shell(p, laws):
        modulus, dissipation = at(p)
        return "hydroelastic", ShellParams(hydro_modulus=float(modulus), hydro_dissipation=float(dissipation))
    return ShellModel(CALIBRATED, "hydroelastic, calibrated (Fig. S3)", True, shell)


def model(name: str) -> ShellModel:
    for m in MODELS:
        if m.name == name:
            return m
    raise ValueError(f"unknown coupled shell model '{name}' (choose from {', '.join(MODEL_NAMES)})")


def coupled_spec(contact: str, shell: ShellParams, friction: dict, extra_terms=(), dt: float = DT_S) -> SimSpec:
    """The coupled scenario: `friction` the steer joint's Majd parameters with its reflected
    rotor inertia `delta_i` (kg m^2; the stand fit's calibrated stand), the drive joint held."""
    majd = {k: float(v) for k, v in friction.items() if k in ("f_w", "f_c", "sigma", "omega_c", "n")}
    delta_i = float(friction.get("delta_i", 0.0))
    return SimSpec(kind="steer_coupled", contact=contact, shell=shell, dt=dt,
                   friction={"steer": "majd", "drive": "none"}, friction_params={"steer": majd},
                   added_inertia={"steer": delta_i} if delta_i else {}, extra_terms=list(extra_terms))


def model_spec(name: str, p_kpa: float | None, laws: ShellLaws, friction: dict, dt: float = DT_S) -> SimSpec:
    """The Drake scenario of shell model `name` at pressure p_kpa (None for models without one)."""
    m = model(name)
    if m.needs_pressure and p_kpa is None:
        raise ValueError(f"coupled shell model '{name}' needs the pressure")
    contact, shell = m.shell(p_kpa, laws)
    spec = coupled_spec(contact, shell, friction, dt=dt)
    spec.pressure_kpa = p_kpa if m.needs_pressure else None
    return spec


def predict(spec: SimSpec, t: np.ndarray, pipe0: float, steer0: float, built=None, rates0: dict | None = None) -> dict:
    """Both coordinates at the times `t` (s, from the let-go at t[0]) of a run released from
    (pipe0, steer0), at rest or with `rates0` ({"pipe_rate", "steer_rate"}, rad/s):
    {"pipe_angle_rad": ..., "steer_angle_rad": ...}."""
    t = np.asarray(t, dtype=float)
    duration = float(t[-1] - t[0]) + 2 * spec.dt
    rate = 1.0 / (5 * spec.dt)           # the log at 100 Hz (dt 2 ms), interpolated to t
    df = simulate(spec, pipe0, duration, sample_rate_hz=rate, steer0=steer0, built=built, rates0=rates0)
    ts = df["time_s"].to_numpy() + t[0]
    return {c: np.interp(t, ts, df[c].to_numpy()) for c in ("pipe_angle_rad", "steer_angle_rad")}
