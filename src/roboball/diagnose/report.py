"""Write a diagnosis: DIR/diagnosis.json (the contract, ../shared/specs/diagnosis.md;
roboball.diagnose.contract), a readable DIR/report.md (roboball.diagnose.markdown) with its
figures (roboball.diagnose.figures), DIR/predictions.csv (every fitted sample with the Drake
predictions) and DIR/details.json (everything else: all parameters, every candidate of every
round, regime table, timings).

The baseline and the augmented model are simulated in DRAKE from the fitted release states for
the figures, the predictions and the contract's Drake RMS (or, without Drake, the reduced
model's fitted predictions stand in).
"""
from __future__ import annotations

import math
import time
from functools import partial

import numpy as np

from roboball.atomic import output_folder, write_csv_atomic, write_json_atomic, write_text_atomic
from roboball.diagnose.beside import Beside, second_thread
from roboball.diagnose.contract import diagnosis_json
from roboball.diagnose.drake import rmse as drake_rmse
from roboball.diagnose.drake import simulate_windows
from roboball.diagnose.figures import write_figures
from roboball.diagnose.locate import classify, locate
from roboball.diagnose.markdown import report_md
from roboball.diagnose.select import Diagnosis


# what `write` puts in its folder (checked by the command before any work)
OUTPUT_FILES = ("diagnosis.json", "details.json", "predictions.csv", "report.md",
                "overlay.png", "regimes.png", "windows.png")


def write(d: Diagnosis, out_dir, drake: bool = True) -> dict:
    """Write diagnosis.json, details.json, report.md and the figures into `out_dir`."""
    out = output_folder(out_dir, files=OUTPUT_FILES)
    labels = classify(d.prep)
    loc_base = locate(d.prep, d.baseline.full.pred, labels)
    loc_final = locate(d.prep, d.final.full.pred, labels)
    t0 = time.perf_counter()
    drake_base, drake_aug, stats = _drake_predictions(d, drake)
    d.timings["drake_s"] = time.perf_counter() - t0
    js = diagnosis_json(d, loc_base, *stats)
    figures = write_figures(d, out, drake_base, drake_aug, loc_base, loc_final,
                            engine="Drake" if drake else "reduced model")
    write_json_atomic(out / "details.json", json_safe(details(d, loc_base, loc_final)))
    write_csv_atomic(predictions_table(d, drake_base, drake_aug), out / "predictions.csv")
    write_text_atomic(out / "report.md", report_md(d, js, loc_base, loc_final, figures, stats))
    write_json_atomic(out / "diagnosis.json", json_safe(js))
    return js


def _drake_predictions(d: Diagnosis, drake: bool):
    """The baseline's and the augmented model's predictions ({window: y}) and their RMS in Drake;
    without `drake`, the reduced model's fitted predictions and no RMS.  Given a second thread
    (roboball.diagnose.beside) the two models run side by side: Drake
    steps without the GIL, each run has its own diagrams and context, and the notes are merged
    in the sequential order, so the output is the same either way."""
    if drake:
        notes_aug = []                   # the run beside notes apart from the recording's own
        run_aug = partial(simulate_windows, d.prep, d.model, d.final.values, d.chosen, notes=notes_aug)
        aug = Beside(run_aug) if d.chosen and second_thread() else None
        drake_base = simulate_windows(d.prep, d.model, d.baseline.values, ())   # here, where Ctrl-C lands
        drake_aug = aug.result() if aug else (run_aug() if d.chosen else drake_base)
        for note in notes_aug:
            if note not in d.prep.notes:
                d.prep.notes.append(note)
        stats = (drake_rmse(d.prep, drake_base), drake_rmse(d.prep, drake_aug))
    else:
        drake_base, drake_aug = d.baseline.full.pred, d.final.full.pred
        stats = (None, None)
    return drake_base, drake_aug, stats


def details(d: Diagnosis, loc_base, loc_final) -> dict:
    """details.json's content (before `json_safe`)."""
    return {
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
        "profiles": d.profiles,          # a rough magnitude's profile likelihood: its interval above
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
        "steer_settings": d.steer_settings,
        "steer_decision": d.steer_decision,
        "model_setup": model_setup(d.model),
        # each equivalent explanation's whole model (F - e + u), for `roboball design`
        "alternatives": {e: [{"effect": a["effect"], "values": a.get("values", {}), "ci95": a.get("ci95_all", {})}
                             for a in alts] for e, alts in d.alternatives.items()},
    }


def model_setup(model) -> dict:
    """What rebuilds the diagnosis's reduced model beside its kind (for `roboball design`): a
    ramp's angle and the baseline friction it was given (Table I where none)."""
    if getattr(model, "kind", "") != "ramp":
        return {}
    return {"ramp_angle_deg": math.degrees(model.alpha), "friction": model.friction_params}


def predictions_table(d: Diagnosis, drake_base: dict, drake_aug: dict):
    """Every fitted sample with the recording, the baseline and augmented Drake predictions and
    the augmented model's held-out (cross-validated) reduced-model prediction; the pipeline
    scores ramp runs (PME, eq. 12) from this table."""
    import pandas as pd
    unit = d.prep.unit_key
    frames = []
    for w in d.prep.windows:
        cv = d.final.cv_pred.get(w.index, np.full(w.n, np.nan))
        frames.append(pd.DataFrame({
            "time_s": w.t, "release": w.index + 1, "time_since_release_s": w.t - w.t0,
            f"measured_{unit}": w.y, f"baseline_drake_{unit}": drake_base[w.index],
            f"augmented_drake_{unit}": drake_aug[w.index], f"augmented_heldout_{unit}": cv}))
    return pd.concat(frames, ignore_index=True)


def json_safe(obj):
    """JSON-safe copy: NaN/inf -> None, numpy -> Python, tuples -> lists."""
    if isinstance(obj, dict):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return [json_safe(v) for v in obj.tolist()]
    if isinstance(obj, (np.floating, float)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj
