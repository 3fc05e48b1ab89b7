"""Diagnosis: locate the mismatch between a recording and its baseline model, name the physics
the baseline leaves out, model it, and show the fit improve (issue 6; contract
../shared/specs/diagnosis.md).

    from roboball.diagnose import diagnose
    d, js = diagnose("raw_data/steer_stand/steer_stand_r1.csv", out_dir="results/diagnose/steer")

Modules: data (fit windows of the releases), models and roboball.reduced_ramp (fast batched
reduced models), fit (batched Levenberg-Marquardt by simulation error), decide (greedy forward
selection with held-out validation and BIC), locate (residual by time window and regime),
drake (the augmented model as a Drake force element), report (diagnosis.json, report.md,
figures), cli (`roboball diagnose`).  The effect library itself is roboball.physics.effects.
"""
from __future__ import annotations


def diagnose(recording, out_dir=None, kind: str | None = None, pressure_kpa: float | None = None,
             settings=None, drake: bool = True, log=None):
    """Diagnose one recording (a path, or a roboball.recording.Recording).

    Returns (Diagnosis, diagnosis.json content).  With `out_dir`, writes diagnosis.json,
    report.md, details.json and the figures there (the Drake simulations of the baseline and
    augmented model run only then, or when `drake` is forced with an out_dir)."""
    from ..recording import Recording
    from .data import prepare, read
    from .decide import diagnose_prepared

    rec = recording if isinstance(recording, Recording) else read(recording, kind=kind, pressure_kpa=pressure_kpa)
    d = diagnose_prepared(prepare(rec), settings=settings, log=log)
    if out_dir is None:
        from .locate import classify, locate
        from .report import diagnosis_json
        labels = classify(d.prep)
        js = diagnosis_json(d, locate(d.prep, d.baseline.full.pred, labels), locate(d.prep, d.final.full.pred, labels))
        return d, js
    from .report import write
    return d, write(d, out_dir, drake=drake)


__all__ = ["diagnose"]
