"""diagnosis.json, the contract's file (../shared/specs/diagnosis.md): the experiment kind, the
baseline and what was fitted inside it, the verdict, where the baseline's residual sits, the
missing physics with 95% intervals, and the fit before and after."""
from __future__ import annotations

import math

from roboball.physics import effects as fx
from roboball.diagnose.select import Diagnosis
from roboball.diagnose.sensor import LAG_KEY


def _round(x, n=6):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return None
    return float(f"{x:.{n}g}")


def baseline_fitted(d: Diagnosis, values: dict | None = None) -> dict:
    """The baseline's own fitted parameters and release states, of the baseline fit (default) or
    of another fit of the same model (the augmented model refits them with its effects)."""
    v = d.baseline.values if values is None else values
    out = {b.name: _round(v[b.name]) for b in d.model.base_params}
    if LAG_KEY in v:        # the sensor's own lag (roboball.diagnose.sensor_fit), not physics
        out[LAG_KEY] = _round(v[LAG_KEY])
    unit = "rad" if d.prep.unit == "rad" else None
    for w in d.prep.windows:
        i = w.index + 1
        if f"q0@{w.index}" in v and unit:
            out[f"release_{i}_{unit}"] = _round(v[f"q0@{w.index}"])
        out[f"release_{i}_s"] = _round(w.t0 + v.get(f"ts@{w.index}", 0.0))
        for h in d.model.hidden_release:       # an unobserved coordinate's release state
            if f"{h.name}@{w.index}" in v:
                out[f"release_{i}_{h.name}_{h.unit.replace('/', '_')}"] = _round(v[f"{h.name}@{w.index}"])
    return out


# On the ramp the drive rate rises and levels off; the signatures read differently there.
RAMP_EXPLAINS = {
    "viscous_damping": "a torque proportional to the drive rate: the descent levels off towards a top speed",
    "quadratic_drag": "a torque growing with the square of the drive rate: the top speed is reached sooner",
    "rolling_resistance": "a constant torque opposing rolling: slower from the start, by the same torque at every speed",
    "stiction": "a torque opposing rolling that is largest at rest and fades over v_s: slow to get going, then freer",
}
# ... and a breakaway in the rolling is the shell's, not a bearing's.
RAMP_MECHANISM = {
    "stiction": "the soft shell's resistance to rolling that fades with speed: rolling off the flat its weight "
                "pressed into it at rest, and a hysteresis loss that falls once the skin is strained faster "
                "than it relaxes",
    "quadratic_drag": "a rolling loss growing with speed: air drag, or the contact's own damping (the leading "
                      "edge of the patch is compressed faster the faster the shell rolls)",
    "viscous_damping": "a rolling loss proportional to speed: the contact's own damping (the leading edge of the "
                       "patch is compressed faster the faster the shell rolls), or a drive-train loss",
}


def missing_physics(d: Diagnosis) -> list:
    """One entry per effect of the final model: parameters with 95% intervals, the BIC the model
    loses without it, its signature and the mechanism it stands for, and the equivalent
    explanations the data cannot tell from it (`alternatives`, roboball.diagnose.equivalents)."""
    out = []
    for e in d.chosen:
        eff = fx.LIBRARY[e]
        params = {p: _round(d.final.values[f"{e}.{p}"]) for p in eff.param_names}
        ci = {p: [_round(d.ci95[f"{e}.{p}"][0]), _round(d.ci95[f"{e}.{p}"][1])] for p in eff.param_names}
        entry = {"effect": e, "dof": d.model.dof, "parameters": params, "ci95": ci,
                 "delta_bic": _round(d.drop_bic.get(e, d.final.delta_bic), 5),
                 "explains": RAMP_EXPLAINS.get(e, eff.explains) if d.prep.kind == "ramp" else eff.explains,
                 "mechanism": _mechanism(e, params, d.prep.kind)}
        alts = d.alternatives.get(e)
        if alts:
            entry["alternatives"] = [_alternative(a, d.prep.kind) for a in alts]
        out.append(entry)
    return out


def _mechanism(effect: str, params: dict, kind: str) -> str:
    """The physical mechanism `effect` stands for at `params` in a recording of `kind`."""
    return (RAMP_MECHANISM.get(effect) if kind == "ramp" else None) or fx.LIBRARY[effect].mechanism_for(params)


def _alternative(a: dict, kind: str) -> dict:
    """An equivalent explanation as diagnosis.json gives it."""
    params = {p: _round(v) for p, v in a["parameters"].items()}
    return {"effect": a["effect"], "parameters": params,
            "ci95": {p: [_round(lo), _round(hi)] for p, (lo, hi) in a["ci95"].items()},
            "rmse_heldout": _round(a["rmse_heldout"]), "delta_bic": _round(a["delta_bic"], 5),
            "mechanism": _mechanism(a["effect"], params, kind)}


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
