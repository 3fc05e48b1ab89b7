"""report.md, the readable report of a diagnosis: what was fitted, where the baseline misses,
the missing physics with 95% intervals (and the candidates below materiality), the fit before
and after, every round of the selection, and where an unexplained residual remains."""
from __future__ import annotations

import math

from roboball.physics import effects as fx
from roboball.diagnose.select import Diagnosis


def report_md(d: Diagnosis, js: dict, located_base, located_final, figures, drake_stats) -> str:
    """The report's Markdown (`js`: diagnosis.json's content; `drake_stats`: the Drake RMS of the
    baseline and the augmented model, or Nones)."""
    lines = (_header(d, js) + _located(located_base) + _missing(js, d.profiles) + _equivalents(d, js) + _immaterial(d)
             + _fit(d, drake_stats) + _selection(d) + _unexplained(d, located_base, located_final) + _footer(d))
    return "\n".join(lines)


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
        if d.model.release_params:
            how += (" (the first block, which holds the release, with the model fitted on the later ones and then "
                    "only the release's state fitted on it, as a held-out release's)")
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


# ---- the report's sections, each a list of lines --------------------------------------------
def _header(d: Diagnosis, js: dict) -> list:
    """Title, verdict, baseline and what was fitted in it, noise level and release windows."""
    prep = d.prep
    u = prep.unit
    return [f"# Diagnosis of `{prep.label}`", "",
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


def _located(located_base) -> list:
    """Where the baseline misses: its located time windows and its regime table."""
    return ["## Where the baseline misses", "",
            _md_table([(f"{w['start_s']:.2f}-{w['end_s']:.2f} s", w["regime"], f"{w['share_of_residual']:.0%}")
                       for w in located_base.windows], ["time window", "regime", "share of squared residual"]), "",
            _md_table([(r["regime"], f"{r['share_of_residual']:.0%}", f"{r['share_of_samples']:.0%}",
                        f"{r['concentration']:.2f}") for r in located_base.regimes],
                      ["regime", "share of squared residual", "share of samples", "concentration"]), "",
            "Regimes overlap (a sample can be fast and near a reversal), so their shares do not add up to "
            "100%; concentration is the share of the residual over the share of the samples (above 1: the "
            "residual gathers there).", "",
            "![residual by regime](regimes.png)", "", "![residual in time](windows.png)", ""]


def _missing(js: dict, profiles: dict | None = None) -> list:
    """The effects added, one row per parameter, with intervals, delta BIC, signature and the
    physical mechanism each stands for (given once per effect, on its first parameter's row), and
    what a rough magnitude's profile says (`profiles`: Diagnosis.profiles)."""
    lines = ["## Missing physics", ""]
    if js["missing_physics"]:
        rows = []
        for m in js["missing_physics"]:
            for i, (p, val) in enumerate(m["parameters"].items()):
                effect = (m["effect"], m["dof"]) if i == 0 else ("", "")
                about = (_fmt(m["delta_bic"], 5), m["explains"], m["mechanism"]) if i == 0 else ("", "", "")
                rows.append((*effect, *_param_cells(m["effect"], p, val, m["ci95"][p]), *about))
        lines += [_md_table(rows, ["effect", "dof", "parameter", "95% interval", "delta BIC", "signature",
                                   "what it stands for"]), "",
                  "delta BIC: how much the BIC rises when the effect is left out of the final model."]
        for key, prof in (profiles or {}).items():
            lines += ["", _profile_note(key, prof)]
    else:
        lines.append("None: no effect of the vocabulary passed the keep rule (see Selection).")
    return lines


def _profile_note(key: str, prof: dict) -> str:
    """What the profile likelihood of a rough magnitude (roboball.diagnose.profile) says of it."""
    effect, name = key.split(".")
    unit = next(p.unit for p in fx.LIBRARY[effect].params if p.name == name)
    lo, hi = prof["interval"]
    vals = prof["values"]
    out = (f"{effect}'s {name} is a breakaway in the creep band: the fit's cost is rough at the scale of a stick "
           f"event, so its 95% interval is the profile likelihood's, not the curvature of the optimum the fit "
           f"ended in. The model was refitted with {name} held at {len(vals)} values from {_fmt(vals[0])} to "
           f"{_fmt(vals[-1])} {unit}; the estimate and the values within the chi-square quantile (likelihood ratio "
           f"at most {prof['q']:.2f} noise variances, inflated for the residual's autocorrelation) span "
           f"[{_fmt(lo)}, {_fmt(hi)}] {unit}")
    out += (f", up to the law's bound: the data bound it from below only." if prof["to_bound"] else ".")
    if prof.get("lr_zero") is not None:
        lr0 = prof["lr_zero"]
        out += f" Without it (zero) the likelihood ratio is {lr0:{'.3g' if lr0 < 1e3 else '.0f'}}"
        out += (", less than twice the quantile: whether the data need a breakaway at all is borderline, and a "
                "change of rounding can decide it either way." if lr0 < 2.0 * prof["q"] else ".")
    if prof.get("lowest"):
        out += (f" Held at {_fmt(prof['lowest']['value'])} {unit} the model fits lower than the estimate (RMS "
                f"{_fmt(prof['lowest']['rmse'])}; the estimate's likelihood ratio to it "
                f"{_fmt(prof['lr_estimate'], 3)}): the estimate is one of the cost's local optima, and the interval "
                "spans both.")
    out += (" Each held fit may end in a local optimum above the profile's, so the interval is at least this "
            "wide.")
    return out + (" The other parameters' intervals are the curvature at the estimate; moving every recorded "
                  "sample by a part in 10^12 has sent such fits to another optimum, farther than those intervals "
                  "(benchmarks/diagnose_last_bits.py).")


def _equivalents(d: Diagnosis, js: dict) -> list:
    """The equivalent explanations of the chosen effects, with the mechanism each stands for
    ([] when the data tell every chosen effect from the others)."""
    entries = [m for m in js["missing_physics"] if m.get("alternatives")]
    if not entries:
        return []
    tol = d.settings.equivalent_tol
    lines = ["", "### Equivalent explanations", "",
             f"The data cannot tell these apart: putting the alternative in the chosen effect's place keeps the "
             f"held-out RMS within {tol:.0%} of the final model's ({_fmt(d.final.cv_rmse)} {d.prep.unit}), and the "
             "alternative passes the keep rule against the model without the chosen effect. Read the chosen one "
             "as one of these mechanisms, not as the only one.", ""]
    rows = []
    for m in entries:
        rows.append((m["effect"], _assignments(m["parameters"]), _fmt(d.final.cv_rmse), m["mechanism"]))
        for a in m["alternatives"]:
            rows.append((f"or {a['effect']}", _assignments(a["parameters"]), _fmt(a["rmse_heldout"]), a["mechanism"]))
    lines.append(_md_table(rows, ["effect", "parameters (SI)", f"held-out RMS ({d.prep.unit})", "what it stands for"]))
    return lines


def _immaterial(d: Diagnosis) -> list:
    """The candidates the data support but that fall short of materiality ([] when none)."""
    if not d.immaterial:
        return []
    rows = []
    for i in d.immaterial:
        for key, val in i["params"].items():
            rows.append((i["effect"], d.model.dof, *_param_cells(i["effect"], key.split(".", 1)[1], val,
                                                                 i["ci95"][key]),
                         _fmt(i["delta_bic"], 5), _fmt(i["heldout_gain"], 3)))
    return ["", "### Supported by the data, below materiality", "",
            "These candidates lower the BIC and the held-out error and their intervals exclude zero, "
            f"but they lower the held-out mean square by less than {d.settings.material_noise:g} noise "
            "variances: the prediction they change is within about two noise levels, the size of the "
            "model-form differences (integrator, contact compliance) a correction can absorb. They are "
            "not added to the model; they are listed so that you can judge them.", "",
            _md_table(rows, ["effect", "dof", "parameter", "95% interval", "delta BIC",
                             "held-out gain (noise variances)"])]


def _fit(d: Diagnosis, drake_stats) -> list:
    """RMS residuals before and after, fitted, held out and in Drake, and the overlay."""
    return ["", "## Fit", "",
            _md_table([("reduced model, fitted", _fmt(d.baseline.rmse), _fmt(d.final.rmse)),
                       ("reduced model, held out", _fmt(d.baseline.cv_rmse), _fmt(d.final.cv_rmse)),
                       ("Drake, fitted parameters", _fmt(drake_stats[0]), _fmt(drake_stats[1]))],
                      ["RMS residual (" + d.prep.unit + ")", "baseline", "augmented"]), "",
            _heldout_note(d, len(d.prep.windows)),
            "", "![recording, baseline and augmented model in Drake](overlay.png)", ""]


def _round_decision(i: dict) -> str:
    """A grown model's decision in the round tables (select.Selector._round_info's entry)."""
    if i.get("kept"):
        return "kept"
    if i.get("qualifies") and not i.get("sidelined"):
        return "passes, higher BIC"
    return i.get("reason", "")


def _selection(d: Diagnosis) -> list:
    """The search and the keep rule as applied, and every round's grown models with their decisions."""
    s = d.settings
    lines = ["## Selection", "", "Each round grows each of the best models so far (up to "
             f"{s.beam_width} per size, the baseline first) by every candidate it lacks and refits by simulation "
             f"error; the {s.top_k} grown models of lowest BIC that beat the best model kept so far are "
             f"cross-validated and judged effect by effect, and the next {s.top_k} in turn while none judged passes. A model is kept when every one of its effects, against "
             f"the same model without it, lowers the BIC by more than {s.bic_min:g}, lowers the held-out RMS by more "
             f"than {s.cv_gain:.0%}, lowers the held-out mean square by at least {s.material_noise:g} noise variances "
             "(materiality), and has 95% intervals of its magnitude (a joint's breakaway: its profile likelihood's; "
             "and of any parameter at whose zero it would "
             "be a simpler effect) that exclude zero (the model without it at the best fit found, also refitted from "
             "the larger model's values); the kept model of lowest BIC is the diagnosis, where it lowers the mean "
             f"square of every kept model of fewer effects on another branch by at least {s.material_noise:g} noise "
             "variances. A round that keeps nothing ends the search"
             + (f" from round {d.model.search_rounds} on" if d.model.search_rounds > 1 else "") + ". In the tables the new effect is in bold and delta BIC is against "
             "the model it was grown from.", ""]
    for k, step in enumerate(d.steps, start=1):
        rows = [(_grown(i), _fmt(i["rmse"]), _fmt(i["cv_rmse"]), _fmt(i["delta_bic"], 5), _round_decision(i))
                for i in step]
        lines += [f"Round {k}:", "", _md_table(rows, ["model", "RMS", "held-out RMS", "delta BIC", "decision"]), ""]
    return lines


def _grown(info: dict) -> str:
    """"coulomb_friction + **linear_stiffness**": the parent's effects and the new one."""
    parent = info.get("parent") or []
    return " + ".join([*parent, f"**{info['effect']}**"])


def _unexplained(d: Diagnosis, located_base, located_final) -> list:
    """Where a structured residual remains ([] unless the verdict is unexplained)."""
    if d.verdict != "unexplained":
        return []
    return ["## Unexplained residual", "", "A structured residual remains that no effect of the vocabulary "
            "explains; it sits here:", "",
            _md_table([(f"{w['start_s']:.2f}-{w['end_s']:.2f} s", w["regime"], f"{w['share_of_residual']:.0%}")
                       for w in (located_final.windows if d.chosen else located_base.windows)],
                      ["time window", "regime", "share of squared residual"]), ""]


def _footer(d: Diagnosis) -> list:
    """The preparation's notes and how long the diagnosis took."""
    lines = []
    if d.prep.notes:
        lines += ["## Notes", ""] + [f"- {n}" for n in d.prep.notes] + [""]
    lines += [f"Diagnosis took {d.timings.get('total_s', 0):.1f} s ({d.timings.get('simulations', 0)} reduced-model "
              f"simulations in {d.timings.get('batched_calls', 0)} batched calls) plus "
              f"{d.timings.get('drake_s', 0):.1f} s of Drake simulation.", ""]
    return lines
