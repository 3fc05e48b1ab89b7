"""`roboball diagnose --kind steer_coupled`: the coupled test's diagnosis, written to the contract.

The baseline (diagnosis.md, steer_coupled) is the calibrated model: the stand-fitted steer
friction (a friction fit JSON with its delta_i) and the injected shell at the recordings' logged
pressure, else at the pressure fitted on the data; the effects are chosen per degree of freedom (roboball.diagnose.coupled_effects).
The model reported (`missing_physics`, `fit.rmse_*`) is fitted on all the recordings given (one
recording: on its first two thirds); held-out numbers are the folds' (leave one repeat out, or
the last third of a single recording).  Writes diagnosis.json, report.md, predictions.csv and
overlay.png into the output folder.
"""
from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd

from roboball.atomic import output_folder, write_csv_atomic, write_json_atomic, write_text_atomic
from roboball.errors import RoboballError
from roboball.physics import effects as fx
from roboball.diagnose.coupled import COORDS, fit_pressure, logged_pressure, read_repeats
from roboball.diagnose.coupled_effects import (baseline_spec, effect_spec, fit_chosen, fold_summary, folds_of,
                                               held_out, key, predict_all, rms_by_coord, screen, truncated)
from roboball.diagnose.scored import Settings
from roboball.diagnose.sensor_fit import sample_noise
from roboball.metrics import lag1

# Where the baseline's residual is located: thirds of each recording's span.
REGIMES = ("large_amplitude", "small_amplitude", "late_decay")


def located(preds: dict, reps, masks) -> list:
    """Each coordinate's squared residual by third of the run, as shares of the total."""
    rows, total = [], 0.0
    for c in COORDS:
        for k, regime in enumerate(REGIMES):
            sq, t0, t1 = 0.0, math.inf, -math.inf
            for r in reps:
                if r.name not in masks:
                    continue
                span = r.t[-1]
                m = masks[r.name] & (r.t >= k * span / 3) & (r.t <= (k + 1) * span / 3)
                if m.any():
                    e = preds[r.name][c][m] - r.coord(c)[m]
                    sq += float(e @ e)
                    t0, t1 = min(t0, float(r.t[m][0])), max(t1, float(r.t[m][-1]))
            if t1 >= t0:           # a third outside the fitted samples has nothing to locate
                rows.append({"start_s": t0, "end_s": t1, "signal": c, "regime": regime, "sq": sq})
            total += sq
    for row in rows:
        row["share_of_residual"] = row.pop("sq") / total if total > 0 else 0.0
    return sorted(rows, key=lambda r: -r["share_of_residual"])


def recorded_noise(reps, masks) -> float:
    """The recordings' noise level over both coordinates (rad): per coordinate the median over
    the repeats of `sample_noise` on the fitted samples, pooled as the fit's RMS pools them."""
    per = [np.median([sample_noise(r.t[masks[r.name]], r.coord(c)[masks[r.name]]) for r in reps if r.name in masks])
           for c in COORDS]
    return float(np.sqrt(np.mean(np.square(per))))


def verdict(fit, pred_base, reps, masks, noise: float, s: Settings = Settings()) -> str:
    """The contract's verdict by the rule of the other kinds (`Settings.verdict`), on the fitted
    samples of both coordinates."""
    res = {(r.name, c): pred_base[r.name][c][masks[r.name]] - r.coord(c)[masks[r.name]]
           for r in reps if r.name in masks for c in COORDS}
    return s.verdict(bool(fit.values), fit.rmse_base_train, fit.rmse_train, lag1(res), noise)


def _alternatives(table: dict, chosen: list, n: int = 3) -> list:
    """The next best sets of the screen (they explain the residual about as well, linearised)."""
    name = "+".join(key(*c) for c in chosen)
    score = "rmse_inner_cv" if any("rmse_inner_cv" in v for v in table.values()) else "delta_bic"
    ranked = sorted(((k, v) for k, v in table.items() if k != name and v["delta_bic"] < 0), key=lambda kv: kv[1][score])
    return [{"effects": k.split("+"), "rmse_linear": v["rmse_linear"], "delta_bic": v["delta_bic"],
             **({"rmse_inner_cv": v["rmse_inner_cv"]} if "rmse_inner_cv" in v else {})} for k, v in ranked[:n]]


