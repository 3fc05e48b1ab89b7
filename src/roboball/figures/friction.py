"""Friction figures and tables: Table I (fitted, with 95% intervals), Fig. 5 (torque vs velocity
with posterior bands), Fig. 7 / Fig. 8 (stand data overlaid with the fitted laws simulated in
Drake), corner plots, and the model-comparison table."""
from __future__ import annotations

import json
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pandas as pd

from roboball.atomic import write_csv_atomic, write_text_atomic
from roboball.identify.friction.comparison import recommendation
from roboball.identify.friction.results import FrictionFit, read_fit
from roboball.physics import friction
from roboball.figures.style import plt, save

STAGES = ("fig5", "fig_stand_fits", "table1", "corner_plot")
LAW_COLOURS = {"viscous": "#1f77b4", "coulomb_viscous": "#ff7f0e", "majd": "#2ca02c"}
LAW_LABELS = {"viscous": "viscous", "coulomb_viscous": "Coulomb + viscous (eq. 2)", "majd": "Majd (eq. 3)"}


def _law_medians(f: FrictionFit) -> dict:
    """The fitted law's posterior medians (without the noise level)."""
    return f.medians(friction.PARAMS[f.law])


def fig5(fits: list, out_png: str) -> None:
    """Torque vs joint velocity of every fitted law, median and 95% posterior band."""
    fits = [read_fit(f) for f in fits]
    joints = sorted({f.joint for f in fits}, key=lambda j: j != "steer")
    fig, axes = plt.subplots(1, len(joints), figsize=(6 * len(joints), 4.5), squeeze=False)
    for ax, joint in zip(axes[0], joints):
        vmax = 2.0 if joint == "steer" else 4.0
        v = np.linspace(-vmax, vmax, 801)
        for f in [f for f in fits if f.joint == joint]:
            law = f.law
            draws = f.samples(300)
            taus = np.array([friction.torque(law, v, {**f.fixed, **row._asdict()}) for row in
                             draws[[c for c in draws.columns if c in friction.PARAMS[law]]].itertuples(index=False)])
            lo, hi = np.percentile(taus, [2.5, 97.5], axis=0)
            col = LAW_COLOURS[law]
            ax.fill_between(v, lo, hi, color=col, alpha=0.25)
            ax.plot(v, friction.torque(law, v, {**f.fixed, **_law_medians(f)}), color=col, lw=1.8,
                    label=LAW_LABELS[law])
        ax.axhline(0, color="k", lw=0.6)
        ax.axvline(0, color="k", lw=0.6)
        ax.set_xlabel(f"{joint} joint velocity (rad/s)")
        ax.set_ylabel("friction torque on the joint (N m)")
        ax.set_title(f"{joint} joint")
        # friction opposes motion, so this quadrant stays empty; short labels keep the legend in it
        ax.legend(fontsize=8, loc="lower left")
    fig.suptitle("Fig. 5: fitted joint-friction laws (lines: posterior medians; bands: 95% of the posterior)")
    save(fig, out_png)


def _drake_release(kind: str, f: FrictionFit, q0: float, shift: float, duration: float):
    """One release of fit `f` simulated in Drake on the calibrated stand: the fitted law, the
    stand's added inertia on the joint's rotor and its rest offset
    (:func:`roboball.sim.scenarios.simulate_calibrated_stand`), let go `shift` seconds after the
    release finder's instant.  Returns (times from that instant, measured angle)."""
    from roboball.sim.scenarios import simulate_calibrated_stand
    from roboball.sim.spec import SimSpec

    joint = "steer" if kind == "steer_stand" else "drive"
    other = "drive" if joint == "steer" else "steer"
    stand = f.stand_values()
    spec = SimSpec(kind=kind, friction={joint: f.law, other: "none"},
                   friction_params={joint: {**f.fixed, **_law_medians(f)}},
                   added_inertia={joint: stand["delta_i"]})
    df = simulate_calibrated_stand(spec, q0, max(duration - shift, 0.1), rest_offset=stand["rest_offset"],
                                   sample_rate_hz=200.0)
    t = df.time_s.to_numpy() + shift
    y = df[f"{joint}_angle_rad"].to_numpy()
    if shift > 0:                        # held at the release angle until let go
        t, y = np.concatenate([[0.0], t]), np.concatenate([[y[0]], y])
    return t, y


