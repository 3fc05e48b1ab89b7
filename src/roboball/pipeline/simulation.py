"""Simulation stages: shell tests of every contact model, the hydroelastic sensitivity sweep,
and ramp descents scored by the point mean error (eq. 12)."""
from __future__ import annotations

import json
import math
import zlib

import numpy as np
import pandas as pd

from roboball.atomic import write_csv_atomic
from roboball.errors import RoboballError
from roboball.metrics import pme, speed_errors
from roboball.physics import shell as shell_laws

STAGES = ("shell_sim", "ramp_sim", "summarise")


# ---- shell regressions -> per-pressure shell parameters ------------------------------------
def shell_at(regression_csv: str, p_kpa: float) -> tuple[float, float]:
    """(zeta, omega_n) at pressure p from the pipeline's regression table."""
    t = pd.read_csv(regression_csv).set_index("name")["value"]
    zeta = shell_laws.zeta_of_p(p_kpa, t["zeta_a"], t["zeta_b"])
    omega = shell_laws.omega_n_of_p(p_kpa, t["omega_n_c"], t["omega_n_d"])
    return float(zeta), float(omega)


def _releases(path):
    with open(path, encoding="utf-8") as fh:
        return json.load(fh)


def tuned_at(hydro_fit_csv: str, p_kpa: float) -> tuple[float, float]:
    """(hydro_modulus Pa, dissipation s/m) of the tuned hydroelastic shell at pressure p: the
    calibration's values (results/identify/hydro_tuned.csv), log-interpolated between its
    pressures; a pressure outside them is refused (the fit says nothing there)."""
    if not hydro_fit_csv:
        raise RoboballError("contact hydro_tuned needs the hydroelastic calibration (--hydro-fit)")
    f = pd.read_csv(hydro_fit_csv).sort_values("pressure_kpa")
    ps = f.pressure_kpa.to_numpy()
    if not in_tuned_range(p_kpa, (ps.min(), ps.max())):
        raise RoboballError(f"{hydro_fit_csv}: pressure {p_kpa:g} kPa is outside the calibrated "
                            f"{ps.min():g}-{ps.max():g} kPa")
    return tuple(float(np.exp(np.interp(p_kpa, ps, np.log(f[c].to_numpy()))))
                 for c in ("hydro_modulus_pa", "hydro_dissipation_s_m"))


def tuned_range(hydro_fit_csv: str) -> tuple[float, float]:
    """(lowest, highest) pressure (kPa) of the hydroelastic calibration's table."""
    ps = pd.read_csv(hydro_fit_csv).pressure_kpa
    return float(ps.min()), float(ps.max())


def in_tuned_range(p_kpa: float, tuned: tuple[float, float]) -> bool:
    """Whether p (kPa) lies within `tuned` (tuned_range's (lowest, highest)), to rounding."""
    lo, hi = tuned
    return lo - 1e-6 <= p_kpa <= hi + 1e-6


def shell_params(contact: str, p_kpa: float, regression: str, hydro_fit: str = "", **kw):
    """(Drake contact, ShellParams) of a pipeline contact model at pressure p: the paper's
    models take zeta and omega_n from the regression; `hydro_tuned` is Drake's hydroelastic
    contact with the calibrated modulus and dissipation.  `kw` go to ShellParams."""
    from roboball.sim.spec import ShellParams

    if contact == "point" and not regression:     # a campaign without a regression: point contact needs none
        return contact, ShellParams(**kw)
    if not regression:
        raise RoboballError(f"contact {contact} needs the shell regression (--regression): zeta(p), omega_n(p)")
    zeta, omega = shell_at(regression, p_kpa)
    if contact == "hydro_tuned":
        modulus, dissipation = tuned_at(hydro_fit, p_kpa)
        return "hydroelastic", ShellParams(zeta=zeta, omega_n=omega, hydro_modulus=modulus,
                                           hydro_dissipation=dissipation, **kw)
    return contact, ShellParams(zeta=zeta, omega_n=omega, **kw)


def drake_decay(spec, release_rad: float, duration: float, omega_guess: float) -> dict:
    """Release the Drake shell `spec` from `release_rad` and extract its decay with the same code
    as the recordings' (nan where no decay can be extracted)."""
    from roboball.identify.shell.decay import extract_decay
    from roboball.ingest.releases.record import Release
    from roboball.sim.scenarios import simulate

    df = simulate(spec, release_rad, duration, sample_rate_hz=100.0)
    t, y = df.time_s.to_numpy(), df.pipe_angle_rad.to_numpy()
    rel = Release(t_release_s=0.0, t_end_s=float(t[-1]), i_release=0, i_end=len(t) - 1,
                  y_release=float(y[0]), y_rest=float(np.mean(y[-100:])), held_from_s=0.0,
                  half_period_s=math.pi / omega_guess, noise=2e-4, kind="shell_rock")
    try:
        res = extract_decay(t, y, rel, noise=2e-4)
        return {"zeta": res.zeta, "zeta_se": res.zeta_se, "omega_n_rad_s": res.omega_n,
                "omega_n_se_rad_s": res.omega_n_se}
    except RoboballError:
        return {"zeta": float("nan"), "zeta_se": float("nan"), "omega_n_rad_s": float("nan"),
                "omega_n_se_rad_s": float("nan")}


def shell_sim(releases: str, regression: str, contact: str, out_csv: str, modulus_scale: float = 1.0,
              dissipation_scale: float = 1.0, duration: float = 9.0, dt: float = 0.001,
              hydro_fit: str = "") -> None:
    """Release the locked-steer Drake model like each recorded release; extract its decay with
    the same code as the data.  One row per release."""
    from roboball.sim.spec import SimSpec

    info = _releases(releases)
    p = info["pressure_kpa"]
    if p is None:
        raise RoboballError(f"{releases}: shell simulation needs the recording's pressure")
    drake_contact, sp = shell_params(contact, p, regression, hydro_fit, modulus_scale=modulus_scale,
                                     dissipation_scale=dissipation_scale)
    spec = SimSpec(kind="shell_rock", contact=drake_contact, pressure_kpa=p, dt=dt, shell=sp)
    rows = []
    for i, r in enumerate(info["releases"], start=1):
        row = drake_decay(spec, r["y_release"], duration, sp.omega_n)
        rows.append({"release": i, "pressure_kpa": p, "contact": contact, "modulus_scale": modulus_scale,
                     "dissipation_scale": dissipation_scale, "release_rad": r["y_release"],
                     "zeta_input": sp.zeta, "omega_n_input_rad_s": sp.omega_n, **row})
    write_csv_atomic(pd.DataFrame(rows), out_csv)


# ---- ramp descents -------------------------------------------------------------------------
def friction_params_of(law):
    from roboball.physics import friction
    return friction.PARAMS[law]


def ramp_window(rec, releases: str) -> tuple[np.ndarray, np.ndarray, float]:
    """The scored part of a recorded descent: times since the release (s) and drive rates
    (rad/s) from the release until the robot leaves the ramp, and the pipe angle held before
    the release (rad), from which every model's simulation starts."""
    r = _releases(releases)["releases"][0]
    t0 = r["t_release_s"]
    t_end = rec.meta.get("ramp_exit_s") or r["t_end_s"]
    t = rec.time
    on_ramp = (t >= t0) & (t <= t_end)
    pipe0 = float(np.median(rec.signal("pipe_angle_rad")[(t <= t0) & (t >= t0 - 0.3)])) \
        if "pipe_angle_rad" in rec.data else 0.0
    return t[on_ramp] - t0, rec.signal("drive_rate_rad_s")[on_ramp], pipe0


