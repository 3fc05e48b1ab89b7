"""Time-step convergence of a ramp descent, for each contact model.

A Drake run at step dt is compared with a reference run at dt / `refine` (4 by default: issue 7's
"a reference run at a quarter of the time step") by the point mean error of eq. 12
(roboball.metrics.pme), with the reference in the place of the measured speed.  The
same scenario as the pipeline's ramp descents: the full robot on the 16 deg ramp, Majd friction
(Table I) on both joints, released from rest with the pipe upright.  Shell terms at one pressure
are given explicitly (`ShellParams`), so the study does not depend on fitted results.

Used by `benchmarks/sim_speed.py` (which prints the study next to the real-time factors) and by
`tests/sim/test_convergence.py` (which holds the pipeline's step to 1% PME).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from roboball.metrics import pme
from roboball.sim.plant import build
from roboball.sim.scenarios import simulate
from roboball.sim.spec import ShellParams, SimSpec

# The benchmark's shell at 13.8 kPa (the mid test pressure): zeta and omega_n close to the
# test bed's regression there, and the paper's carried-forward hydroelastic dissipation x0.5.
STUDY_PRESSURE_KPA = 13.8
STUDY_SHELL = ShellParams(zeta=0.10, omega_n=2.75, dissipation_scale=0.5)
SAMPLE_RATE_HZ = 100.0


def ramp_spec(contact: str, dt: float, pressure_kpa: float = STUDY_PRESSURE_KPA,
              shell: ShellParams = STUDY_SHELL) -> SimSpec:
    """A ramp descent of the full robot with Majd friction on both joints."""
    return SimSpec(kind="ramp", contact=contact, friction={"steer": "majd", "drive": "majd"}, dt=dt,
                   pressure_kpa=pressure_kpa, shell=replace(shell))


def timed_descent(spec: SimSpec, duration: float, release: float = 0.0) -> tuple[np.ndarray, float]:
    """(drive_rate samples at SAMPLE_RATE_HZ, wall seconds of the simulation; build excluded)."""
    built = build(spec, sample_period=1.0 / SAMPLE_RATE_HZ)
    t0 = time.perf_counter()
    df = simulate(spec, release, duration, built=built, sample_rate_hz=SAMPLE_RATE_HZ)
    return df.drive_rate_rad_s.to_numpy(), time.perf_counter() - t0


@dataclass
class StepResult:
    contact: str
    dt_s: float
    ref_dt_s: float
    real_time_x: float          # simulated seconds per wall second at dt
    pme_vs_ref_percent: float   # eq. 12 with the reference run as the "measured" speed

    def within(self, tol_percent: float) -> bool:
        return bool(np.isfinite(self.pme_vs_ref_percent) and abs(self.pme_vs_ref_percent) <= tol_percent)


def step_study(contact: str, dts, duration: float = 2.0, refine: int = 4,
               pressure_kpa: float = STUDY_PRESSURE_KPA, shell: ShellParams = STUDY_SHELL) -> list[StepResult]:
    """Each step in `dts` against its own reference at dt / `refine`.  References shared between
    steps (dt / 4 of one step is another step) are run once."""

    runs: dict = {}

    def run(dt: float):
        key = round(dt * 1e9)
        if key not in runs:
            runs[key] = timed_descent(ramp_spec(contact, dt, pressure_kpa, shell), duration)
        return runs[key]

    out = []
    for dt in dts:
        w, wall = run(dt)
        w_ref, _ = run(dt / refine)
        out.append(StepResult(contact, float(dt), float(dt / refine), duration / wall, pme(w_ref, w)))
    return out
