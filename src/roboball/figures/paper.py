"""Figures and tables for people: labelled axes with units, legends, the paper's figure number
in the file name.  Every figure is written as PNG and PDF (atomically)."""
from __future__ import annotations


import numpy as np
import pandas as pd

from roboball.atomic import write_csv_atomic, write_text_atomic
from roboball.errors import RoboballError
# The style, the atomic saver and the ingest QC plot live in .plotting, so that editing a figure
# here reruns the figure rules only (the ingest stage imports .plotting, not this module).
from roboball.figures.style import CONTACT_COLOURS, plt, save
from roboball.kinds import CONTACT_MODELS
from roboball.metrics import pme_table

STAGES = ("fig10", "fig11", "fig13_14", "table2")
# Columns of the ramp summary that fig13_14 needs (roboball.pipeline.simulation.speed_errors).
SUMMARY_COLUMNS = frozenset({"contact", "pressure_kpa", "pme_percent", "mape_percent", "rmse_rad_s"})


def _reg(table):
    t = pd.read_csv(table).set_index("name")
    return t


def _of(campaign: str) -> str:
    """' (<campaign> recordings)' for a title, '' without a campaign label."""
    return f" ({campaign} recordings)" if campaign else ""


# Fig. 10 runs the paper's hydroelastic control (eq. 10-11, no scaling) beside the calibrated one.
FIG10_NAMES = {"point": "point contact", "injected": "injected contact (eq. 6-9)",
               "hydroelastic": "hydroelastic contact (eq. 10-11)", "hydro_tuned": "hydroelastic, calibrated (Fig. S3)"}


def fig10(points: str, regression: str, sims: str, out_png: str, robot_yaml: str = "", campaign: str = "") -> None:
    """Fig. 10: recorded zeta and omega_n vs pressure (error bars), regressions with 95% bands,
    eq. 5 (dashed), and each contact model's simulated values.  `campaign` names where the
    recordings come from (config `campaign`), in the title."""
    from roboball.config import load_robot
    from roboball.identify.shell.regress import fit_regressions

    robot = load_robot(robot_yaml or None)
    pts = pd.read_csv(points)
    sim = pd.read_csv(sims)
    sim = sim[(sim.modulus_scale == 1.0) & (sim.dissipation_scale == 1.0)]
    reg = fit_regressions(pts)
    pp = np.linspace(pts.pressure_kpa.min() - 1, pts.pressure_kpa.max() + 1, 100)
    fig, axes = plt.subplots(2, 1, figsize=(9.5, 7.5), sharex=True)
    for ax, col, se, fit, label, unit, law in [
            (axes[0], "zeta", "zeta_se", reg.zeta, "damping ratio $\\zeta$", "-", "$\\zeta = a\\,e^{b p}$"),
            (axes[1], "omega_n_rad_s", "omega_n_se_rad_s", reg.omega_n, "natural frequency $\\omega_n$", "rad/s",
             "$\\omega_n = c + d\\,p$")]:
        ax.errorbar(pts.pressure_kpa, pts[col], yerr=1.96 * pts[se], fmt="o", color="k", ms=4, capsize=2,
                    label="recorded releases (95% CI)")
        lo, hi = fit.band(pp)
        ax.plot(pp, fit.predict(pp), color="k", lw=1.5,
                label=f"regression: {law}\n(scatter between releases $\\tau$ = {fit.tau:.2g}"
                      + ("" if fit.tau_ci is None else f" [{fit.tau_ci[0]:.2g}, {fit.tau_ci[1]:.2g}]")
                      + ("" if unit == "-" else f" {unit}") + ")")
        ax.fill_between(pp, lo, hi, color="k", alpha=0.12, label="95% confidence band")
        shown = [c for c in CONTACT_MODELS if c in set(sim.contact)]
        for k, contact in enumerate(shown):
            g = sim[sim.contact == contact]
            m = g.groupby("pressure_kpa")[col].agg(["mean", "std"]).reset_index()
            off = 0.3 * (k - (len(shown) - 1) / 2)          # side by side at each pressure
            ax.errorbar(m.pressure_kpa + off, m["mean"], yerr=m["std"].fillna(0), fmt="s", mfc="none",
                        color=CONTACT_COLOURS[contact], ms=6, capsize=2, label=f"Drake, {FIG10_NAMES.get(contact, contact)}")
        ax.set_ylabel(f"{label} ({unit})")
    axes[1].axhline(robot.omega_n_eq5, color="tab:purple", ls="--", lw=1.2,
                    label=f"eq. 5: $\\sqrt{{K_{{eq}}/M_{{eq}}}}$ = {robot.omega_n_eq5:.3f} rad/s")
    a, b = reg.zeta.value("zeta_a"), reg.zeta.value("zeta_b")
    c, d = reg.omega_n.value("omega_n_c"), reg.omega_n.value("omega_n_d")
    axes[0].set_title(f"$\\zeta(p) = {a:.3f}\\,e^{{{b:.4f}\\,p}}$,  $\\omega_n(p) = {c:.3f} {'-' if d < 0 else '+'} {abs(d):.4f}\\,p$")
    axes[1].set_xlabel("shell gauge pressure p (kPa)")
    for ax in axes:      # beside the panel: inside it covered the highest points
        ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    fig.suptitle(f"Fig. 10: locked-steer shell dynamics vs pressure{_of(campaign)}")
    save(fig, out_png)


