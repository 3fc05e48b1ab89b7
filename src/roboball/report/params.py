"""`roboball report --params`: the current parameter posteriors and PME intervals as Markdown.

Reads what the pipeline already wrote and reruns nothing (no simulation, no fit):

* joint friction posteriors: every fit JSON under results/friction/ (median and 95% interval of
  each parameter, chain convergence when recorded) and the model comparisons beside them
  (*_comparison.csv, the converged fit of lowest BIC recommended);
* shell regressions (Fig. 10): results/identify/shell_regression.csv, plus what they give at the
  test pressures (zeta, omega_n, K_inject and C_inject of eq. 7-8, the hydroelastic modulus of
  eq. 10) from the robot facts;
* ramp drive-speed PME (eq. 12): paper_figures/table_pme.csv (mean, run range and friction-
  posterior interval per contact model and pressure), else aggregated from results/ramp/summary.csv.

A source that has not been produced yet is listed as missing; with none at all the command
stops with one line saying what to run.
"""
from __future__ import annotations

import math
from pathlib import Path

from roboball.errors import RoboballError
from roboball.identify.friction.comparison import recommendation
from roboball.identify.friction.results import try_read_fit
from roboball.metrics import pme_table

PRESSURES_KPA = (6.9, 10.3, 13.8, 17.2, 20.7)


def _fmt(x, spec=".4g") -> str:
    try:
        x = float(x)
    except (TypeError, ValueError):
        return str(x)
    return "n/a" if not math.isfinite(x) else format(x, spec)


def _md_table(header: list, rows: list) -> list:
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return out


def _friction(results: Path, missing: list) -> list:
    root = results / "friction"
    fits = []
    for path in sorted(root.rglob("*.json")) if root.is_dir() else []:
        fit = try_read_fit(path)           # None for the JSON files there that are not fits
        if fit is not None:
            fits.append((path, fit))
    if not fits:
        missing.append(f"{root}/**/*.json (friction fits)")
        return []
    lines = ["## Joint friction posteriors", "",
             "Posterior median and 95% interval of each parameter (torques in N m, rates in rad/s).", ""]
    rows = []
    for path, d in fits:
        ok = {True: "yes", False: "NO"}.get(d.convergence.get("converged"), "n/a")
        for name, p in d.parameters.items():
            rows.append([d.recording or path.parent.name, d.joint, d.law, name, _fmt(p["median"]),
                         f"[{_fmt(p['ci95_low'])}, {_fmt(p['ci95_high'])}]", ok])
    lines += _md_table(["recording", "joint", "law", "parameter", "median", "95% interval", "converged"], rows)
    conv_rows = []
    for path, d in fits:
        c = d.convergence
        if c:
            tau = c.get("max_tau", float("nan"))
            steps = c.get("steps", float("nan"))
            conv_rows.append([d.recording or path.parent.name, d.joint, d.law, _fmt(steps, ".0f"),
                              _fmt(tau, ".1f"), _fmt(steps / tau if tau else float("nan"), ".0f"),
                              _fmt(c.get("acceptance_fraction"), ".2f"), _fmt(c.get("ess_min"), ".0f")])
    if conv_rows:
        lines += ["", "Chains: length over the longest integrated autocorrelation time (tau), acceptance, "
                  "smallest effective sample size.", ""]
        lines += _md_table(["recording", "joint", "law", "steps", "max tau", "steps/tau", "acceptance", "min ESS"],
                           conv_rows)
    comparisons = sorted(root.rglob("*_comparison.csv"))
    if comparisons:
        import pandas as pd

        lines += ["", "Model comparison (lowest BIC of a converged chain recommended):", ""]
        for path in comparisons:
            c = pd.read_csv(path)
            if not {"law", "bic"} <= set(c.columns):
                raise RoboballError(f"{path}: model comparison needs columns law, bic")
            c = c.sort_values("bic")
            best, why = recommendation(c)
            head = f"**{best.law}** {why}".rstrip() if best is not None else f"**{why}**"
            lines.append(f"- {path.parent.name}/{path.stem}: {head} "
                         f"({', '.join(f'{r.law} {r.bic:.1f}' for r in c.itertuples())})")
    return lines + [""]


