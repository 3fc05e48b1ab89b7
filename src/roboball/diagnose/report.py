"""Write a diagnosis: DIR/diagnosis.json (the contract, ../shared/specs/diagnosis.md), a readable
DIR/report.md with figures, and DIR/details.json (everything else: all parameters, every
candidate of every round, regime table, timings).

The figures overlay the recording, the baseline and the augmented model, both simulated in
DRAKE from the fitted release states, with the residual before and after; the held-out
(cross-validated) prediction of the augmented model is drawn too, so the improvement is shown
on data the fit did not see.
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from roboball.atomic import output_folder, savefig_atomic, write_csv_atomic, write_json_atomic, write_text_atomic
from roboball.physics import effects as fx
from roboball.diagnose.decide import Diagnosis
from roboball.diagnose.drake import rmse as drake_rmse
from roboball.diagnose.drake import simulate_windows
from roboball.diagnose.locate import classify, locate


def _round(x, n=6):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return None
    return float(f"{x:.{n}g}")


def _clean(obj):
    """JSON-safe copy: NaN/inf -> None, numpy -> Python, tuples -> lists."""
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return [_clean(v) for v in obj.tolist()]
    if isinstance(obj, (np.floating, float)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


def baseline_fitted(d: Diagnosis, values: dict | None = None) -> dict:
    """The baseline's own fitted parameters and release states, of the baseline fit (default) or
    of another fit of the same model (the augmented model refits them with its effects)."""
    v = d.baseline.values if values is None else values
    out = {b.name: _round(v[b.name]) for b in d.model.base_params}
    unit = "rad" if d.prep.unit == "rad" else None
    for w in d.prep.windows:
        i = w.index + 1
        if f"q0@{w.index}" in v and unit:
            out[f"release_{i}_{unit}"] = _round(v[f"q0@{w.index}"])
        out[f"release_{i}_s"] = _round(w.t0 + v.get(f"ts@{w.index}", 0.0))
    return out


# On the ramp the drive rate rises and levels off; the signatures read differently there.
RAMP_EXPLAINS = {
    "viscous_damping": "a torque proportional to the drive rate: the descent levels off towards a top speed",
    "quadratic_drag": "a torque growing with the square of the drive rate: the top speed is reached sooner",
    "rolling_resistance": "a constant torque opposing rolling: slower from the start, by the same torque at every speed",
}


def missing_physics(d: Diagnosis) -> list:
    out = []
    dbic = {}
    for step in d.steps:
        for info in step:
            if info.get("kept"):
                dbic[info["effect"]] = info["delta_bic"]
    for e in d.chosen:
        eff = fx.LIBRARY[e]
        params = {p: _round(d.final.values[f"{e}.{p}"]) for p in eff.param_names}
        ci = {p: [_round(d.ci95[f"{e}.{p}"][0]), _round(d.ci95[f"{e}.{p}"][1])] for p in eff.param_names}
        out.append({"effect": e, "dof": d.model.dof, "parameters": params, "ci95": ci,
                    "delta_bic": _round(dbic.get(e, d.final.delta_bic), 5),
                    "explains": RAMP_EXPLAINS.get(e, eff.explains) if d.prep.kind == "ramp" else eff.explains})
    return out


def diagnosis_json(d: Diagnosis, located_base, drake_before=None, drake_after=None) -> dict:
    # The contract's `located` is where the BASELINE's residual concentrates (its shares sum to at
    # most 1); where an unexplained residual remains after the effects is in report.md and in
    # details.json ("located_augmented").
    located = [dict(w, share_of_residual=_round(w["share_of_residual"], 4)) for w in located_base.windows]
    fit = {"rmse_before": _round(d.baseline.rmse), "rmse_after": _round(d.final.rmse),
           "rmse_heldout_before": _round(d.baseline.cv_rmse), "rmse_heldout_after": _round(d.final.cv_rmse),
           "units": d.prep.unit}
    if drake_before is not None:
        fit["drake_rmse_before"] = _round(drake_before)
        fit["drake_rmse_after"] = _round(drake_after)
    baseline = {"description": d.model.description, "fitted": baseline_fitted(d)}
    if d.chosen:        # the augmented model refits them with its effects: needed to reproduce it
        baseline["refitted_with_effects"] = baseline_fitted(d, d.final.values)
    friction = getattr(d.model, "friction_params", None)     # the ramp baseline's fitted friction, if any
    if friction:
        baseline["friction"] = friction
    return {
        "kind": d.prep.kind,
        "baseline": baseline,
        "verdict": d.verdict,
        "located": located,
        "missing_physics": missing_physics(d),
        "fit": fit,
    }


# ---- figures ------------------------------------------------------------------------------
def _figures(d: Diagnosis, out: Path, drake_base, drake_aug, located_base, located_final) -> list:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    files = []
    prep = d.prep
    wins = prep.windows
    n = len(wins)
    # layout="none", then tight_layout: these figures look the same whatever layout an importer
    # of matplotlib made the default (roboball.figures.style makes it constrained)
    fig, axes = plt.subplots(2, n, figsize=(5.2 * n, 6.4), squeeze=False, sharex="col", layout="none",
                             gridspec_kw={"height_ratios": [2, 1.3]})
    for j, w in enumerate(wins):
        ax, axr = axes[0, j], axes[1, j]
        t = w.t - w.t0
        ax.plot(t, w.y, ".", ms=2.2, color="0.35", label="recording")
        ax.plot(t, drake_base[w.index], color="tab:red", lw=1.0, label="baseline (Drake)")
        if d.chosen:
            ax.plot(t, drake_aug[w.index], color="tab:blue", lw=1.0, label="augmented (Drake)")
        if w.start == "turning point":
            ax.set_title(f"release {w.index + 1} (let go {w.release.t_release_s:.2f} s), "
                         f"fitted from its first turning point, {w.t0:.2f} s", fontsize=9)
        else:
            ax.set_title(f"release {w.index + 1} at {w.t0:.2f} s")
        axr.plot(t, drake_base[w.index] - w.y, color="tab:red", lw=0.8, label="baseline, fitted")
        if d.chosen:
            axr.plot(t, drake_aug[w.index] - w.y, color="tab:blue", lw=0.8, label="augmented, fitted")
        cvb = d.baseline.cv_pred.get(w.index)
        if cvb is not None and np.any(np.isfinite(cvb)):
            axr.plot(t, cvb - w.y, color="tab:purple", lw=0.7, ls="--", label="baseline, held out")
        cv = d.final.cv_pred.get(w.index)
        if d.chosen and cv is not None and np.any(np.isfinite(cv)):
            axr.plot(t, cv - w.y, color="tab:green", lw=0.8, ls="--", label="augmented, held out")
        axr.axhline(0, color="k", lw=0.5)
        axr.set_xlabel("time since the window's start (s)")
        if j == 0:
            name = prep.signal.rsplit("_rad", 1)[0].replace("_", " ")     # steer_angle_rad -> steer angle
            ax.set_ylabel(f"{name} ({prep.unit})")
            axr.set_ylabel(f"model - recording ({prep.unit})")
            ax.legend(fontsize=7, loc="best")
            axr.legend(fontsize=7, loc="best")
    fig.suptitle(f"{prep.label}: {d.verdict}" + (f" (+ {', '.join(d.chosen)})" if d.chosen else ""), fontsize=10)
    fig.tight_layout()
    f = out / "overlay.png"
    savefig_atomic(fig, f, dpi=110)
    plt.close(fig)
    files.append(f.name)

    fig, ax = plt.subplots(figsize=(8, 3.6), layout="none")
    regs = [r["regime"] for r in located_base.regimes]
    x = np.arange(len(regs))
    ax.bar(x - 0.27, [r["share_of_samples"] for r in located_base.regimes], 0.27, color="0.7", label="share of samples")
    ax.bar(x, [r["share_of_residual"] for r in located_base.regimes], 0.27, color="tab:red",
           label="share of squared residual, baseline")
    if d.chosen:
        fin = {r["regime"]: r["share_of_residual"] for r in located_final.regimes}
        ax.bar(x + 0.27, [fin.get(r, 0.0) for r in regs], 0.27, color="tab:blue",
               label="share of squared residual, augmented")
    ax.set_xticks(x)
    ax.set_xticklabels(regs, rotation=30, ha="right", fontsize=8)
    ax.set_ylabel("share (-)")
    ax.legend(fontsize=7)
    ax.set_title("residual by regime (regimes overlap)", fontsize=10)
    fig.tight_layout()
    f = out / "regimes.png"
    savefig_atomic(fig, f, dpi=110)
    plt.close(fig)
    files.append(f.name)

    fig, ax = plt.subplots(figsize=(10, 3.2), layout="none")
    for w in wins:
        ax.plot(w.t, (d.baseline.full.pred[w.index] - w.y) ** 2, color="tab:red", lw=0.7,
                label="baseline" if w.index == 0 else None)
        if d.chosen:
            ax.plot(w.t, (d.final.full.pred[w.index] - w.y) ** 2, color="tab:blue", lw=0.7,
                    label="augmented" if w.index == 0 else None)
    for loc in located_base.windows:
        ax.axvspan(loc["start_s"], loc["end_s"], color="orange", alpha=0.25)
        ax.text(loc["start_s"], ax.get_ylim()[1] * 0.9, f"{loc['regime']} {loc['share_of_residual']:.0%}", fontsize=7)
    ax.set_xlabel("recording time (s)")
    ax.set_ylabel(f"squared residual ({prep.unit}^2)")
    from matplotlib.patches import Patch
    handles, _ = ax.get_legend_handles_labels()
    ax.legend(handles=handles + [Patch(color="orange", alpha=0.25, label="located windows (baseline)")],
              fontsize=7, loc="upper right")
    ax.set_title("where the baseline's residual sits", fontsize=9)
    fig.tight_layout()
    f = out / "windows.png"
    savefig_atomic(fig, f, dpi=110)
    plt.close(fig)
    files.append(f.name)
    return files


def predictions_table(d: Diagnosis, drake_base: dict, drake_aug: dict):
    """Every fitted sample with the recording, the baseline and augmented Drake predictions and
    the augmented model's held-out (cross-validated) reduced-model prediction; the pipeline
    scores ramp runs (PME, eq. 12) from this table."""
    import pandas as pd
    unit = "rad_s" if d.prep.unit == "rad/s" else "rad"
    frames = []
    for w in d.prep.windows:
        cv = d.final.cv_pred.get(w.index, np.full(w.n, np.nan))
        frames.append(pd.DataFrame({
            "time_s": w.t, "release": w.index + 1, "time_since_release_s": w.t - w.t0,
            f"measured_{unit}": w.y, f"baseline_drake_{unit}": drake_base[w.index],
            f"augmented_drake_{unit}": drake_aug[w.index], f"augmented_heldout_{unit}": cv}))
    return pd.concat(frames, ignore_index=True)


def _md_table(rows, header) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


def _param_cells(effect: str, name: str, value, ci) -> tuple:
    """The "parameter" and "95% interval" cells of an effect's parameter: "c = 3.83 N m s/rad",
    "[3.82, 3.841]"."""
    unit = fx.LIBRARY[effect].units()[name]
    return f"{name} = {_fmt(value)} {unit}", f"[{_fmt(ci[0])}, {_fmt(ci[1])}]"


def _assignments(values: dict) -> str:
    """"viscous_c = 0.689, release_1_rad = 0.889" for the report."""
    return ", ".join(f"{k} = {v}" for k, v in values.items())


def _fmt(x, n=4):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return f"{x:.{n}g}"


def _heldout_note(d: Diagnosis, n_windows: int) -> str:
    """How the report's held-out errors were made."""
    if n_windows > 1:
        how = ("leave one release out (the model fitted on the other releases, then only the held-out release's "
               "state fitted)" if d.model.release_params else
               "leave one release out (the model fitted on the other releases predicts the held-out one from its "
               "detected release)")
    else:
        how = f"{d.settings.n_blocks} contiguous time blocks, each predicted by a fit to the others"
    if d.model.base_params:
        return f"Held out: {how}."
    if d.model.release_params:
        return (f"Held out: {how}. The baseline fits no parameter of its own besides the release states, so its "
                "held-out error is (nearly) its fitted error.")
    return (f"Held out: {how}. The baseline fits no parameter at all (each release starts at rest at its detected "
            "instant), so its held-out error is its fitted error.")