def fig11(sweep: str, points: str, out_png: str, out_table: str, out_md: str, carried_modulus: float = 1.0,
          carried_dissipation: float = 0.5, campaign: str = "") -> None:
    """Fig. 11: hydroelastic sensitivity (modulus and dissipation x0.5, x1.5, both) of the
    simulated damping ratio at every pressure, and the percent-error change against the control."""
    sw = pd.read_csv(sweep)
    meas = pd.read_csv(points).groupby("pressure_kpa").zeta.mean()
    sw["case"] = [("control" if (m, d) == (1.0, 1.0) else
                   f"modulus x{m:g}" if d == 1.0 else f"dissipation x{d:g}" if m == 1.0 else f"both x{m:g}")
                  for m, d in zip(sw.modulus_scale, sw.dissipation_scale)]
    g = sw.groupby(["case", "modulus_scale", "dissipation_scale", "pressure_kpa"]).zeta.mean().reset_index()
    g["zeta_measured"] = g.pressure_kpa.map(meas)
    g["abs_error_percent"] = 100 * (g.zeta - g.zeta_measured).abs() / g.zeta_measured
    ctrl = g[g.case == "control"].set_index("pressure_kpa").abs_error_percent
    g["error_change_vs_control_percent"] = g.abs_error_percent - g.pressure_kpa.map(ctrl)
    g = g.sort_values(["case", "pressure_kpa"]).reset_index(drop=True)
    write_csv_atomic(g, out_table)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    cases = sorted(g.case.unique(), key=lambda c: (c != "control", c))
    others = [c for c in cases if c != "control"]
    colours = {c: plt.cm.tab10(i) for i, c in enumerate(others)}
    colours["control"] = "k"
    pressures = sorted(g.pressure_kpa.unique())
    slot = {p: i for i, p in enumerate(pressures)}          # one group of bars per tested pressure
    w = 0.8 / max(len(others), 1)
    for case in cases:
        s = g[g.case == case]
        axes[0].plot(s.pressure_kpa, s.zeta, "o-", label=case, color=colours[case], lw=2.5 if case == "control" else 1.2)
        if case != "control":
            k = others.index(case)
            axes[1].bar(s.pressure_kpa.map(slot).to_numpy() + (k - (len(others) - 1) / 2) * w,
                        s.error_change_vs_control_percent, w * 0.9, label=case, color=colours[case])
    axes[1].set_xticks(range(len(pressures)), [f"{p:g}" for p in pressures])
    axes[0].plot(meas.index, meas.values, "kx", ms=9, mew=2, label="recorded (mean)")
    axes[0].set_xlabel("pressure (kPa)")
    axes[0].set_ylabel("simulated damping ratio $\\zeta$ (-)")
    axes[0].legend(fontsize=7)
    axes[1].axhline(0, color="k", lw=0.8)
    axes[1].set_xlabel("pressure (kPa)")
    axes[1].set_ylabel("change of $|\\zeta$ error$|$ vs control (percentage points)")
    axes[1].legend(fontsize=7)
    fig.suptitle(f"Fig. 11: hydroelastic parameter sensitivity{_of(campaign)}; negative = closer to the data")
    save(fig, out_png)
    mean_err = g.groupby("case").abs_error_percent.mean().sort_values()
    carried = ("control" if (carried_modulus, carried_dissipation) == (1.0, 1.0) else
               f"modulus x{carried_modulus:g}" if carried_dissipation == 1.0 else
               f"dissipation x{carried_dissipation:g}" if carried_modulus == 1.0 else f"both x{carried_modulus:g}")
    best = mean_err.index[0]
    lines = ["# Hydroelastic sensitivity sweep (section III-D)", "",
             "Mean absolute error of the simulated damping ratio against the measured mean, over all pressures:", "",
             "| case | mean abs error (%) |", "|---|---|"]
    lines += [f"| {c} | {v:.1f} |" for c, v in mean_err.items()]
    verdict = ("still favour" if best == carried else "no longer favour")
    lines += ["", f"Setting carried forward to the ramp (config `shell.carried_forward`): **{carried}**. "
              f"Best case in this sweep: **{best}**. The data {verdict} the carried-forward setting."]
    write_text_atomic(out_md, "\n".join(lines) + "\n")