def ramp_sim(recording: str, releases: str, regression: str, contact: str, out_csv: str,
             out_trace: str = "", friction_steer: str = "", friction_drive: str = "",
             dissipation_scale: float = 1.0, modulus_scale: float = 1.0, dt: float = 0.001,
             posterior_draws: int = 0, seed: int = 0, hydro_fit: str = "") -> None:
    """Ramp descent of one recorded run with `contact`, Majd friction on both joints (fitted
    medians when given, else Table I), started from the recording's initial pipe angle; the
    drive rate is compared with the recording until the robot leaves the ramp.  The
    `posterior_draws` friction draws come from the campaign's `seed` and the run's name."""
    from roboball.ingest.recording import read_recording
    from roboball.sim.scenarios import simulate
    from roboball.sim.spec import SimSpec

    rec = read_recording(recording)
    tt, w_e, pipe0 = ramp_window(rec, releases)
    p = rec.pressure_kpa
    from roboball.identify.friction.fitted import read_joint_friction

    params = read_joint_friction(friction_steer, friction_drive)
    drake_contact, shell = shell_params(contact, p, regression, hydro_fit, modulus_scale=modulus_scale,
                                        dissipation_scale=dissipation_scale, injected_steer=False,
                                        injected_drive=True)
    duration = float(tt[-1]) + 0.05
    settled = {}    # the run and its friction draws start from the same settled pose

    def run(fp):
        spec = SimSpec(kind="ramp", contact=drake_contact, friction={"steer": "majd", "drive": "majd"},
                       friction_params={k: v for k, v in fp.items() if v}, pressure_kpa=p, shell=shell, dt=dt,
                       ramp_angle_deg=rec.ramp_angle_deg)
        df = simulate(spec, pipe0, duration, sample_rate_hz=200.0, settled=settled)
        return np.interp(tt, df.time_s.to_numpy(), df.drive_rate_rad_s.to_numpy())

    w_s = run(params)
    row = {"recording": rec.path.stem if rec.path else recording, "pressure_kpa": p, "contact": contact,
           **speed_errors(w_e, w_s), "initial_pipe_angle_rad": pipe0, "n_samples": int(tt.size),
           "ramp_time_s": float(tt[-1])}
    draws = []
    if posterior_draws and friction_steer and friction_drive:
        # the run's own stream: the same draws for every contact model of this run, and none that
        # move when another run joins the campaign
        rng = np.random.default_rng([seed, zlib.crc32(row["recording"].encode())])
        files = {k: _samples_and_held(v) for k, v in (("steer", friction_steer), ("drive", friction_drive))}
        samples = {k: pd.read_csv(path) for k, (path, _) in files.items()}
        majd = friction_params_of("majd")
        for _ in range(posterior_draws):
            fp = {}
            for joint, s in samples.items():
                i = int(rng.integers(len(s)))
                # a draw of the sampled parameters, with those the fit held (Majd's n) at their value
                fp[joint] = {**{k: v for k, v in files[joint][1].items() if k in majd},
                             **{c: float(s[c].iloc[i]) for c in s.columns if c in majd}}
            draws.append(pme(w_e, run(fp)))
        row.update(pme_draw_low=float(np.percentile(draws, 2.5)), pme_draw_high=float(np.percentile(draws, 97.5)),
                   pme_draw_median=float(np.median(draws)))
    write_csv_atomic(pd.DataFrame([row]), out_csv)
    if out_trace:
        write_csv_atomic(pd.DataFrame({"time_s": tt, "drive_rate_measured_rad_s": w_e,
                                       "drive_rate_sim_rad_s": w_s}), out_trace)


def _samples_and_held(fit_json) -> tuple[str, dict]:
    """(the fit's samples CSV, the parameters it held fixed {name: value})."""
    with open(fit_json, encoding="utf-8") as fh:
        d = json.load(fh)
    return d["samples_csv"], {k: float(v) for k, v in (d.get("fixed") or {}).items()}


def summarise(inputs: list, out_csv: str) -> None:
    """Concatenate per-job CSV rows into one table."""
    write_csv_atomic(pd.concat([pd.read_csv(p) for p in sorted(inputs)], ignore_index=True), out_csv)