def _window_note(prep) -> str:
    """How the report's windows start, per kind of experiment."""
    if prep.kind == "ramp":
        return ("A ramp window starts at the release the release finder detects and ends where the robot "
                "leaves the ramp; the model starts there at rest (release_i_s is that detected instant, not "
                f"fitted) and its drive rate is averaged over the same +-{prep.windows[0].smooth_s:g} s windows "
                "as the recording's.")
    return ("A window starts at the first turning point after the hand lets go when enough swings follow "
            "(the let-go itself, where the hand may still touch the body, is not simulated); the model "
            "starts at rest there, and release_i_s / release_i_rad are its starting instant and angle, fitted "
            "near the turning point's.")


def report_md(d: Diagnosis, js: dict, located_base, located_final, figures, drake_stats) -> str:
    prep = d.prep
    u = prep.unit
    lines = [f"# Diagnosis of `{prep.label}`", "",
             f"**kind** {prep.kind} - **signal** {prep.signal} - **verdict: {d.verdict}**"
             + (f" - missing physics: {', '.join(d.chosen)}" if d.chosen else ""), "",
             f"Baseline: {d.model.description}.", "",
             f"Fitted inside the baseline: {_assignments(js['baseline']['fitted'])}", "",
             *([f"Refitted with the effects (the augmented model): "
                f"{_assignments(js['baseline']['refitted_with_effects'])}", ""]
               if "refitted_with_effects" in js["baseline"] else []),
             f"Noise level of the recording: {prep.noise:.3g} {u}"
             + (f"; of the averaged trend the fit compares (the noise variances of the keep rule and the "
                f"tests of a white or explained residual): {prep.fit_noise:.3g} {u}"
                if prep.fit_noise != prep.noise else "")
             + f"; {len(prep.windows)} release(s) "
             f"({', '.join(f'{w.t0:.2f}-{w.t[-1]:.2f} s (from the {w.start}; {w.end_reason})' for w in prep.windows)}).",
             "", _window_note(prep), ""]
    lines += ["## Where the baseline misses", "",
              _md_table([(f"{w['start_s']:.2f}-{w['end_s']:.2f} s", w["regime"], f"{w['share_of_residual']:.0%}")
                         for w in located_base.windows], ["time window", "regime", "share of squared residual"]), "",
              _md_table([(r["regime"], f"{r['share_of_residual']:.0%}", f"{r['share_of_samples']:.0%}",
                          f"{r['concentration']:.2f}") for r in located_base.regimes],
                        ["regime", "share of squared residual", "share of samples", "concentration"]), "",
              "Regimes overlap (a sample can be fast and near a reversal), so their shares do not add up to "
              "100%; concentration is the share of the residual over the share of the samples (above 1: the "
              "residual gathers there).", "",
              "![residual by regime](regimes.png)", "", "![residual in time](windows.png)", ""]
    lines += ["## Missing physics", ""]
    if js["missing_physics"]:
        rows = []
        for m in js["missing_physics"]:
            for p, val in m["parameters"].items():
                rows.append((m["effect"], m["dof"], *_param_cells(m["effect"], p, val, m["ci95"][p]),
                             _fmt(m["delta_bic"], 5), m["explains"]))
        lines.append(_md_table(rows, ["effect", "dof", "parameter", "95% interval", "delta BIC", "signature"]))
    else:
        lines.append("None: no effect of the vocabulary passed the keep rule (see Selection).")
    if d.immaterial:
        rows = []
        for i in d.immaterial:
            for key, val in i["params"].items():
                rows.append((i["effect"], d.model.dof, *_param_cells(i["effect"], key.split(".", 1)[1], val,
                                                                     i["ci95"][key]),
                             _fmt(i["delta_bic"], 5), _fmt(i["heldout_gain"], 3)))
        lines += ["", "### Supported by the data, below materiality", "",
                  "These candidates lower the BIC and the held-out error and their intervals exclude zero, "
                  f"but they lower the held-out mean square by less than {d.settings.material_noise:g} noise "
                  "variances: the prediction they change is within about two noise levels, the size of the "
                  "model-form differences (integrator, contact compliance) a correction can absorb. They are "
                  "not added to the model; they are listed so that you can judge them.", "",
                  _md_table(rows, ["effect", "dof", "parameter", "95% interval", "delta BIC",
                                   "held-out gain (noise variances)"])]
    lines += ["", "## Fit", "",
              _md_table([("reduced model, fitted", _fmt(d.baseline.rmse), _fmt(d.final.rmse)),
                         ("reduced model, held out", _fmt(d.baseline.cv_rmse), _fmt(d.final.cv_rmse)),
                         ("Drake, fitted parameters", _fmt(drake_stats[0]), _fmt(drake_stats[1]))],
                        ["RMS residual (" + u + ")", "baseline", "augmented"]), "",
              _heldout_note(d, len(prep.windows)),
              "", "![recording, baseline and augmented model in Drake](overlay.png)", ""]
    lines += ["## Selection", "", "Each round adds every remaining candidate in turn and refits by simulation "
              f"error; the best {d.settings.top_k} by fit are cross-validated. A candidate qualifies when it "
              "lowers the BIC by "
              f"more than {d.settings.bic_min:g}, lowers the held-out RMS by more than {d.settings.cv_gain:.0%}, "
              f"lowers the held-out mean square by at least {d.settings.material_noise:g} noise variances "
              "(materiality), and the 95% intervals of its magnitude (and of any parameter at whose zero it "
              "would be a simpler effect) exclude zero; the qualifying candidate with the lowest BIC is kept.", ""]
    for k, step in enumerate(d.steps, start=1):
        rows = [(i["effect"], _fmt(i["rmse"]), _fmt(i["cv_rmse"]), _fmt(i["delta_bic"], 5),
                 "kept" if i.get("kept") else ("qualifies, higher BIC" if i.get("qualifies") else i.get("reason", "")))
                for i in step]
        lines += [f"Round {k}:", "", _md_table(rows, ["candidate", "RMS", "held-out RMS", "delta BIC", "decision"]), ""]
    if d.verdict == "unexplained":
        lines += ["## Unexplained residual", "", "A structured residual remains that no effect of the vocabulary "
                  "explains; it sits here:", "",
                  _md_table([(f"{w['start_s']:.2f}-{w['end_s']:.2f} s", w["regime"], f"{w['share_of_residual']:.0%}")
                             for w in (located_final.windows if d.chosen else located_base.windows)],
                            ["time window", "regime", "share of squared residual"]), ""]
    if prep.notes:
        lines += ["## Notes", ""] + [f"- {n}" for n in prep.notes] + [""]
    lines += [f"Diagnosis took {d.timings.get('total_s', 0):.1f} s ({d.timings.get('simulations', 0)} reduced-model "
              f"simulations in {d.timings.get('batched_calls', 0)} batched calls) plus "
              f"{d.timings.get('drake_s', 0):.1f} s of Drake simulation.", ""]
    return "\n".join(lines)