DETAIL_PERCENT = 5.0


def _range_whisker(ax, x, low, high, capsize):
    """A whisker from `low` to `high` (the 95% range over friction-posterior draws), drawn on its
    own: the bar is the mean over runs of the posterior-median PME, which need not lie inside the
    range of a few draws."""
    ax.errorbar(x, 0.5 * (low + high), yerr=0.5 * abs(high - low), fmt="none", ecolor="k", capsize=capsize, lw=1)


def _in_sample_note(s: pd.DataFrame) -> str:
    """A line naming the pressures where the diagnosed model is scored on a run its diagnosis
    was fitted on (a single run there: roboball.pipeline.diagnosis.ramp_diagnosed), or ""."""
    if "scored_in_sample" not in s:
        return ""
    inside = s[(s.contact == "diagnosed") & (s.scored_in_sample.astype(str) == "True")]
    if inside.empty:
        return ""
    ps = ", ".join(f"{p:g}" for p in sorted(inside.pressure_kpa.unique()))
    return (f"diagnosed at {ps} kPa: scored in sample (a single run there, so its diagnosis was fitted on "
            "the run it is scored on)")


def _fig13(s: pd.DataFrame, agg: pd.DataFrame, contacts: list, out: str, campaign: str, names: dict,
           note: str = "") -> None:
    """Fig. 13: PME bars per pressure and model, the runs as dots, posterior whiskers; `note` (the
    in-sample scores, :func:`_in_sample_note`) in red under the detail panel's bars."""
    pressures = sorted(s.pressure_kpa.unique())
    # Two panels: every model, and below it the models within DETAIL_PERCENT of the recording,
    # whose differences (a few tenths of a percent) the full scale hides.
    fig, (ax, ax_d) = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True, gridspec_kw={"height_ratios": [2, 1.2]})
    w = 0.8 / len(contacts)
    for axis in (ax, ax_d):
        for k, c in enumerate(contacts):
            a = agg[agg.contact == c].set_index("pressure_kpa").reindex(pressures)
            x = np.arange(len(pressures)) + (k - (len(contacts) - 1) / 2) * w
            axis.bar(x, a.pme_mean_percent, w * 0.9, color=CONTACT_COLOURS[c], label=names[c], alpha=0.85)
            runs = s[s.contact == c]
            for i, p in enumerate(pressures):
                r = runs[runs.pressure_kpa == p]
                axis.plot(np.full(len(r), x[i]), r.pme_percent, "k.", ms=4)
                if "pme_draw_low" in r and r.pme_draw_low.notna().any():
                    _range_whisker(axis, x[i], r.pme_draw_low.min(), r.pme_draw_high.max(), capsize=3)
        axis.axhline(0, color="k", lw=0.8)
    small = s.pme_percent[s.pme_percent.abs() <= DETAIL_PERCENT]
    lim = max(1.0, 1.25 * float(small.abs().max())) if len(small) else DETAIL_PERCENT
    ax_d.set_ylim(-lim, lim)
    ax_d.set_ylabel("detail (%)")
    ax_d.text(0.01, 0.96, f"detail: the same bars on a finer scale, for the models within {DETAIL_PERCENT:g}% "
              "of the recording",
              transform=ax_d.transAxes, va="top", fontsize=8, color="0.3")
    ax_d.set_xticks(np.arange(len(pressures)), [f"{p:g}" for p in pressures])
    ax_d.set_xlabel("shell pressure (kPa)")
    ax.set_ylabel("drive-speed PME (%)  [+ = model too fast]")
    ax.set_title(f"Fig. 13: drive-speed error per pressure{_of(campaign)}")
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo, hi + 0.1 * (hi - lo))               # room for the key line above the tallest bar
    ax.text(0.01, 0.98, "bars: mean of runs   dots: runs   whiskers: 95% over friction-posterior draws",
            transform=ax.transAxes, va="top", fontsize=8, color="0.3")
    ax.legend(fontsize=8)
    if note:
        ax_d.text(0.01, 0.04, note, transform=ax_d.transAxes, va="bottom", fontsize=8, color="tab:red")
    save(fig, out)