def _drake_fits(pairs: list, fits: list) -> dict:
    """Per fit: its Drake releases [(t, y), ...] and the RMS of the recordings about them over
    every release's free response (what Fig. 7/8 show).  `pairs`: (recording, release) in the
    order the fit's segments were built (stand runs fitted together, one after another)."""
    out = {}
    for f in fits:
        angles = f.release_angle_medians()
        shifts = f.release_shift_medians() or [0.0] * len(pairs)
        traces, res = [], []
        for i, (rec, r) in enumerate(pairs):
            t_all, y_all = rec.time, rec.signal(rec.main_signal())
            q0 = angles[i] if angles and i < len(angles) else r["y_release"]
            tr = _drake_release(rec.kind, f, q0, shifts[i], r["t_end_s"] - r["t_release_s"])
            m = (t_all >= r["t_release_s"]) & (t_all <= r["t_end_s"])
            res.append(y_all[m] - np.interp(t_all[m] - r["t_release_s"], *tr))
            traces.append(tr)
        out[f.path] = (traces, float(np.sqrt(np.mean(np.concatenate(res) ** 2))))
    return out


def fig_stand_fits(recording: list, releases: list, fits: list, out_png: str, title: str = "") -> None:
    """Stand data (every release of every run) overlaid with each fitted law simulated in Drake
    on the calibrated stand from the fitted release angle and instant (Fig. 7 for the steer
    stand, Fig. 8 for the drive stand); the legend gives each law's RMS against the recordings.
    Several runs of one joint (fitted together) are drawn one after another."""
    from roboball.ingest.recording import read_recording

    recording = [recording] if isinstance(recording, str) else list(recording)
    releases = [releases] if isinstance(releases, str) else list(releases)
    pairs = []
    for rec_path, rel_path in zip(recording, releases):
        rec = read_recording(rec_path)
        with open(rel_path, encoding="utf-8") as fh:
            pairs += [(rec, r) for r in json.load(fh)["releases"]]
    fits = [read_fit(f) for f in fits]
    drake = _drake_fits(pairs, fits)
    fig, axes = plt.subplots(len(pairs), 1, figsize=(9, 2.6 * len(pairs)), squeeze=False)
    for i, (ax, (rec, r)) in enumerate(zip(axes[:, 0], pairs)):
        sig = rec.main_signal()
        t, y = rec.time, rec.signal(sig)
        m = (t >= r["t_release_s"] - 0.3) & (t <= r["t_end_s"])
        ax.plot(t[m] - r["t_release_s"], y[m], "k.", ms=2.5, label="recording")
        for f in fits:
            traces, rms = drake[f.path]
            unconverged = not f.convergence.get("converged", True)
            st = f.stand_values()
            ax.plot(*traces[i], color=LAW_COLOURS[f.law], lw=1.4,
                    label=f"Drake, {LAW_LABELS[f.law]}: rms {rms * 1e3:.1f} mrad; stand delta_i "
                          f"{st['delta_i']:.3g} kg m^2, offset {st['rest_offset'] * 1e3:.1f} mrad"
                          + ("; chain NOT converged" if unconverged else ""))
        ax.set_ylabel(f"{sig[:-4].replace('_', ' ')} (rad)")
        run = f"{Path(rec.path).stem}, " if len(recording) > 1 else ""
        ax.set_title(f"{run}release {i + 1} at {r['t_release_s']:.2f} s", fontsize=9)
    axes[-1, 0].set_xlabel("time since release (s)")
    # Below the panels: inside the first one the legend covered the swings' troughs.
    fig.legend(*axes[0, 0].get_legend_handles_labels(), fontsize=7, loc="outside lower center")
    fig.suptitle((title or f"{' + '.join(Path(p).stem for p in recording)}: data and fitted friction laws")
                 + "\n(each law on the stand it calibrated, let go at its fitted angle and instant)", fontsize=10)
    save(fig, out_png)