def _missing(fit, alternatives) -> list:
    out = []
    for (dof, name), value in fit.values.items():
        eff = fx.LIBRARY[name]
        p = eff.params[0]
        out.append({"effect": name, "dof": dof, "parameters": {p.name: value},
                    "ci95": {p.name: list(fit.ci95[(dof, name)])}, "units": {p.name: p.unit},
                    "delta_bic": fit.delta_bic, "explains": eff.explains,
                    "mechanism": eff.mechanism_for({p.name: value}), "alternatives": alternatives})
    return out


def _pooled(folds: list, which: str) -> dict:
    return {c: float(np.sqrt(np.mean([f[which][c] ** 2 for f in folds]))) for c in COORDS}


def heldout_warning(per_coordinate: dict, effects: bool, one_recording: bool) -> str | None:
    """A sentence when the effects make a held-out coordinate worse than the baseline (None
    otherwise): the effects are chosen on the training samples (BIC, or the inner folds), so a
    short log can take effects that fit its first part and miss the rest.  The numbers stay as
    measured; the sentence says how far to trust the effects."""
    before, after = per_coordinate["heldout_before"], per_coordinate["heldout_after"]
    worse = [c for c in COORDS if after[c] > before[c]]
    if not effects or not worse:
        return None
    where, next_step = (("the recording's last third, which the fit never saw", "repeats of the test would confirm "
                         "or refute them") if one_recording else
                        ("the repeats left out in turn", "they fit the repeats together but not each one from the others"))
    return ("the augmented model predicts " + " and ".join(f"{c} worse than the baseline ({before[c]:.4f} -> "
                                                            f"{after[c]:.4f} rad)" for c in worse)
            + f" on {where}: the effects are not confirmed ({next_step})")


# what `diagnose_coupled` puts in its folder (checked by the command before any work)
OUTPUT_FILES = ("diagnosis.json", "predictions.csv", "overlay.png", "report.md")


def read_inputs(paths, regression, friction_steer) -> tuple:
    """The coupled recordings (`Repeat`s), the shell laws of the regression table and the stand
    fit's steer friction, each read and checked once, before any work (a one-line error naming
    the file and what is wrong)."""
    from roboball.identify.friction.fitted import read_stand_friction
    from roboball.sim.schedule import ShellLaws

    for f, what, flag in ((regression, "shell regression table (pipeline rule shell_regression)", "--regression"),
                          (friction_steer, "steer friction fit (pipeline rule friction_fit, real steer stand)",
                           "--friction-steer")):
        if not Path(f).is_file():
            raise RoboballError(f"{f}: {what} not found; the steer_coupled baseline needs it: run `make figures` "
                                f"in this checkout first, or give the file with {flag}")
    return read_repeats(paths), ShellLaws.from_regression_csv(regression), read_stand_friction(friction_steer)