def _fig14_signed(ax, s: pd.DataFrame, contacts: list, m: pd.Series, names: dict) -> None:
    """Eq. 12's signed mean over pressures (the paper's Fig. 14), its mean written on each bar."""
    ax.bar(range(len(contacts)), m.values, color=[CONTACT_COLOURS[c] for c in contacts], alpha=0.85)
    for i, c in enumerate(contacts):
        r = s[s.contact == c]
        ax.plot(np.full(len(r), i), r.pme_percent, "k.", ms=4)
        if "pme_draw_low" in r and r.pme_draw_low.notna().any():
            _range_whisker(ax, i, r.pme_draw_low.mean(), r.pme_draw_high.mean(), capsize=4)
    ax.axhline(0, color="k", lw=0.8)
    span = float(np.nanmax(np.abs(s.pme_percent))) if len(s) else 1.0
    for i, c in enumerate(contacts):      # the mean written on each bar: small bars are invisible at this scale
        r = s[s.contact == c]             # written above the bar, its runs and its whisker, clear of the dots
        tops = [m[c], 0.0, *r.pme_percent.dropna()]
        if "pme_draw_high" in r and r.pme_draw_high.notna().any():
            tops.append(r.pme_draw_high.mean())
        ax.annotate(f"{m[c]:+.2f}%", (i, max(tops)), xytext=(0, 4), textcoords="offset points",
                    ha="center", va="bottom", fontsize=9,
                    bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.8))
    ax.set_ylim(top=1.12 * span)
    ax.set_xticks(range(len(contacts)), [names[c] for c in contacts], fontsize=8)
    ax.set_ylabel("drive-speed PME averaged over pressures (%)")
    ax.set_title("eq. 12 (signed): + = model too fast", fontsize=9)


