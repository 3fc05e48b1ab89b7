"""The parameter-uncertainty report: one self-contained HTML page (figures embedded) with every
identified parameter (median and 95% interval), convergence diagnostics, the model comparisons,
the shell regressions, the hydroelastic sweep, the PME table with posterior intervals and the
diagnoses; red flags first, for every unconverged chain and every recommendation that rests on
one.
"""
from __future__ import annotations

import html
import json
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd

from roboball.atomic import write_text_atomic
from roboball.errors import RoboballError
from roboball.identify.friction.comparison import recommendation
from roboball.identify.friction.results import read_fit
from roboball.report import markdown
from roboball.report.uncertainty_page import CSS, PAGE, png_data_uri

STAGES = ("uncertainty_report",)

# The Snakemake report embeds each result as a data URI; Chromium opens none over 2 MiB.
DATA_URI_LIMIT = 2 * 1024 * 1024

# What each paper figure shows (the report's captions; workflow/report/*.rst say the same at length).
FIGURE_CAPTIONS = {
    "fig5_friction_laws": "Fig. 5: friction torque against joint velocity for every fitted law; lines are posterior "
                          "medians, bands 95% posterior intervals of the torque.",
    "fig7_testbed_steer_fits": "Fig. 7 (test bed): the steer stand's recording (dots) and each fitted steer law "
                               "simulated from its fitted release; the legend gives each law's residual RMS.",
    "fig7_real_steer_fits": "Fig. 7 (the authors' real log): the steer stand's recording and each fitted steer law "
                            "simulated from its fitted release.",
    "fig8_testbed_drive_fits": "Fig. 8: the drive stand's recording and the fitted Majd law simulated from its fitted "
                               "release.",
    "fig10_shell_dynamics": "Fig. 10: the shell's damping ratio and natural frequency against pressure, one point per "
                            "release, with the fitted regressions and their 95% bands; squares are Drake simulations "
                            "of each contact model.",
    "fig11_hydro_sensitivity": "Fig. 11: simulated damping ratio when the hydroelastic modulus and dissipation are "
                               "scaled by 0.5 and 1.5, and the change of its error against the control.",
    "fig13_ramp_pme": "Fig. 13: drive-speed point mean error (eq. 12) of each contact model at each pressure; dots "
                      "are runs, whiskers 95% ranges over friction-posterior draws.",
    "fig14_ramp_pme_mean": "Fig. 14: drive-speed error of each contact model over all pressures and runs: the signed "
                           "PME of eq. 12 and the mean absolute error.",
    "figS3_hydro_calibration": "Fig. S3 (beyond the paper): the hydroelastic shell calibrated to the shell releases: "
                               "Drake's damping ratio and natural frequency over modulus and dissipation, the fitted "
                               "values with 95% intervals as contact volumes V(p) (eq. 10) against the membrane law "
                               "and the authors' values, and the fitted dissipations against eq. 11.",
}


def _cell(v) -> str:
    """One table cell: numbers to 4 significant digits (right-aligned), yes/no for booleans,
    an em dash for a missing number."""
    if isinstance(v, (bool, np.bool_)):
        return f"<td>{'yes' if v else 'no'}</td>"
    if isinstance(v, (float, np.floating, int, np.integer)):
        if isinstance(v, (float, np.floating)) and not math.isfinite(v):
            return "<td class='num'>&mdash;</td>"
        return f"<td class='num'>{v:.4g}</td>" if isinstance(v, (float, np.floating)) else f"<td class='num'>{v}</td>"
    if v == "no":
        return "<td class='bad'>no</td>"
    return f"<td>{html.escape(str(v))}</td>"


