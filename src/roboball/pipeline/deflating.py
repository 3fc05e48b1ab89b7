"""Beyond the paper: a ramp descent while the shell deflates (Fig. S1).

The paper (section V) cannot change pressure during a run.  This stage runs the ramp descent
three times per contact model: at the schedule's start pressure, at its end pressure, and
following the schedule (roboball.sim.schedule_run), and draws the drive rate of each with the
pressure above it.  The injected shell follows p(t) continuously through its pressure input; the
hydroelastic shell gets new contact properties every `hydro_update_s` (Drake allows no more).
"""
from __future__ import annotations

import pandas as pd

from roboball.atomic import write_csv_atomic
from roboball.errors import RoboballError

STAGES = ("deflating_ramp",)


def descent_spec(contact: str, dt: float = 1e-3, dissipation_scale: float = 1.0, modulus_scale: float = 1.0,
                 geometry: str = "planar", friction_params: dict | None = None):
    """The Fig. S1 descent's simulation: ramp, Majd friction on both joints, the injected shell in
    the drive direction only; the scales apply to the hydroelastic shell."""
    from roboball.sim.spec import ShellParams, SimSpec

    hydro = contact == "hydroelastic"
    shell = ShellParams(injected_steer=False, injected_drive=True, geometry=geometry,
                        dissipation_scale=dissipation_scale if hydro else 1.0,
                        modulus_scale=modulus_scale if hydro else 1.0)
    return SimSpec(kind="ramp", contact=contact, friction={"steer": "majd", "drive": "majd"},
                   friction_params={k: v for k, v in (friction_params or {}).items() if v}, shell=shell, dt=dt)


def run_cases(laws, schedule, contacts=("injected", "hydroelastic"), duration: float = 3.0, release: float = 0.0,
              dt: float = 1e-3, dissipation_scale: float = 1.0, modulus_scale: float = 1.0, geometry: str = "planar",
              friction_params: dict | None = None, hydro_update_s: float = 0.05) -> pd.DataFrame:
    """Ramp descents at the schedule's first and last pressure and following it, per contact
    model; long table: contact, case, time_s, pressure_kpa, drive_rate_rad_s."""
    from roboball.sim.schedule import PressureSchedule
    from roboball.sim.schedule_run import simulate_schedule

    p_start, p_end = schedule.pressures_kpa[0], schedule.pressures_kpa[-1]
    cases = [(f"constant {p_start:g} kPa", PressureSchedule.constant(p_start)),
             (f"constant {p_end:g} kPa", PressureSchedule.constant(p_end)),
             ("schedule", schedule)]
    rows = []
    for contact in contacts:
        spec = descent_spec(contact, dt, dissipation_scale, modulus_scale, geometry, friction_params)
        for case, sched in cases:
            df = simulate_schedule(spec, sched, laws, release, duration, sample_rate_hz=100.0,
                                   hydro_update_s=hydro_update_s)
            rows.append(pd.DataFrame({"contact": contact, "case": case, "time_s": df.time_s,
                                      "pressure_kpa": df.pressure_kpa, "drive_rate_rad_s": df.drive_rate_rad_s}))
    return pd.concat(rows, ignore_index=True)


def plot(table: pd.DataFrame, schedule, out_png: str) -> None:
    """Fig. S1: pressure (top) and drive rate (bottom) of every case; PNG + PDF."""
    from roboball.figures.style import CONTACT_COLOURS, plt, save

    styles = {"schedule": "-"}
    cases = list(dict.fromkeys(table.case))
    for case, ls in zip([c for c in cases if c != "schedule"], ("--", ":")):
        styles[case] = ls
    fig, (ax_p, ax_w) = plt.subplots(2, 1, figsize=(7.5, 6.0), sharex=True, height_ratios=[1, 2.2])
    first = table[table.contact == table.contact.iloc[0]]
    for case in cases:
        d = first[first.case == case]
        ax_p.plot(d.time_s, d.pressure_kpa, color="k", ls=styles[case],
                  label="deflating shell" if case == "schedule" else case)
    ax_p.set_ylabel("shell pressure (kPa)")
    ax_p.legend(fontsize=8, loc="center right")
    for contact in dict.fromkeys(table.contact):
        for case in cases:
            d = table[(table.contact == contact) & (table.case == case)]
            label = f"{contact}, {'deflating' if case == 'schedule' else case}"
            ax_w.plot(d.time_s, d.drive_rate_rad_s, color=CONTACT_COLOURS.get(contact, "k"), ls=styles[case],
                      lw=1.8 if case == "schedule" else 1.1, label=label)
    ax_w.set_xlabel("time since release (s)")
    ax_w.set_ylabel("drive rate (rad/s)")
    ax_w.legend(fontsize=8, ncol=2, loc="upper center", bbox_to_anchor=(0.5, -0.14))   # inside, it hid a curve
    p0, p1 = schedule.pressures_kpa[0], schedule.pressures_kpa[-1]
    ax_p.set_title(f"Fig. S1: 16 deg ramp descent while the shell deflates {p0:g} -> {p1:g} kPa")
    save(fig, out_png)


def deflating_ramp(regression: str, out_png: str, out_csv: str = "", schedule_csv: str = "",
                   schedule_time_s: list = (), schedule_pressure_kpa: list = (),
                   p_start_kpa: float = 20.7, p_end_kpa: float = 6.9, duration: float = 3.0,
                   contacts: list = ("injected", "hydroelastic"), dissipation_scale: float = 1.0,
                   modulus_scale: float = 1.0, geometry: str = "planar", friction_steer: str = "",
                   friction_drive: str = "", dt: float = 0.001, hydro_update_s: float = 0.05) -> None:
    """Fig. S1 (PNG + PDF) and its traces (CSV): ramp descents at constant start and end
    pressure and while deflating (the schedule CSV, else the time/pressure lists, else linearly
    from p_start to p_end over the run)."""
    from roboball.sim.schedule import PressureSchedule, ShellLaws
    from roboball.identify.friction.fitted import read_joint_friction

    laws = ShellLaws.from_regression_csv(regression)
    if schedule_csv:
        schedule = PressureSchedule.from_csv(schedule_csv)
    elif schedule_time_s or schedule_pressure_kpa:
        try:
            times = tuple(float(x) for x in schedule_time_s)
            pressures = tuple(float(x) for x in schedule_pressure_kpa)
        except ValueError as exc:
            raise RoboballError(f"--schedule-time-s / --schedule-pressure-kpa: {exc}")
        schedule = PressureSchedule(times, pressures, source="--schedule-time-s/--schedule-pressure-kpa")
    else:
        schedule = PressureSchedule.linear(p_start_kpa, p_end_kpa, 0.0, duration)
    if schedule.is_constant:
        raise RoboballError(f"{schedule.source}: the schedule is constant; Fig. S1 compares a changing pressure "
                            "with its two ends")
    if not str(out_png).endswith(".png"):
        raise RoboballError(f"--out-png {out_png}: must end in .png (the PDF is written beside it)")
    fp = read_joint_friction(friction_steer, friction_drive)
    table = run_cases(laws, schedule, tuple(contacts), duration=duration, dt=dt,
                      dissipation_scale=dissipation_scale, modulus_scale=modulus_scale, geometry=geometry,
                      friction_params=fp, hydro_update_s=hydro_update_s)
    if out_csv:
        write_csv_atomic(table, out_csv)
    plot(table, schedule, out_png)
    summary = table.groupby(["contact", "case"]).drive_rate_rad_s.last()
    for (contact, case), w in summary.items():
        print(f"{contact:13s} {case:18s} drive rate at {duration:g} s: {w:.3f} rad/s")