def _fig14_absolute(ax_abs, s: pd.DataFrame, contacts: list, names: dict) -> None:
    """The mean |point error| over the same samples, which cannot cancel, on a log scale where
    the small errors are visible too: each model's mean a wide tick, its runs dots.  No bars: a
    bar's length on a log axis is set by where the axis starts, not by the value."""
    mabs = s.groupby("contact").mape_percent.mean().reindex(contacts)
    shown = np.isfinite(mabs.values) & (mabs.values > 0)          # a log axis cannot show 0 or NaN
    ax_abs.set_yscale("log")
    for i, c in enumerate(contacts):
        r = s.mape_percent[(s.contact == c) & (s.mape_percent > 0)]
        ax_abs.plot(np.full(len(r), i), r, ".", color=CONTACT_COLOURS[c], ms=5, alpha=0.7)
        if shown[i]:
            ax_abs.hlines(mabs[c], i - 0.32, i + 0.32, color=CONTACT_COLOURS[c], lw=3.5, label="_mean")
            ax_abs.annotate(f"{mabs[c]:.2f}%", (i, max(mabs[c], *r)), xytext=(0, 4), textcoords="offset points",
                            ha="center", va="bottom", fontsize=9,
                            bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.8))
        else:                                  # said, not silently dropped
            ax_abs.annotate("0%" if mabs[c] == 0 else "n/a", (i, 0.02), xycoords=("data", "axes fraction"),
                            ha="center", va="bottom", fontsize=9)
    if shown.any():
        lo, hi = float(np.nanmin(mabs.values[shown])), float(np.nanmax(s.mape_percent))
        ax_abs.set_ylim(0.5 * min(lo, float(s.mape_percent[s.mape_percent > 0].min())), 3.0 * hi)
    ax_abs.set_xlim(-0.6, len(contacts) - 0.4)
    ax_abs.set_xticks(range(len(contacts)), [names[c] for c in contacts], fontsize=8)
    ax_abs.set_ylabel("mean |point error| over pressures (%)")
    ax_abs.set_title("the same samples, absolute: errors cannot cancel\n(thick: mean over runs; dots: runs)",
                     fontsize=9)


def _pme_markdown(s: pd.DataFrame, agg: pd.DataFrame, contacts: list, m: pd.Series, names: dict,
                  note: str = "") -> str:
    """The PME table for people: per (contact, pressure), then per contact over all runs;
    `names` the figures' labels of the contacts, said where they add to the table's key."""
    said = [f"`{c}`: {names[c].replace(chr(10), ' ')}" for c in contacts if names.get(c, c) != c]
    lines = ["# Drive-speed point mean error (eq. 12), percent; + = model faster than the robot", "",
              "Eq. 12 is a signed mean: a model that runs fast early and slow late can score near zero. "
              "`mean |error|` is the same mean over the same samples of the absolute relative error, and "
              "`RMSE` the RMS drive-rate error over the whole descent (rad/s); both are means over runs.", "",
              *([f"Models as in Figs. 13/14: {'; '.join(said)}.", ""] if said else []),
              *([f"Out of sample except: {note}.", ""] if note else []),
              "| contact | pressure (kPa) | runs | mean PME | min | max | posterior 95% | mean \\|error\\| (%) | RMSE (rad/s) |",
              "|---|---|---|---|---|---|---|---|---|"]
    for r in agg.itertuples():
        post = (f"[{r.pme_post_low_percent:.1f}, {r.pme_post_high_percent:.1f}]"
                if hasattr(r, "pme_post_low_percent") and np.isfinite(r.pme_post_low_percent) else "-")
        line = (f"| {r.contact} | {r.pressure_kpa:g} | {r.runs} | {r.pme_mean_percent:.2f} | "
                f"{r.pme_min_percent:.2f} | {r.pme_max_percent:.2f} | {post} | "
                f"{r.mape_mean_percent:.2f} | {r.rmse_mean_rad_s:.4f} |")
        lines.append(line)
    overall = s.groupby("contact")[["mape_percent", "rmse_rad_s"]].mean().reindex(contacts)
    lines += ["", "| contact | mean PME over all runs (%) | mean \\|error\\| (%) | RMSE (rad/s) |",
              "|---|---|---|---|"]
    lines += [f"| {c} | {m[c]:.2f} | {overall.mape_percent[c]:.2f} | {overall.rmse_rad_s[c]:.4f} |"
              for c in contacts]
    return "\n".join(lines) + "\n"


