"""Fig. S3 (beyond the paper, issue 25): the hydroelastic calibration.  How Drake's hydroelastic
shell's zeta and omega_n follow the modulus and the dissipation (the calibration grid), the
fitted moduli as contact volumes V = f_n / modulus (eq. 10) against pressure with the power law
V(p) through them, the paper's membrane V(p) and the authors' tuned values, and the fitted
dissipations against eq. 11's.  With its table (Markdown) for people."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd

from roboball.atomic import write_csv_atomic, write_text_atomic
from roboball.figures.style import CONTACT_COLOURS, plt, save

STAGES = ("figs2",)
TUNED = CONTACT_COLOURS["hydro_tuned"]


def _at_bound(table: pd.DataFrame) -> np.ndarray:
    return table["at_grid_bound"].astype(bool).to_numpy() if "at_grid_bound" in table else np.zeros(len(table), bool)


def _pressures(rows: pd.DataFrame) -> str:
    return ", ".join(f"{p:g}" for p in rows.pressure_kpa) + " kPa"


def _grid_panels(ax_w, ax_z, grid: pd.DataFrame, table: pd.DataFrame) -> None:
    """omega_n and zeta of the grid's Drake runs against the modulus, one line per dissipation,
    the recorded range shaded, the fits marked."""
    from roboball.identify.shell.hydro import ZETA_MAX

    ok = grid[np.isfinite(grid.zeta) & (grid.zeta < ZETA_MAX)]   # as the surrogate: overdamped runs left out
    ds = sorted(ok.hydro_dissipation_s_m.unique())
    cmap = plt.cm.viridis(np.linspace(0, 0.9, len(ds)))
    for colour, d in zip(cmap, ds):
        g = ok[ok.hydro_dissipation_s_m == d].sort_values("hydro_modulus_pa")
        ax_w.plot(g.hydro_modulus_pa, g.omega_n_rad_s, "o-", color=colour, ms=3, lw=1, label=f"d = {d:.3g} s/m")
        ax_z.plot(g.hydro_modulus_pa, g.zeta, "o-", color=colour, ms=3, lw=1, label=f"d = {d:.3g} s/m")
    for ax, col in ((ax_w, "omega_n_recorded_rad_s"), (ax_z, "zeta_recorded")):
        ax.axhspan(table[col].min(), table[col].max(), color=TUNED, alpha=0.15, label="recorded, range over pressures")
        ax.set_xscale("log")
        ax.set_xlabel("hydroelastic modulus (Pa)")
    # A fit stopped at the grid's bound is not a match: hollow, with its pressures named (several
    # sit on one point at the softest modulus).
    edge = _at_bound(table)
    for mask, fill, label in ((~edge, TUNED, "fits (Drake)"), (edge, "none", f"fits at the grid's bound ({_pressures(table[edge])})")):
        if not mask.any():
            continue
        for ax, col in ((ax_w, "omega_n_drake_rad_s"), (ax_z, "zeta_drake")):
            ax.plot(table.hydro_modulus_pa[mask], table[col][mask], "*", color=TUNED, mfc=fill, ms=10, mec="k",
                    label=label)
    ax_w.set_ylabel("Drake natural frequency $\\omega_n$ (rad/s)")
    ax_z.set_ylabel("Drake damping ratio $\\zeta$ (-)")
    ax_z.set_yscale("log")
    ax_w.set_title("(a) Drake grid: $\\omega_n$ follows the modulus", fontsize=9)
    ax_z.set_title("(b) Drake grid: $\\zeta$ follows the dissipation (and the modulus); key in (a)", fontsize=9)
    ax_w.legend(fontsize=7.5, ncol=2, loc="upper right")    # one key for both: (b) has no empty corner


def _volume_panel(ax, table: pd.DataFrame, law: dict, authors: list, robot) -> None:
    """Fitted contact volumes with intervals, the power law, the membrane law, the authors'."""
    from roboball.physics import shell as sl

    w = robot.weight_n
    p = table.pressure_kpa.to_numpy()
    v = sl.volume_of_modulus(w, table.hydro_modulus_pa.to_numpy())
    v_lo = sl.volume_of_modulus(w, table.hydro_modulus_ci95_high_pa.to_numpy())
    v_hi = sl.volume_of_modulus(w, table.hydro_modulus_ci95_low_pa.to_numpy())
    edge = _at_bound(table)
    for mask, fill, label in ((~edge, TUNED, "calibrated: $f_n$ / modulus (95%)"),
                              (edge, "none", f"calibrated at the grid's bound ({_pressures(table[edge])})")):
        if mask.any():
            ax.errorbar(p[mask], v[mask], yerr=[(v - v_lo)[mask], (v_hi - v)[mask]], fmt="o", color=TUNED, mfc=fill,
                        mec="k", capsize=3, label=label)
    pp = np.linspace(p.min() - 1, p.max() + 1, 100)
    k = law["exponent"]
    if np.isfinite(k):                     # a law needs two pressures at least
        ax.plot(pp, sl.contact_volume_power(pp * 1e3, law["v_ref_m3"], law["p_ref_pa"], k), color=TUNED,
                label=f"fitted law V(p) = {law['v_ref_m3']:.3g} (p / {law['p_ref_pa'] / 1e3:.3g} kPa)$^{{{k:.2f}}}$ m$^3$")
    ax.plot(pp, [sl.contact_volume(x * 1e3, w, robot.radius) for x in pp], "k--", lw=1.2,
            label="eq. 10's membrane V(p) (paper model)")
    styles = ["-.", ":", (0, (5, 2)), (0, (1, 3))]
    for i, a in enumerate(authors):
        ax.axhline(sl.volume_of_modulus(w, a["modulus_pa"]), color="tab:purple", ls=styles[i % len(styles)], lw=1,
                   label=f"authors: {a['label']}, {a['modulus_pa']:.3g} Pa")
    ax.set_yscale("log")
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo, hi * (hi / lo) ** 1.1)           # room above the data for the legend
    ax.set_xlabel("shell gauge pressure p (kPa)")
    ax.set_ylabel("contact volume V = $f_n$ / modulus (m$^3$)")
    ax.set_title("(c) contact volume V(p) (eq. 10) through the calibrated moduli\n"
                 "(the authors' test pressure was not logged: lines)", fontsize=9)
    ax.legend(fontsize=7.5, loc="upper left")


