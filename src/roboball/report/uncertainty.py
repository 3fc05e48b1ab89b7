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


def _table(df: pd.DataFrame, floatfmt="{:.4g}") -> str:
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in df.columns)
    rows = []
    for r in df.itertuples(index=False):
        cells = "".join(f"<td>{floatfmt.format(v) if isinstance(v, (float, np.floating)) else html.escape(str(v))}</td>" for v in r)
        rows.append(f"<tr>{cells}</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>"


def _friction_section(fits: list, comparisons: list) -> list:
    """Section 1: the friction posteriors, their chains' convergence and the model comparisons."""
    parts = ["<h2>1. Joint friction (emcee posteriors)</h2>"]
    rows, conv = [], []
    for path in fits:
        f = read_fit(path)
        for name, p in f.parameters.items():
            if name.startswith("release"):
                continue
            rows.append({"recording": f.recording, "joint": f.joint, "law": f.law, "parameter": name,
                         "median": p["median"], "ci95_low": p["ci95_low"], "ci95_high": p["ci95_high"]})
        c = f.convergence
        conv.append({"recording": f.recording, "joint": f.joint, "law": f.law,
                     "steps": c["steps"], "max_tau_steps": c["max_tau"],
                     "chain_over_tau": c.get("chain_over_tau", float("nan")),
                     "acceptance": c["acceptance_fraction"], "ess_min": c["ess_min"],
                     "converged": "yes" if c["converged"] else "NO", "rmse_rad": f.stats["rmse_rad"]})
    parts.append(_table(pd.DataFrame(rows)))
    parts.append("<h3>Convergence</h3><p>A chain counts as converged when its length is at least "
                 "<code>friction.autocorr_multiple</code> (50) integrated autocorrelation times of every parameter.</p>")
    parts.append(_table(pd.DataFrame(conv)))
    parts.append("<h3>Model comparison</h3>")
    for path in comparisons:
        cmp_ = pd.read_csv(path)
        best = cmp_.sort_values("bic").iloc[0]
        second = cmp_.sort_values("bic").iloc[1] if len(cmp_) > 1 else None
        margin = f" by &Delta;BIC = {second.bic - best.bic:.1f}" if second is not None else ""
        parts.append(f"<p><b>{html.escape(Path(path).stem)}</b>: recommended law <b>{best.law}</b>{margin}.</p>")
        parts.append(_table(cmp_))
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