def fig13_14(summary: str, out13: str, out14: str, out_csv: str, out_md: str, campaign: str = "",
             hydro_setting: str = "") -> None:
    """Fig. 13 (PME per pressure and model, spread over runs, posterior intervals) and Fig. 14
    (averaged over pressures); the PME table as CSV and Markdown.  `hydro_setting` names the
    paper's hydroelastic variant the ramp runs (config shell.carried_forward, e.g. "dissipation
    x0.5") in the figures' labels, beside the tuned one."""
    s = pd.read_csv(summary)
    missing = sorted(SUMMARY_COLUMNS - set(s.columns))
    if missing:
        raise RoboballError(f"{summary}: missing column(s) {', '.join(missing)} (written by roboball.pipeline.simulation)")
    contacts = [c for c in [*CONTACT_MODELS, "diagnosed"] if c in set(s.contact)]
    agg = pme_table(s)
    write_csv_atomic(agg, out_csv)
    names = {c: c for c in contacts}
    if hydro_setting and "hydroelastic" in names:
        names["hydroelastic"] = f"hydroelastic\n({hydro_setting})"
    if "hydro_tuned" in names:
        names["hydro_tuned"] = "hydroelastic\n(calibrated, Fig. S3)"
    note = _in_sample_note(s)
    _fig13(s, agg, contacts, out13, campaign, {c: n.replace("\n", " ") for c, n in names.items()}, note)
    # 12 in wide: five two-line model names side by side without overlapping
    fig, (ax, ax_abs) = plt.subplots(1, 2, figsize=(14, 4.2), gridspec_kw={"width_ratios": [1.2, 1.2]})
    m = s.groupby("contact").pme_percent.mean().reindex(contacts)
    _fig14_signed(ax, s, contacts, m, names)
    _fig14_absolute(ax_abs, s, contacts, names)
    fig.suptitle(f"Fig. 14: averaged drive speed error{_of(campaign)}" + (f"\n{note}" if note else ""), fontsize=10)
    save(fig, out14)
    write_text_atomic(out_md, _pme_markdown(s, agg, contacts, m, names, note))


def table2(out_csv: str, out_md: str, robot_yaml: str = "") -> None:
    """Table II (measured numerical values) from configs/robot.yaml, with the eq. 4-5 numbers
    derived from them."""
    from roboball.config import load_robot

    r = load_robot(robot_yaml or None)
    L = r.links
    rows = [
        ("link mass m_pc", L["pitch_center"].mass_kg, "kg"), ("link mass m_p", L["pendulum"].mass_kg, "kg"),
        ("link mass m_s", L["pipe_assembly"].mass_kg, "kg"),
        ("inertia I_pc (xx)", L["pitch_center"].inertia_kg_m2[0], "kg m^2"),
        ("inertia I_p (xx)", L["pendulum"].inertia_kg_m2[0], "kg m^2"),
        ("inertia I_s (xx)", L["pipe_assembly"].inertia_kg_m2[0], "kg m^2"),
        ("distance r_pc", -L["pitch_center"].com_m[2], "m"), ("distance r_p", -L["pendulum"].com_m[2], "m"),
        ("outer radius R", r.radius, "m"), ("ramp angle", r.ramp_angle_deg, "deg"),
        ("M_eq (eq. 4)", r.M_eq, "kg m^2"), ("K_eq (eq. 4)", r.K_eq, "N m/rad"),
        ("omega_n (eq. 5)", r.omega_n_eq5, "rad/s"), ("shell rest angle", r.shell_rest_angle, "rad"),
        ("steer stand omega", r.steer_stand_terms["omega_n"], "rad/s"),
        ("steer stand rest angle", r.steer_stand_terms["rest_angle"], "rad"),
    ]
    df = pd.DataFrame(rows, columns=["parameter", "value", "unit"])
    write_csv_atomic(df, out_csv)
    md = ["# Table II: measured numerical values (configs/robot.yaml) and derived eq. 4-5 numbers", "",
          "| parameter | value | unit |", "|---|---|---|"]
    md += [f"| {p} | {v:.5g} | {u} |" for p, v, u in rows]
    write_text_atomic(out_md, "\n".join(md) + "\n")