def diagnose_coupled(reps, laws, friction, out_dir, log=None, pressure_kpa: float | None = None) -> dict:
    """Diagnose the coupled recordings `reps` against the injected baseline of the shell `laws`
    and the steer `friction` (as `read_inputs` gives them) at their logged `pressure_kpa`, or at
    the pressure fitted on them when it was not logged; returns the diagnosis.json content."""
    folds = folds_of(reps)
    train = folds[0].train if len(reps) == 1 else {r.name: np.ones(len(r.t), bool) for r in reps}
    logged = pressure_kpa is not None
    pressure = (logged_pressure(reps, pressure_kpa) if logged
                else fit_pressure([truncated(r, train[r.name]) for r in reps], laws, friction))
    how = "logged" if logged else "fitted"
    base = baseline_spec(pressure.p_kpa, laws, friction)
    pred_base = predict_all(base, reps)
    chosen, table = screen(base, reps, train, log=log, preds0=pred_base)
    chosen, fit, dropped = fit_chosen(base, chosen, reps, train, preds0=pred_base)
    pred_aug = predict_all(effect_spec(base, fit.values), reps)
    noise = recorded_noise(reps, train)
    if len(reps) > 1:
        heldout = held_out(reps, laws, friction, pressure, log=log)
    else:   # one recording: its one fold is the fit above (trained on the first two thirds)
        test = folds[0].test
        heldout = [{"fold": folds[0].name, "pressure_kpa": pressure.p_kpa, "effects": [key(*c) for c in chosen],
                    "values": {key(*c): v for c, v in fit.values.items()}, "dropped": [key(*c) for c in dropped],
                    "rmse_heldout_before": rms_by_coord(pred_base, reps, test),
                    "rmse_heldout_after": rms_by_coord(pred_aug, reps, test)}]
    js = {
        "kind": "steer_coupled",
        "baseline": {"description": "stand-fitted Majd steer friction with its rotor inertia, injected shell "
                                    f"(eq. 6-9) at the {how} pressure, pendulum free, drive held, flat ground",
                     "fitted": ({} if logged else {"pressure_kpa": pressure.p_kpa,
                                                   "pressure_ci95_kpa": list(pressure.ci95_kpa)}),
                     **({"pressure_kpa": pressure.p_kpa} if logged else {}),
                     "friction_steer": friction},
        "verdict": verdict(fit, pred_base, reps, train, noise),
        "located": located(pred_base, reps, train),
        "located_augmented": located(pred_aug, reps, train),
        "noise_rad": noise,
        "missing_physics": _missing(fit, _alternatives(table, chosen)),
        "fit": {"rmse_before": fit.rmse_base_train, "rmse_after": fit.rmse_train,
                "rmse_heldout_before": float(np.sqrt(np.mean([v ** 2 for v in _pooled(heldout, "rmse_heldout_before").values()]))),
                "rmse_heldout_after": float(np.sqrt(np.mean([v ** 2 for v in _pooled(heldout, "rmse_heldout_after").values()]))),
                "units": "rad",
                "per_coordinate": {"before": rms_by_coord(pred_base, reps, train), "after": rms_by_coord(pred_aug, reps, train),
                                   "heldout_before": _pooled(heldout, "rmse_heldout_before"),
                                   "heldout_after": _pooled(heldout, "rmse_heldout_after")}},
        "heldout_folds": [fold_summary(f) for f in heldout],
        "dropped": [key(*c) for c in dropped],
        "notes": ["release states: the first sample, with rates from a quadratic fitted to the first 0.1 s of each log (estimated from the data, not fitted by simulation)"],
    }
    js["heldout_warning"] = heldout_warning(js["fit"]["per_coordinate"], bool(fit.values), len(reps) == 1)
    out = output_folder(out_dir, files=OUTPUT_FILES)
    write_json_atomic(out / "diagnosis.json", js)
    write_csv_atomic(_predictions(reps, pred_base, pred_aug), out / "predictions.csv")
    named = ", ".join(key(*c) for c in chosen) or "nothing added"
    _overlay(reps, pred_base, pred_aug, out / "overlay.png",
             f"steer_coupled diagnosis at the {how} {pressure.p_kpa:.1f} kPa: augmented = baseline + {named}, "
             + ("fitted on the first two thirds" if len(reps) == 1 else
                f"fitted on all {len(reps)} repeats (held-out figures: each repeat left out in turn)"),
             cut_s=float(reps[0].t[train[reps[0].name]][-1]) if len(reps) == 1 else None)
    write_text_atomic(out / "report.md", report_md(js))
    return js


def _predictions(reps, base, aug) -> pd.DataFrame:
    parts = []
    for r in reps:
        d = {"recording": r.name, "time_s": r.t}
        for c in COORDS:
            d[c] = r.coord(c)
            d[f"baseline_{c}"] = base[r.name][c]
            d[f"augmented_{c}"] = aug[r.name][c]
        parts.append(pd.DataFrame(d))
    return pd.concat(parts, ignore_index=True)