def table(df: pd.DataFrame, bad=None) -> str:
    """An HTML table of `df`; rows where `bad` (a boolean sequence) is true are red."""
    if df.empty:
        return "<p><em>none</em></p>"
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in df.columns)
    flags = list(bad) if bad is not None else [False] * len(df)
    rows = []
    for r, flag in zip(df.itertuples(index=False), flags):
        cls = ' class="bad"' if flag else ""
        rows.append(f"<tr{cls}>{''.join(_cell(v) for v in r)}</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>"


def _interval(p: dict, fmt: str = ".4g") -> str:
    return f"{p['median']:{fmt}} [{p['ci95_low']:{fmt}}, {p['ci95_high']:{fmt}}]"


def _fit_tables(fits: list) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """(parameters, chains, stand calibration) of the friction fits, one row per parameter, fit
    and fit; each with a boolean ``_bad`` column for the unconverged chains."""
    rows, conv, calib = [], [], []
    for path in fits:
        f = read_fit(path)
        c = f.convergence
        bad = not c.get("converged", False)
        for name, p in f.parameters.items():
            if name.startswith("release"):
                continue
            rows.append({"recording": f.recording, "joint": f.joint, "law": f.law, "parameter": name,
                         "median": p["median"], "ci95_low": p["ci95_low"], "ci95_high": p["ci95_high"], "_bad": bad})
        conv.append({"recording": f.recording, "joint": f.joint, "law": f.law, "converged": not bad,
                     "steps": c["steps"], "max_tau (steps)": c["max_tau"],
                     "chain / tau": c.get("chain_over_tau", float("nan")),
                     "acceptance": c["acceptance_fraction"], "ESS min": c["ess_min"],
                     "rmse (rad)": f.stats["rmse_rad"], "_bad": bad})
        stand = f.stand()
        if stand:
            calib.append({"recording": f.recording, "joint": f.joint, "law": f.law,
                          "delta_i (kg m^2)": _interval(stand["delta_i"]),
                          "rest_offset (rad)": _interval(stand["rest_offset"]),
                          "release shifts (s)": ", ".join(f"{s:+.3f}" for s in (f.release_shift_medians() or [])),
                          "_bad": bad})
    return pd.DataFrame(rows), pd.DataFrame(conv), pd.DataFrame(calib)


def _flagged(df: pd.DataFrame) -> str:
    return table(df.drop(columns="_bad"), bad=df["_bad"]) if not df.empty else "<p><em>none</em></p>"


def _chain_flags(conv: pd.DataFrame) -> list:
    return [f"Chain not converged: {r['recording']} {r['joint']} {r['law']} (chain {r['chain / tau']:.3g} "
            f"autocorrelation times long, {r['steps']} steps); its posterior is not a result."
            for _, r in conv[conv["_bad"]].iterrows()] if not conv.empty else []


def _comparison(path: str, flags: list) -> str:
    """One comparison: its recommendation (red when none, or when it rests on leaving out a
    law of lower BIC whose chain did not converge) and its table."""
    cmp_ = pd.read_csv(path)
    name = f"{Path(path).parent.name} {Path(path).stem.replace('_', ' ')}"
    best, why = recommendation(cmp_)
    if best is None:
        flags.append(f"{name}: {why}.")
        head = f"<span class='bad'>{html.escape(why)}</span>"
    elif "did not converge" in why:
        flags.append(f"{name}: the recommendation of {best.law} rests on an unconverged chain {why}; "
                     "it may change once that chain converges.")
        head = f"recommended law <b>{html.escape(best.law)}</b> <span class='bad'>{html.escape(why)}</span>"
    else:
        head = f"recommended law <b>{html.escape(best.law)}</b> {html.escape(why)}"
    unconverged = ~cmp_["converged"].astype(bool) if "converged" in cmp_ else None
    return f"<p class='rec'><b>{html.escape(name)}</b>: {head}.</p>" + table(cmp_, bad=unconverged)


def _friction_section(fits: list, comparisons: list, flags: list) -> dict:
    """Section: the friction posteriors, the stand's calibration, the chains' convergence and
    the model comparisons (unconverged chains in red, never recommended)."""
    params, conv, calib = _fit_tables(fits)
    flags += _chain_flags(conv)
    intro = ("<p>Each law is fitted on the calibrated stand: the stand's added inertia <code>delta_i</code> "
             "(the gearbox's reflected rotor inertia J N<sup>2</sup>, which the URDF leaves out, net of the "
             "URDF's own inertia error) and its <code>rest_offset</code> are fitted with the law, and so is each "
             "release's instant. Rows in red belong to a chain that did not converge.</p>")
    subs = [{"id": "posteriors", "title": "Posteriors (median, 95% interval)", "body": _flagged(params)},
            {"id": "calibration", "title": "Stand calibration (median [95% interval])", "body": _flagged(calib)},
            {"id": "convergence", "title": "Convergence",
             "body": "<p>A chain counts as converged when its length is at least <code>friction.autocorr_multiple"
                     "</code> (50) integrated autocorrelation times of every parameter. Wall times are left out so "
                     "that the report reproduces byte for byte: each fit's JSON holds them (<code>timing.wall_s</code>) "
                     "and <code>benchmarks/friction_speed.py</code> measures them.</p>" + _flagged(conv)},
            {"id": "comparison", "title": "Model comparison",
             "body": "".join(_comparison(p, flags) for p in comparisons) or "<p><em>none</em></p>"}]
    return {"id": "friction", "title": "Joint friction (emcee posteriors)", "body": intro, "subs": subs}


def _pressure(text) -> float:
    """The pressure (kPa) in a name like "ramp_13.8kpa" or a number; inf when there is none."""
    if isinstance(text, (int, float)):
        return float(text)
    m = re.search(r"(\d+(?:\.\d+)?)\s*kpa", str(text), re.I)
    return float(m.group(1)) if m else math.inf


def _pme_section(pme_table: str, ramp_friction: list, flags: list) -> dict:
    """Section: the PME table sorted by contact model and numeric pressure, the recommended
    contact model (flagged when the friction it draws from did not converge)."""
    pme = pd.read_csv(pme_table)
    if "pressure_kpa" in pme:
        pme = pme.assign(pressure_kpa=pd.to_numeric(pme["pressure_kpa"])).sort_values(
            ["contact", "pressure_kpa"], kind="stable")
    best = pme.groupby("contact").pme_mean_percent.apply(lambda s: s.abs().mean()).sort_values()
    rec = f"<p class='rec'>Recommended contact model (smallest mean |PME| over pressures): <b>{html.escape(best.index[0])}</b>."
    shaky = [read_fit(p) for p in ramp_friction]
    shaky = [f"{f.recording} {f.joint} {f.law}" for f in shaky if not f.convergence.get("converged", False)]
    if shaky:
        flags.append(f"The ramp's PME and its recommended contact model ({best.index[0]}) rest on friction "
                     f"from unconverged chains: {', '.join(shaky)}.")
        rec += f" <span class='bad'>It rests on friction from unconverged chains: {html.escape(', '.join(shaky))}.</span>"
    return {"id": "pme", "title": "Ramp drive-speed PME with friction-posterior intervals",
            "body": rec + "</p>" + table(pme), "subs": []}


def _diagnosis_row(path: str) -> dict:
    with open(path, encoding="utf-8") as fh:
        d = json.load(fh)
    found = "; ".join(f"{m['effect']} ({m.get('dof', '')}: " + ", ".join(f"{k} = {v:.3g}" for k, v in m["parameters"].items())
                      + ")" for m in d.get("missing_physics", [])) or "none"
    fit = d.get("fit", {})
    return {"diagnosed": Path(path).parent.name, "kind": d["kind"], "verdict": d["verdict"], "missing physics": found,
            "held-out RMSE before": fit.get("rmse_heldout_before", float("nan")),
            "after": fit.get("rmse_heldout_after", float("nan")), "unit": fit.get("units", ""),
            "supported, below materiality (not added)": _immaterial(Path(path).with_name("details.json")) or "none"}


def _immaterial(details_path) -> str:
    """The candidates a diagnosis found supported by the data but below materiality, read from
    its details.json when there is one, e.g. at 10.3 kPa "quadratic_drag (c2 = 0.054 [...]; lowers
    the held-out mean square by 0.71 noise variances)" after the damping and rolling resistance."""
    path = Path(details_path)
    if not path.exists():
        return ""
    with open(path, encoding="utf-8") as fh:
        found = json.load(fh).get("immaterial") or []
    out = []
    for i in found:
        params = ", ".join(f"{k.split('.', 1)[1]} = {v:.3g} [{i['ci95'][k][0]:.3g}, {i['ci95'][k][1]:.3g}]"
                           for k, v in i["params"].items())
        out.append(f"{i['effect']} ({params}; lowers the held-out mean square by {i['heldout_gain']:.2g} noise variances)")
    return ", ".join(out)


def _diagnosis_section(diagnoses: list) -> dict:
    rows = sorted((_diagnosis_row(p) for p in diagnoses), key=lambda r: (r["kind"], _pressure(r["diagnosed"]), r["diagnosed"]))
    return {"id": "diagnosis", "title": "Diagnosis of missing physics",
            "body": "<p>What <code>roboball diagnose</code> found each model leaves out, with the held-out error "
                    "before and after adding it (the ramp runs pooled per pressure).</p>" + table(pd.DataFrame(rows)),
            "subs": []}


def _figures_section(figures: list) -> dict:
    parts = []
    for f in figures:
        p = Path(f)
        if not p.exists():
            raise RoboballError(f"{p}: figure not found (the uncertainty report embeds it)")
        text = FIGURE_CAPTIONS.get(p.stem, p.name)
        parts.append(f"<figure><img src='{png_data_uri(p)}' alt='{html.escape(text)}'>"
                     f"<figcaption>{html.escape(text)} <code>{html.escape(p.name)}</code></figcaption></figure>")
    return {"id": "figures", "title": "Figures", "body": "\n".join(parts), "subs": []}


def uncertainty_report(fits: list, comparisons: list, regression: str, pme_table: str, sweep_md: str,
                       figures: list, out_html: str, diagnoses: list = [], ramp_friction: list = []) -> None:  # noqa: B006
    """Render the report from the pipeline's results (no simulation is rerun).  A campaign
    without shell releases at several pressures or without ramp runs has no regression, sweep
    or PME table (an empty `regression`, `sweep_md`, `pme_table`): those sections are left out.

    Args:
        ramp_friction: the fit JSONs whose posteriors the ramp simulations draw from (their
            convergence decides whether the PME recommendation is flagged).
    Raises:
        RoboballError: when the page would be over 2 MiB as a data URI (the Snakemake report).
    """
    flags: list = []
    sections = [_friction_section(fits, comparisons, flags)] if fits else []
    if regression:
        sections.append({"id": "shell", "title": "Shell regressions (Fig. 10)",
                         "body": table(pd.read_csv(regression)), "subs": []})
    if sweep_md:
        sections.append({"id": "sweep", "title": "Hydroelastic sweep",
                         "body": markdown.to_html(Path(sweep_md).read_text(encoding="utf-8"), shift=2), "subs": []})
    if pme_table:
        sections.append(_pme_section(pme_table, ramp_friction, flags))
    if diagnoses:
        sections.append(_diagnosis_section(diagnoses))
    sections.append(_figures_section(figures))
    page = PAGE.render(css=CSS, flags=[html.escape(f) for f in flags], sections=sections)
    n = len(page.encode("utf-8"))
    if len("data:text/html;base64,") + 4 * math.ceil(n / 3) > DATA_URI_LIMIT:
        raise RoboballError(f"{out_html}: {n} bytes, over the 2 MiB a browser opens as the Snakemake report's data URI")
    write_text_atomic(out_html, page)