def _dissipation_panel(ax, table: pd.DataFrame, regression: str, authors: list, robot) -> None:
    """Fitted dissipations with intervals against eq. 11 (C_inject) and the paper's x0.5."""
    from roboball.physics import shell as sl

    t = pd.read_csv(regression).set_index("name")["value"]
    p = table.pressure_kpa.to_numpy()
    d = table.hydro_dissipation_s_m.to_numpy()
    ax.errorbar(p, d, yerr=[d - table.hydro_dissipation_ci95_low_s_m, table.hydro_dissipation_ci95_high_s_m - d],
                fmt="o", color=TUNED, mec="k", capsize=3, label="calibrated (95%)")
    pp = np.linspace(p.min() - 1, p.max() + 1, 100)
    c = sl.hydro_dissipation(sl.zeta_of_p(pp, t["zeta_a"], t["zeta_b"]), sl.omega_n_of_p(pp, t["omega_n_c"], t["omega_n_d"]),
                             robot.M_eq)
    ax.plot(pp, c, color=CONTACT_COLOURS["hydroelastic"], label="eq. 11: d = C_inject (paper)")
    ax.plot(pp, 0.5 * c, color=CONTACT_COLOURS["hydroelastic"], ls="--", label="eq. 11 x 0.5 (paper's ramp variant)")
    styles = ["-.", ":", (0, (5, 2)), (0, (1, 3))]
    for i, a in enumerate(authors):
        ax.axhline(a["dissipation_s_m"], color="tab:purple", ls=styles[i % len(styles)], lw=1,
                   label=f"authors: {a['label']}")
    ax.set_yscale("log")
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo / (hi / lo) ** 0.6, hi)          # room below the data for the legend
    ax.set_xlabel("shell gauge pressure p (kPa)")
    ax.set_ylabel("Hunt-Crossley dissipation d (s/m)")
    ax.set_title("(d) dissipation: calibrated vs eq. 11", fontsize=9)
    ax.legend(fontsize=7.5, loc="lower left")