def _overlay(reps, base, aug, path, title: str, cut_s: float | None = None) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from roboball.atomic import savefig_atomic

    fig, axes = plt.subplots(2, len(reps), figsize=(4.5 * len(reps), 6), squeeze=False, sharex="col")
    for j, r in enumerate(reps):
        for i, c in enumerate(COORDS):
            ax = axes[i, j]
            ax.plot(r.t, r.coord(c), "k.", ms=2.5, label="recording")
            ax.plot(r.t, base[r.name][c], color="#1f77b4", label="baseline (injected shell)")
            ax.plot(r.t, aug[r.name][c], color="#2ca02c", lw=2, label="augmented")
            if cut_s is not None:     # one repeat: its last third is held out
                ax.axvline(cut_s, color="0.4", ls=":", lw=1, label="held out from here")
            ax.set_ylabel(c.replace("_rad", " (rad)").replace("_", " ") if j == 0 else "")
            ax.grid(alpha=0.3)
        axes[1, j].set_xlabel("time since let-go (s)")
        axes[0, j].set_title(r.name, fontsize=9)
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(textwrap.fill(title, width=int(55 * len(reps))), fontsize=10)
    fig.tight_layout()
    savefig_atomic(fig, path, format="png")
    plt.close(fig)


def report_md(js: dict) -> str:
    pc = js["fit"]["per_coordinate"]
    fitted = js["baseline"]["fitted"]
    pressure = (f"Logged pressure {js['baseline']['pressure_kpa']:.1f} kPa (not fitted)." if "pressure_kpa" not in fitted
                else f"Fitted pressure {fitted['pressure_kpa']:.1f} kPa "
                     f"(95 % {fitted['pressure_ci95_kpa'][0]:.1f}-{fitted['pressure_ci95_kpa'][1]:.1f}).")
    lines = [f"# Diagnosis: steer_coupled ({js['verdict']})", "", js["baseline"]["description"] + ".", pressure,
             "", "| coordinate | RMS before (rad) | after | held out before | held out after |", "|---|---|---|---|---|"]
    for c in COORDS:
        lines.append(f"| {c} | {pc['before'][c]:.4f} | {pc['after'][c]:.4f} | {pc['heldout_before'][c]:.4f} | "
                     f"{pc['heldout_after'][c]:.4f} |")
    lines += ["", f"Noise level of the recordings: {js['noise_rad']:.2g} rad. The verdict is `augmented` when the "
              "augmented model's fitted residual is within 3 noise levels or a tenth of the baseline's, "
              "`unexplained` when a larger residual remains."]
    if js["verdict"] == "unexplained":
        top = [w for w in js["located_augmented"] if w["share_of_residual"] >= 0.1][:3]
        lines += ["", "Where the residual remains (augmented model): " + "; ".join(
            f"{w['signal']} {w['start_s']:.2f}-{w['end_s']:.2f} s ({w['regime']}, {100 * w['share_of_residual']:.0f}%)"
            for w in top) + "."]
    lines += ["", "## Missing physics", ""]
    for m in js["missing_physics"] or [{"effect": "none"}]:
        if m["effect"] == "none":
            lines.append("Nothing: no effect lowers BIC.")
            continue
        (p, v), = m["parameters"].items()
        lo, hi = m["ci95"][p]
        lines.append(f"- `{m['effect']}` on the {m['dof']} coordinate: {p} = {v:.4g} {m['units'][p]} "
                     f"(95 % {lo:.4g} to {hi:.4g}); {m['explains']}; physically: {m['mechanism']}.")
    if js["dropped"]:
        lines.append("- screened but dropped, their 95 % interval includes zero: " + ", ".join(js["dropped"]))
    warning = js.get("heldout_warning")
    if warning:
        lines += ["", f"**Not confirmed held out:** {warning[0].upper() + warning[1:]}."]
    lines += ["", "## Held out", ""] + [f"- {h['fold']}: {'+'.join(h['effects']) or 'nothing'}; "
                                        + ", ".join(f"{c} {h['rmse_heldout_before'][c]:.4f} -> {h['rmse_heldout_after'][c]:.4f} rad"
                                                    for c in COORDS) for h in js["heldout_folds"]]
    lines += ["", "![recording, baseline and augmented model](overlay.png)", ""] + [f"Note: {n}" for n in js["notes"]]
    return "\n".join(lines) + "\n"