def write(d: Diagnosis, out_dir, drake: bool = True) -> dict:
    """Write diagnosis.json, details.json, report.md and the figures into `out_dir`."""
    out = output_folder(out_dir)
    labels = classify(d.prep)
    loc_base = locate(d.prep, d.baseline.full.pred, labels)
    loc_final = locate(d.prep, d.final.full.pred, labels)
    t0 = time.perf_counter()
    if drake:
        drake_base = simulate_windows(d.prep, d.model, d.baseline.values, ())
        drake_aug = simulate_windows(d.prep, d.model, d.final.values, d.chosen) if d.chosen else drake_base
        stats = (drake_rmse(d.prep, drake_base), drake_rmse(d.prep, drake_aug))
    else:
        drake_base, drake_aug = d.baseline.full.pred, d.final.full.pred
        stats = (None, None)
    d.timings["drake_s"] = time.perf_counter() - t0
    js = diagnosis_json(d, loc_base, *stats)
    figures = _figures(d, out, drake_base, drake_aug, loc_base, loc_final)
    details = {
        "recording": str(d.prep.label),
        "signal": d.prep.signal,
        "noise": d.prep.noise,
        "fit_noise": d.prep.fit_noise,   # of the signal the fit compares (a ramp's averaged trend)
        "windows": [dict(index=w.index + 1, t_release_s=w.t0, t_end_s=float(w.t[-1]), samples=w.n,
                         end_reason=w.end_reason, start=w.start, t_let_go_s=w.release.t_release_s)
                    for w in d.prep.windows],
        "baseline_values": d.baseline.values,
        "final_values": d.final.values,
        "ci95": {k: list(v) for k, v in d.ci95.items()},
        "rounds": d.steps,
        "immaterial": d.immaterial,      # supported by the data, below materiality: not added
        "regimes_baseline": loc_base.regimes,
        "regimes_augmented": loc_final.regimes,
        "located_augmented": loc_final.windows,
        "lag1_baseline": d.baseline.rho1,
        "lag1_augmented": d.final.rho1,
        "settings": vars(d.settings),
        "timings": d.timings,
        "notes": d.prep.notes,
    }
    write_json_atomic(out / "details.json", _clean(details))
    write_csv_atomic(predictions_table(d, drake_base, drake_aug), out / "predictions.csv")
    write_text_atomic(out / "report.md", report_md(d, js, loc_base, loc_final, figures, stats))
    write_json_atomic(out / "diagnosis.json", _clean(js))
    return js