def _markdown(table: pd.DataFrame, law: dict, authors: list, robot) -> str:
    from roboball.physics import shell as sl

    w = robot.weight_n
    lines = ["# Tuned hydroelastic shell (issue 25): calibrated modulus and dissipation", "",
             "Drake's hydroelastic shell (`hydro_tuned`) fitted at each pressure to the recorded releases' zeta and "
             "omega_n (means over the releases) by simulation error; 95% intervals from the recorded values' "
             "uncertainty through the inverse map. `zeta`/`omega_n` Drake: Drake's own runs at the fitted values "
             "from the recorded releases. Acceptance: both within 10% at every pressure.", "",
             "| p (kPa) | hydro_modulus (Pa) [95%] | dissipation (s/m) [95%] | V = f_n/modulus (m^3) | eq. 10 membrane "
             "modulus (Pa) | zeta recorded | zeta Drake (err %) | omega_n recorded (rad/s) | omega_n Drake (err %) "
             "| on an edge* |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in table.itertuples():
        lines.append(
            f"| {r.pressure_kpa:g} | {r.hydro_modulus_pa:.4g} [{r.hydro_modulus_ci95_low_pa:.4g}, "
            f"{r.hydro_modulus_ci95_high_pa:.4g}] | {r.hydro_dissipation_s_m:.3g} [{r.hydro_dissipation_ci95_low_s_m:.3g}, "
            f"{r.hydro_dissipation_ci95_high_s_m:.3g}] | {sl.volume_of_modulus(w, r.hydro_modulus_pa):.3g} | "
            f"{sl.hydro_modulus(r.pressure_kpa * 1e3, w, robot.radius):.3g} | {r.zeta_recorded:.4f} | "
            f"{r.zeta_drake:.4f} ({r.zeta_error_percent:+.2f}) | {r.omega_n_recorded_rad_s:.4f} | "
            f"{r.omega_n_drake_rad_s:.4f} ({r.omega_n_error_percent:+.2f}) | {'yes' if r.at_grid_bound else 'no'} |")
    from roboball.identify.shell.hydro import acceptance_failures

    misses = acceptance_failures(table)
    lines += ["", "*The fit, or the inverse of the recorded mean, on an edge of the box the fit is kept in (the grid, "
              "above the softest modulus at which Drake's shell held the robot): the interval is one-sided there.",
              "", f"Within 10% at every pressure, intervals holding the fits: **{'yes' if not misses else 'no'}**"
              + ("" if not misses else ": " + "; ".join(misses)) + ".", "",
              f"Contact-volume law through the fitted moduli: V(p) = {law['v_ref_m3']:.4g} m^3 "
              f"[{law['v_ref_ci95_low_m3']:.4g}, {law['v_ref_ci95_high_m3']:.4g}] x (p / {law['p_ref_pa'] / 1e3:.4g} kPa)"
              f"^k, k = {law['exponent']:.3f} [{law['exponent_ci95_low']:.3f}, {law['exponent_ci95_high']:.3f}] "
              f"({int(law['n_pressures'])} pressures; eq. 10's membrane model has k close to -2).", "",
              "Elasticities of Drake's shell at the fits (d ln output / d ln parameter; the surrogate's): "
              "omega_n to the modulus " + ", ".join(f"{x:.3f}" for x in table.dlnomega_n_dlnmodulus) +
              "; zeta to the dissipation " + ", ".join(f"{x:.3f}" for x in table.dlnzeta_dlndissipation) +
              "; zeta to the modulus " + ", ".join(f"{x:.3f}" for x in table.dlnzeta_dlnmodulus) + ".", "",
              "| the authors' values | hydro_modulus (Pa) | dissipation (s/m) | V = f_n/modulus (m^3) |",
              "|---|---|---|---|"]
    lines += [f"| {a['label']} | {a['modulus_pa']:.4g} | {a['dissipation_s_m']:.3g} | "
              f"{sl.volume_of_modulus(w, a['modulus_pa']):.3g} |" for a in authors]
    return "\n".join(lines) + "\n"


def figs2(table: str, law: str, grid_csvs: list, regression: str, out_png: str, out_md: str, out_csv: str = "",
          authors_json: str = "[]", campaign: str = "", robot_yaml: str = "") -> None:
    """Fig. S3 and its tables: the hydroelastic calibration (see the module docstring); `out_csv`
    is the calibration table as committed with the figures (paper_figures/table_hydro_tuned.csv)."""
    from roboball.config import load_robot

    robot = load_robot(robot_yaml or None)
    t = pd.read_csv(table).sort_values("pressure_kpa")
    lw = pd.read_csv(law).iloc[0].to_dict()
    grid = pd.concat([pd.read_csv(p) for p in sorted(grid_csvs)], ignore_index=True)
    authors = json.loads(authors_json or "[]")
    fig, axes = plt.subplots(2, 2, figsize=(12, 9))
    _grid_panels(axes[0, 0], axes[0, 1], grid, t)
    _volume_panel(axes[1, 0], t, lw, authors, robot)
    _dissipation_panel(axes[1, 1], t, regression, authors, robot)
    where = f" ({campaign} recordings)" if campaign else ""
    fig.suptitle(f"Fig. S3: hydroelastic shell calibrated to the shell releases{where}")
    save(fig, out_png)
    write_text_atomic(out_md, _markdown(t, lw, authors, robot))
    if out_csv:
        write_csv_atomic(t.reset_index(drop=True), out_csv)
