"""The parameter-uncertainty report: one self-contained HTML file (figures embedded) with every
identified parameter (median and 95% interval), convergence diagnostics, posterior-predictive
bands over the data, the shell regressions, the PME table with posterior intervals, and which
model each table recommends."""
from __future__ import annotations

import base64
import html
import json
from pathlib import Path

import numpy as np
import pandas as pd

from roboball.atomic import write_text_atomic
from roboball.identify.friction.comparison import recommendation
from roboball.identify.friction.results import read_fit

STAGES = ("uncertainty_report",)


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


def _img(path) -> str:
    p = Path(path)
    if not p.exists():
        return f"<p><em>missing figure {html.escape(str(p))}</em></p>"
    data = base64.b64encode(p.read_bytes()).decode()
    return f'<figure><img src="data:image/png;base64,{data}" style="max-width:100%"><figcaption>{html.escape(p.name)}</figcaption></figure>'


def _table(df: pd.DataFrame, floatfmt="{:.4g}", bad=None) -> str:
    """An HTML table of `df`; rows where `bad` (a boolean sequence) is true are red."""
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in df.columns)
    rows = []
    flags = list(bad) if bad is not None else [False] * len(df)
    for r, flag in zip(df.itertuples(index=False), flags):
        cells = "".join(f"<td>{floatfmt.format(v) if isinstance(v, (float, np.floating)) else html.escape(str(v))}</td>" for v in r)
        rows.append(f"<tr class='bad'>{cells}</tr>" if flag else f"<tr>{cells}</tr>")
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
        conv.append({"recording": f.recording, "joint": f.joint, "law": f.law,
                     "steps": c["steps"], "max_tau_steps": c["max_tau"],
                     "chain_over_tau": c.get("chain_over_tau", float("nan")),
                     "acceptance": c["acceptance_fraction"], "ess_min": c["ess_min"],
                     "converged": "yes" if not bad else "NO", "wall_s": f.timing.get("wall_s", float("nan")),
                     "rmse_rad": f.stats["rmse_rad"], "_bad": bad})
        stand = f.stand()
        if stand:
            calib.append({"recording": f.recording, "joint": f.joint, "law": f.law,
                          "delta_i (kg m^2)": _interval(stand["delta_i"]),
                          "rest_offset (rad)": _interval(stand["rest_offset"]),
                          "release shifts (s)": ", ".join(f"{s:+.3f}" for s in (f.release_shift_medians() or [])),
                          "_bad": bad})
    return pd.DataFrame(rows), pd.DataFrame(conv), pd.DataFrame(calib)


def _flagged(df: pd.DataFrame) -> str:
    return _table(df.drop(columns="_bad"), bad=df["_bad"]) if not df.empty else "<p><em>none</em></p>"


def _friction_section(fits: list, comparisons: list) -> list:
    """Section 1: the friction posteriors, the stand's calibration, the chains' convergence and
    the model comparisons (unconverged chains in red, never recommended)."""
    params, conv, calib = _fit_tables(fits)
    parts = ["<h2>1. Joint friction (emcee posteriors)</h2>",
             "<p>Each law is fitted on the calibrated stand: the stand's added inertia <code>delta_i</code> "
             "(the gearbox's reflected rotor inertia J N<sup>2</sup>, which the URDF leaves out, net of the "
             "URDF's own inertia error) and its <code>rest_offset</code> are fitted with the law, and so is each "
             "release's instant. Rows in red belong to a chain that did not converge.</p>",
             _flagged(params), "<h3>Stand calibration (median [95% interval])</h3>", _flagged(calib),
             "<h3>Convergence</h3><p>A chain counts as converged when its length is at least "
             "<code>friction.autocorr_multiple</code> (50) integrated autocorrelation times of every parameter.</p>",
             _flagged(conv), "<h3>Model comparison</h3>"]
    for path in comparisons:
        cmp_ = pd.read_csv(path)
        best, why = recommendation(cmp_)
        head = (f"recommended law <b>{html.escape(best.law)}</b> {html.escape(why)}" if best is not None
                else f"<span class='bad'>{html.escape(why)}</span>")
        parts.append(f"<p><b>{html.escape(Path(path).stem)}</b>: {head}.</p>")
        unconverged = ~cmp_["converged"].astype(bool) if "converged" in cmp_ else None
        parts.append(_table(cmp_, bad=unconverged))
    return parts


def uncertainty_report(fits: list, comparisons: list, regression: str, pme_table: str, sweep_md: str,
                       figures: list, out_html: str, diagnoses: list = []) -> None:  # noqa: B006
    """Render the report from the pipeline's results (no simulation is rerun)."""
    parts = ["<!doctype html><html><head><meta charset='utf-8'><title>roboball: parameter uncertainty</title>",
             "<style>body{font-family:sans-serif;max-width:1100px;margin:auto;padding:1em}"
             "table{border-collapse:collapse;margin:0.5em 0}td,th{border:1px solid #bbb;padding:2px 6px;font-size:13px}"
             "th{background:#eee}.bad{color:#b00;font-weight:bold}</style></head><body>",
             "<h1>Parameter-uncertainty report</h1>",
             "<p>Every identified parameter with its posterior median and 95% interval, how well each chain "
             "converged, and which model each comparison recommends. Generated by the pipeline from "
             "<code>results/</code>; nothing here is typed by hand.</p>"]
    parts += _friction_section(fits, comparisons)
    # Shell
    parts.append("<h2>2. Shell regressions (Fig. 10)</h2>")
    parts.append(_table(pd.read_csv(regression)))
    parts.append("<h2>3. Hydroelastic sweep</h2><pre>" + html.escape(Path(sweep_md).read_text()) + "</pre>")
    # Ramp
    parts.append("<h2>4. Ramp drive-speed PME with friction-posterior intervals</h2>")
    pme = pd.read_csv(pme_table)
    best = pme.groupby("contact").pme_mean_percent.apply(lambda s: s.abs().mean()).sort_values()
    parts.append(f"<p>Recommended contact model (smallest mean |PME| over pressures): <b>{best.index[0]}</b>.</p>")
    parts.append(_table(pme))
    if diagnoses:
        parts.append("<h2>5. Diagnosis of missing physics</h2>")
        for path in diagnoses:
            with open(path, encoding="utf-8") as fh:
                d = json.load(fh)
            found = ", ".join(f"{m['effect']} ({m.get('dof', '')}: " + ", ".join(f"{k} = {v:.3g}" for k, v in m["parameters"].items()) + ")"
                              for m in d.get("missing_physics", [])) or "none"
            fit = d.get("fit", {})
            hint = _immaterial(Path(path).with_name("details.json"))
            parts.append(f"<p><b>{html.escape(Path(path).parent.name)}</b> ({d['kind']}): verdict <b>{d['verdict']}</b>; "
                         f"missing physics: {html.escape(found)}; held-out RMSE {fit.get('rmse_heldout_before', float('nan')):.4g} "
                         f"&rarr; {fit.get('rmse_heldout_after', float('nan')):.4g} {fit.get('units', '')}"
                         + (f"; supported by the data but below materiality (not added): {html.escape(hint)}" if hint else "")
                         + ".</p>")
    parts.append("<h2>Figures</h2>")
    parts += [_img(f) for f in figures]
    parts.append("</body></html>")
    write_text_atomic(out_html, "\n".join(parts))