def _shell(results: Path, missing: list) -> list:
    import pandas as pd

    from roboball.config import load_robot
    from roboball.physics import shell as shell_laws

    path = results / "identify" / "shell_regression.csv"
    if not path.is_file():
        missing.append(f"{path} (shell regression)")
        return []
    t = pd.read_csv(path)
    need = {"name", "value"}
    if not need <= set(t.columns):
        raise RoboballError(f"{path}: needs columns name, value (has {', '.join(t.columns)})")
    v = t.set_index("name")
    for key in ("zeta_a", "zeta_b", "omega_n_c", "omega_n_d"):
        if key not in v.index:
            raise RoboballError(f"{path}: missing row '{key}'")
    lines = ["## Shell regressions (Fig. 10)", "",
             "zeta(p) = a exp(b p), omega_n(p) = c + d p, p in kPa; 95% intervals of the fit. "
             "`*_tau`: the scatter between releases beyond their fits' errors, which weights each release "
             "(Paule-Mandel; 95% Q-profile interval).", ""]
    rows = []
    for r in t.itertuples():
        ci = f"[{_fmt(r.ci95_low)}, {_fmt(r.ci95_high)}]" if hasattr(r, "ci95_low") else "n/a"
        rows.append([r.name, _fmt(r.value), ci, getattr(r, "unit", ""), getattr(r, "n_points", "")])
    lines += _md_table(["parameter", "value", "95% interval", "unit", "points"], rows)
    robot = load_robot()
    rows = []
    for p in PRESSURES_KPA:
        zeta = shell_laws.zeta_of_p(p, v.value["zeta_a"], v.value["zeta_b"])
        omega = shell_laws.omega_n_of_p(p, v.value["omega_n_c"], v.value["omega_n_d"])
        rows.append([f"{p:g}", _fmt(zeta), _fmt(omega), _fmt(shell_laws.k_inject(omega, robot.M_eq, robot.K_eq)),
                     _fmt(shell_laws.c_inject(zeta, omega, robot.M_eq)),
                     _fmt(shell_laws.hydro_modulus(p * 1e3, robot.weight_n, robot.radius), ".3g")])
    lines += ["", "What the regressions give at the test pressures (eq. 7, 8, 10):", ""]
    lines += _md_table(["pressure (kPa)", "zeta", "omega_n (rad/s)", "K_inject (N m/rad)", "C_inject (N m s/rad)",
                        "hydro modulus (Pa)"], rows)
    return lines + [""]


def _pme(results: Path, figures: Path, missing: list) -> list:
    import pandas as pd

    table = figures / "table_pme.csv"
    summary = results / "ramp" / "summary.csv"
    if table.is_file():
        agg, source = pd.read_csv(table), table
        need = {"contact", "pressure_kpa", "pme_mean_percent"}
        if not need <= set(agg.columns):
            raise RoboballError(f"{table}: needs columns {', '.join(sorted(need))}")
    elif summary.is_file():
        s, source = pd.read_csv(summary), summary
        need = {"contact", "pressure_kpa", "pme_percent"}
        if not need <= set(s.columns):
            raise RoboballError(f"{summary}: needs columns {', '.join(sorted(need))}")
        agg = pme_table(s)
    else:
        missing.append(f"{table} or {summary} (ramp PME)")
        return []
    lines = ["## Ramp drive-speed PME (eq. 12)", "",
             f"From {source}. Positive: the model rolls faster than the robot. Runs: range over the recorded runs; "
             "posterior: 95% range over friction-posterior draws propagated through the simulations.", ""]
    rows = []
    for r in agg.sort_values(["contact", "pressure_kpa"]).itertuples():
        runs = f"[{_fmt(r.pme_min_percent, '.1f')}, {_fmt(r.pme_max_percent, '.1f')}]" \
            if hasattr(r, "pme_min_percent") else "n/a"
        post = f"[{_fmt(r.pme_post_low_percent, '.1f')}, {_fmt(r.pme_post_high_percent, '.1f')}]" \
            if hasattr(r, "pme_post_low_percent") else "n/a"
        rows.append([r.contact, _fmt(r.pressure_kpa, "g"), _fmt(r.pme_mean_percent, ".1f"), runs, post,
                     getattr(r, "runs", "")])
    lines += _md_table(["contact", "pressure (kPa)", "mean PME (%)", "runs (%)", "posterior 95% (%)", "n runs"], rows)
    overall = agg.groupby("contact").pme_mean_percent.apply(lambda x: x.abs().mean()).sort_values()
    lines += ["", "Mean |PME| over pressures: " + ", ".join(f"{c} {v:.1f}%" for c, v in overall.items())
              + f"; recommended contact model: **{overall.index[0]}**."]
    return lines + [""]


def render(results="results", figures="paper_figures") -> str:
    """The Markdown report from the files under `results` and `figures`."""
    results, figures = Path(results), Path(figures)
    missing: list = []
    body = _friction(results, missing) + _shell(results, missing) + _pme(results, figures, missing)
    if not body:
        raise RoboballError(f"{results}: no parameter results yet (missing {'; '.join(missing)}); "
                            "run the pipeline first ('make figures')")
    head = ["# roboball: parameter posteriors and PME intervals", "",
            f"Rendered from `{results}/` and `{figures}/` as they are now; no simulation or fit was rerun.", ""]
    if missing:
        head += ["Not available yet: " + "; ".join(missing) + ".", ""]
    return "\n".join(head + body)
