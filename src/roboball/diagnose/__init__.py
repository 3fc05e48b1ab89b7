"""Diagnosis: locate the mismatch between a recording and its baseline model, name the physics
the baseline leaves out, model it, and show the fit improve (issue 6; contract
../shared/specs/diagnosis.md).

    from roboball.diagnose import diagnose
    d, js = diagnose("raw_data/steer_stand/steer_stand_r1.csv", out_dir="results/diagnose/steer")

Modules, in the order a diagnosis runs: data (fit windows of the releases; handholds, its fallback
release finder for records with no decaying oscillation; the fast batched
reduced models are in roboball.reduced), fit (batched Levenberg-Marquardt by simulation error),
scored (the selection's settings and scored models), crossval (held-out errors), keep (the keep
rule: BIC, held-out error, materiality, 95% intervals), restarts (a joint's breakaway refitted
from several starts before it is judged), profile (its profile likelihood: the breakaway's
significance and 95% interval), select (beam search over small sets of
effects, each effect judged against the set without it, and the verdict), equivalents (swaps
and the equivalent explanations of the chosen effects), locate (residual by time window and
regime), drake (the augmented model as a Drake force element and joint rotor inertia), report
(writes the outputs: contract for diagnosis.json, markdown for report.md, figures for the PNGs);
steer (a shell release's steer setting: locked, free or unknown); beside (two independent calls
at once, given a second thread).  The command is
roboball.cli.diagnose; the effect library itself is roboball.physics.effects.
"""
from __future__ import annotations


def diagnose(recording, out_dir=None, kind: str | None = None, pressure_kpa: float | None = None,
             settings=None, drake: bool = True, log=None, friction: dict | None = None,
             steer_joint: str | None = None):
    """Diagnose one recording (a path, or a roboball.ingest.recording.Recording), or several recordings
    of one experiment together (a list: same kind, pressure and ramp angle; every release of
    each is a release of the pooled fit, and held-out validation leaves one release out:
    roboball.diagnose.data.pool).

    `friction` replaces the ramp baseline's (or a free steer joint's) Table I joint friction ({"steer": {...}, "drive":
    {...}} Majd parameters, e.g. from roboball.identify.friction.fitted.read_diagnosis_friction): the pipeline diagnoses the
    paper's point model with the friction fitted on the stand logs.  A free steer joint also takes the steer fit's
    reflected rotor inertia `delta_i` (kg m^2); the ramp baseline reads the Majd parameters only.

    Returns (Diagnosis, diagnosis.json content).  With `out_dir`, writes diagnosis.json,
    report.md, details.json and the figures there (the Drake simulations of the baseline and
    augmented model run only then, or when `drake` is forced with an out_dir).

    `steer_joint` ("locked", "free" or "unknown"; default the sidecar's `steer_joint`, else
    "locked", the contract's shell_rock baseline): whether the pendulum was clamped during a shell
    release.  Free, the baseline is roboball.reduced.shell_steer's two-coordinate model, with the
    steer joint's unobserved release state fitted inside it.  Unknown, the recording is diagnosed
    both ways and the setting whose diagnosis predicts the held-out data better is reported
    (roboball.diagnose.steer)."""
    from roboball.ingest.recording import Recording
    from roboball.diagnose.data import pool, prepare, read
    from roboball.diagnose.select import diagnose_prepared
    from roboball.diagnose.steer import either_steer_setting, steer_setting
    from roboball.reduced.models import model_for

    items = list(recording) if isinstance(recording, (list, tuple)) else [recording]
    if not items:
        raise ValueError("no recording to diagnose")
    recs = [r if isinstance(r, Recording) else read(r, kind=kind, pressure_kpa=pressure_kpa) for r in items]
    prep = pool([prepare(r) for r in recs])
    steer = steer_setting(prep, steer_joint)      # checked before anything is said
    if log:
        log(f"data: {len(prep.windows)} release window(s) of {prep.kind}")
    model = None
    if steer == "unknown":
        d = either_steer_setting(recs, prep, settings, log, (friction or {}).get("steer"))
    else:
        if steer == "free":
            from roboball.reduced.shell_steer import ShellSteerModel
            model = ShellSteerModel(friction=(friction or {}).get("steer"))
            if log:
                log(f"data: the pendulum free on its steer joint ({model.friction_source} friction)")
        elif friction:
            if prep.kind != "ramp":
                raise ValueError(f"baseline friction can replace Table I only in the ramp baseline, not in {prep.kind}")
            model = model_for("ramp", ramp_angle_deg=prep.recording.ramp_angle_deg, friction=friction)
        d = diagnose_prepared(prep, settings=settings, log=log, model=model)
    if out_dir is None:
        from roboball.diagnose.locate import classify, locate
        from roboball.diagnose.contract import diagnosis_json
        labels = classify(d.prep)
        js = diagnosis_json(d, locate(d.prep, d.baseline.full.pred, labels))
        return d, js
    from roboball.diagnose.report import write
    return d, write(d, out_dir, drake=drake)