def _table1_rows(fits: list, robot) -> tuple[pd.DataFrame, list, list]:
    """(parameter rows, chain rows, stand-calibration rows) of Table I."""
    rows, chains, calib = [], [], []
    for path in fits:
        f = read_fit(path)
        paper = friction.table1_params(robot, f.law, f.joint)
        c = f.convergence
        converged = bool(c.get("converged", True))
        for name, p in f.parameters.items():
            if name.startswith("release"):
                continue
            rows.append({"joint": f.joint, "law": f.law, "parameter": name, "median": p["median"],
                         "map": p.get("map", float("nan")), "ci95_low": p["ci95_low"], "ci95_high": p["ci95_high"],
                         "unit": p.get("unit") or ("rad" if name == "noise_rad" else friction.UNITS.get(name, "")),
                         "paper_table1": paper.get(name, float("nan")), "source": f.recording,
                         "converged": converged, "held": False})
        for name, value in f.fixed.items():     # held by a point prior (Majd's n) or by the law (v_tol)
            rows.append({"joint": f.joint, "law": f.law, "parameter": name, "median": float(value),
                         "map": float("nan"), "ci95_low": float("nan"), "ci95_high": float("nan"),
                         "unit": friction.UNITS.get(name, ""), "paper_table1": paper.get(name, float("nan")),
                         "source": f.recording, "converged": converged, "held": True})
        if c:
            chains.append(f"| {f.recording} | {f.joint} | {f.law} | {c['steps']} | {c['burn_in']} | "
                          f"{c['max_tau']:.0f} | {c['chain_over_tau']:.1f} (needs {c['autocorr_multiple']:g}) | "
                          f"{c['ess_min']:.0f} | {'yes' if c['converged'] else '**no**'} |")
        st = f.stand()
        if st:
            shifts = ", ".join(f"{x:+.3f}" for x in (f.release_shift_medians() or [])) or "-"
            calib.append(f"| {f.recording} | {f.joint} | {_law_cell(f.law, converged)} | "
                         f"{_ci(st['delta_i'])} | {_ci(st['rest_offset'])} | {shifts} |")
    return pd.DataFrame(rows), chains, calib


def _ci(p: dict) -> str:
    return f"{p['median']:.4g} [{p['ci95_low']:.4g}, {p['ci95_high']:.4g}]"


def _law_cell(law: str, converged: bool) -> str:
    return law if converged else f"{law} (**chain not converged**)"


TABLE1_HEAD = [
    "# Table I: joint-friction parameters (posterior median, 95% interval; paper value)", "",
    "Each law is fitted on the calibrated stand: the stand's added inertia `delta_i` (the steer and drive "
    "gearboxes' reflected rotor inertia J N^2, which the URDF leaves out, net of the URDF's own inertia "
    "error) and its `rest_offset` (the measured angle's zero) are fitted with the law, and the angle and "
    "instant at which each swing starts with them (section Stand calibration). Majd's law is sampled by its "
    "stiction peak: `h_peak`, the hump's torque where its sigma term peaks, at the speed `v_peak`; `sigma` and "
    "`omega_c` are derived from them, `f_c` and `n`. Majd's `n` is held at 1.6 (Table I's drive value) by a "
    "point prior stated in configs/priors.yaml, because the swings do not pin it, and eq. 2's stiction band "
    "`v_tol` at the robot facts' value; such rows say \"held\". `noise_rad` is the likelihood's "
    "standard deviation of the angle, fitted with the law: sensor noise plus what the law cannot fit (the "
    "paper gives none). A fit whose chain did not converge is marked in the law column.", "",
    "| recording | joint | law | parameter | median | 95% interval | MAP | paper | unit |",
    "|---|---|---|---|---|---|---|---|---|"]

CHAINS_HEAD = [
    "", "## Posterior sampling (emcee)", "",
    "A chain is converged when its length after burn-in is at least `autocorr_multiple` "
    "integrated autocorrelation times (tau) of its slowest parameter. A chain that reaches "
    "`friction.max_steps` first is marked **no**: a chain that has not mixed underestimates its "
    "own tau, so its ESS is optimistic and its intervals may be narrower than the posterior's "
    "(read them as lower bounds on the uncertainty); the model comparison never recommends it. "
    "ESS: effective sample size of the slowest parameter. A fit's wall time is not given here, so that "
    "the table reproduces byte for byte: each fit's JSON holds it (`timing.wall_s`) and "
    "`benchmarks/friction_speed.py` measures it.", "",
    "| recording | joint | law | steps | burn-in | slowest tau (steps) | chain / tau | min ESS | converged |",
    "|---|---|---|---|---|---|---|---|---|"]

CALIBRATION_HEAD = [
    "", "## Stand calibration (posterior median [95% interval])", "",
    "The stand's added inertia `delta_i` (kg m^2, on top of the URDF's joint inertia; in Drake the joint "
    "actuator's rotor inertia delta_i / N^2 behind the gear ratio N) and `rest_offset` (rad, added to the "
    "simulated angle), fitted with each law; the shifts of the release instants from the release finder's "
    "(s) are the fitted let-go of the hand.", "",
    "| recording | joint | law | delta_i (kg m^2) | rest_offset (rad) | release shifts (s) |",
    "|---|---|---|---|---|---|"]


def table1(fits: list, out_csv: str, out_md: str, comparison_csv: str = "", robot_yaml: str = "") -> None:
    """Table I regenerated: point estimates (posterior median, MAP) and 95% intervals, next to
    the paper's values; the stand's calibration; each chain's state; the model comparison."""
    from roboball.config import load_robot

    df, chains, calib = _table1_rows(fits, load_robot(robot_yaml or None))
    write_csv_atomic(df, out_csv)
    md = list(TABLE1_HEAD)
    for r in df.itertuples():
        paper_value = f"{r.paper_table1:.4g}" if np.isfinite(r.paper_table1) else "-"
        interval = "held (not fitted)" if r.held else f"[{r.ci95_low:.4g}, {r.ci95_high:.4g}]"
        map_value = "-" if r.held else f"{r.map:.4g}"
        md.append(f"| {r.source} | {r.joint} | {_law_cell(r.law, r.converged)} | {r.parameter} | {r.median:.4g} | "
                  f"{interval} | {map_value} | {paper_value} | {r.unit} |")
    if calib:
        md += CALIBRATION_HEAD + calib
    if chains:
        md += CHAINS_HEAD + chains
    if comparison_csv:
        cmp_ = pd.read_csv(comparison_csv)
        best, why = recommendation(cmp_)
        md += ["", "## Model comparison (lower BIC is better; only a converged chain is recommended)", "",
               (f"Recommended: **{best.law}** {why}".rstrip() + "." if best is not None else f"**{why}**."), "",
               cmp_.to_markdown(index=False, floatfmt=".4g") if _has_tabulate() else _md_table(cmp_)]
    write_text_atomic(out_md, "\n".join(md) + "\n")


def _has_tabulate():
    try:
        import tabulate  # noqa: F401
        return True
    except ImportError:
        return False


def _md_table(df: pd.DataFrame) -> str:
    cols = list(df.columns)
    out = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for row in df.itertuples(index=False):
        out.append("| " + " | ".join(f"{v:.4g}" if isinstance(v, float) else str(v) for v in row) + " |")
    return "\n".join(out)


@contextmanager
def _pdf_images_copied():
    """While a figure is saved: the PDF writer keeps its own copy of each rasterised image.  It
    otherwise keeps matplotlib's cropped view (backend_mixed.stop_rasterizing), and with it the
    whole figure's raster buffer, until the file is written: the real steer log's Majd corner
    plot, a buffer per rasterised scatter panel, peaked at 1.36 GB, with copies at 0.24 GB, the
    PDF the same to the byte (tests/figures/test_corner_memory.py)."""
    from matplotlib.backends import backend_pdf

    keep = backend_pdf.PdfFile.imageObject
    backend_pdf.PdfFile.imageObject = lambda self, image: keep(self, np.array(image))
    try:
        yield
    finally:
        backend_pdf.PdfFile.imageObject = keep


def corner_plot(fit: str, out_png: str) -> None:
    """Corner plot of one posterior (law parameters and the noise level)."""
    import corner

    f = read_fit(fit)
    s = f.samples(20000)
    # the fit's own unit of each parameter (the stand's delta_i in kg m^2, rest_offset in rad)
    units = {c: (f.parameters.get(c) or {}).get("unit") or ("rad" if c == "noise_rad" else friction.UNITS.get(c, "-"))
             for c in s.columns}
    labels = [f"{c} ({units[c]})" for c in s.columns]
    k = s.shape[1]
    # corner lays its K x K grid out with subplots_adjust, which a layout engine (the style's
    # constrained layout) would ignore: the figure gets none, and room at the top for the title
    fig = plt.figure(figsize=(2.0 * k + 1.4, 2.0 * k + 1.7), layout="none")
    corner.corner(s.to_numpy(), fig=fig, labels=labels, quantiles=[0.025, 0.5, 0.975], show_titles=True,
                  title_fmt=".3g", title_kwargs={"fontsize": 8}, label_kwargs={"fontsize": 8},
                  max_n_ticks=4)            # five rotated labels per 2-inch panel ran into the next panel's
    for ax in fig.axes:
        ax.tick_params(labelsize=7)
    fig.subplots_adjust(top=1.0 - 1.2 / (2.0 * k + 1.7), left=0.9 / (2.0 * k + 1.4), bottom=0.9 / (2.0 * k + 1.7))
    fig.suptitle(f"Posterior: {f.law.replace('_', '+')} friction, {f.joint} joint ({f.recording})\n"
                 "dashed: 2.5, 50 and 97.5% quantiles", fontsize=9, y=0.995)
    with _pdf_images_copied():
        save(fig, out_png)
