"""Decide which physics the baseline leaves out: stepwise selection by simulation error.

1. Fit the baseline (its own parameters and every release state) to the whole recording and
   cross-validate it.
2. Each round, every vocabulary effect that applies to the experiment and is not yet in the
   model is added in turn and fitted with everything else by Levenberg-Marquardt on the
   SIMULATION error over all releases (`roboball.diagnose.fit`).  Starts: the best point of a
   dense grid of the effect's magnitudes (roboball.physics.effects.Param.grid_values), tried on
   the current model's values and on "nominal" values (baseline parameters at their defaults,
   release states at the hold levels, earlier effects rescaled by 0.1-1.6), because a model
   that misses strong physics distorts its own fit and dry friction's cost has narrow basins.
   After a few screening iterations the `top_k` best candidates are refitted to convergence and
   cross-validated: leave one release out (fit on the others, then fit only the held-out
   release's state with the model frozen and score it), or for a recording with a single
   release, three contiguous time blocks.
3. Keep rule.  The best candidate (lowest BIC) is kept only if
   - it lowers the BIC, n ln(RSS / n) + k ln(n) (k fitted parameters including the release
     states), by more than `bic_min` = 10 ("very strong" evidence);
   - it lowers the held-out RMS by at least `cv_gain` = 5%;
   - it is material: it lowers the held-out mean square by at least `material_noise` = 4
     noise variances (an RMS of two noise levels), so the sub-noise corrections that absorb
     small model-form differences (integrator, contact compliance) are not reported.  The
     noise is that of the signal the fit compares (`Prepared.fit_noise`): the sensor's, or
     for a ramp's averaged trend the noise left in the average (about a tenth of the raw
     variance); a trend's residual measured in raw variances would let nothing be material;
   - the 95% interval of its magnitude excludes zero, and so does that of every parameter at
     whose zero it becomes a simpler vocabulary entry (`Effect.reduces_to`: backlash whose
     free play b may be zero is linear stiffness, one parameter fewer for the same fit).
   Rounds stop when nothing qualifies, the residual is white (lag-1 autocorrelation below
   `white_rho` and RMS within `white_factor` noise levels), or `max_effects` were added.
4. A backward pass drops an earlier effect that no longer passes the keep rule against the
   model without it (made redundant by a later pick); a swap pass replaces a chosen effect by
   an unchosen one when that lowers the BIC by more than `bic_min` without raising the
   held-out error (greedy paths can go through an effect that imitates a combination).

95% intervals come from the Jacobian at the optimum, cov = s^2 (J^T J)^-1, inflated by
n / n_eff with n_eff = n (1 - rho1) / (1 + rho1) for the residual's lag-1 autocorrelation rho1.

Verdict: `adequate` when nothing was added and the baseline's residual is at the noise level
or shows no structure; `augmented` when effects were added and the augmented model explains
the recording (residual RMS within `explained_factor` = 3 noise levels, or at most a tenth of
the baseline's, i.e. 99% of its squared residual removed); `unexplained` otherwise (a
structured residual remains; where it sits is reported by roboball.diagnose.locate).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from roboball.physics import effects as fx
from roboball.diagnose.data import Prepared
from roboball.diagnose.fit import Engine, Problem, effect_keys
from roboball.reduced.base import DT, ReducedModel
from roboball.reduced.models import model_for
from roboball.metrics import bic, lag1, n_eff


@dataclass
class Settings:
    dt: float = DT
    screen_iter: int = 4
    fit_iter: int = 15                # full fits
    fold_iter: int = 8                # cross-validation fits (warm-started from the full fit)
    state_iter: int = 6               # held-out release-state fits
    top_k: int = 2
    bic_min: float = 10.0
    cv_gain: float = 0.05
    material_noise: float = 4.0       # an effect must lower the held-out mean square by >= 4 sigma^2
    material_share: float = 0.0       # ... (and, if set, this share of the baseline's held-out mean square)
    max_effects: int = 4
    white_rho: float = 0.3
    white_factor: float = 1.5
    explained_factor: float = 3.0
    explained_ratio: float = 0.1      # augmented: residual RMS within 3 noise levels or a tenth of the baseline's
    n_blocks: int = 3


@dataclass
class Scored:
    """A fitted model (full data) with its cross-validation and statistics."""

    effects: tuple
    full: Problem
    cv_rmse: float = math.nan
    cv_pred: dict = field(default_factory=dict)     # window -> held-out prediction (NaN where fitted)
    rho1: float = math.nan
    bic: float = math.nan
    delta_bic: float = math.nan

    @property
    def rmse(self) -> float:
        return math.sqrt(self.full.rss / max(self.full.n, 1))

    @property
    def values(self) -> dict:
        return self.full.values


@dataclass
class Diagnosis:
    """Everything the report and diagnosis.json need."""

    prep: Prepared
    model: ReducedModel
    settings: Settings
    baseline: Scored
    final: Scored
    chosen: list
    steps: list                     # per round: candidates with their scores
    ci95: dict
    verdict: str
    noise: float
    timings: dict = field(default_factory=dict)
    folds: list = field(default_factory=list)

    @property
    def effects(self) -> tuple:
        return self.final.effects

    @property
    def immaterial(self) -> list:
        return immaterial(self.steps)


def immaterial(steps: list) -> list:
    """Candidates of the round where the selection stopped (`steps`: Diagnosis.steps, or the
    "rounds" of details.json) that the data support (they lower the BIC and the held-out error,
    and their intervals exclude zero) but that fall short of materiality alone: not added,
    reported so the user can judge them."""
    if not steps or any(i.get("kept") for i in steps[-1]):
        return []
    return [i for i in steps[-1] if i.get("failed") == ["material"]]


def residuals(prep: Prepared, pred: dict) -> dict:
    return {w.index: pred[w.index] - w.y for w in prep.windows if w.index in pred}


class Selector:
    """Runs the forward selection for one prepared recording."""

    def __init__(self, prep: Prepared, model: ReducedModel | None = None, settings: Settings | None = None,
                 log=None):
        self.prep = prep
        self.model = model or model_for(prep.kind, **({"ramp_angle_deg": prep.recording.ramp_angle_deg}
                                                      if prep.kind == "ramp" else {}))
        self.s = settings or Settings()
        self.engine = Engine(self.model, prep, self.s.dt)
        self.full_masks = {w.index: np.ones(w.n, bool) for w in prep.windows}
        self.folds = self._folds()
        self.log = log or (lambda msg: None)

    # ---- cross-validation folds --------------------------------------------------------------
    def _folds(self):
        """[(train masks, held-out window or None, held-out masks)]."""
        wins = self.prep.windows
        if len(wins) >= 2:
            out = []
            for w in wins:
                train = {v.index: np.ones(v.n, bool) for v in wins if v.index != w.index}
                out.append((train, w.index, {w.index: np.ones(w.n, bool)}))
            return out
        w = wins[0]
        after = np.nonzero(w.t >= w.t0)[0]
        edges = np.linspace(0, len(after), self.s.n_blocks + 1).astype(int)
        out = []
        for b in range(self.s.n_blocks):
            held = np.zeros(w.n, bool)
            lo = 0 if b == 0 else after[edges[b]]
            hi = w.n if b == self.s.n_blocks - 1 else after[edges[b + 1]]
            held[lo:hi] = True
            out.append(({w.index: ~held}, None, {w.index: held}))
        return out

    # ---- problems -----------------------------------------------------------------------------
    def free_keys(self, effects, windows=None) -> list:
        return [b.name for b in self.model.base_params] + effect_keys(effects) + self.engine.release_keys(windows)

    def full_problem(self, effects, values) -> Problem:
        return Problem(effects=tuple(effects), values=dict(values), free=self.free_keys(effects),
                       masks=dict(self.full_masks))

    def cross_validate(self, scored: list, cofit: bool = False) -> None:
        """Held-out RMSE of each scored model (batched over models and folds).  With `cofit`,
        the models' full fits are refined in the same batched iterations as the folds (which
        then start from the models' current, not final, values)."""
        if not scored:
            return
        stage1 = [sc.full for sc in scored] if cofit else []
        for sc in scored:
            for fi, (train, held_w, held_masks) in enumerate(self.folds):
                wins = set(train)
                p = Problem(effects=sc.effects, values=dict(sc.values),
                            free=[k for k in self.free_keys(sc.effects) if "@" not in k or int(k.split("@")[1]) in wins],
                            masks=dict(train), tag=(id(sc), fi))
                stage1.append(p)
        for p in stage1:
            p.converged = False
        c0 = self.engine.n_calls
        for p in stage1:
            p.max_iter = self.s.fold_iter if isinstance(p.tag, tuple) else self.s.fit_iter
        self.engine.fit(stage1, max_iter=self.s.fit_iter)
        self.log(f"   cv stage1: {len(stage1)} problems, {self.engine.n_calls - c0} calls")
        stage1 = [p for p in stage1 if isinstance(p.tag, tuple)]
        stage2 = []
        for p in stage1:
            sc_id, fi = p.tag
            train, held_w, held_masks = self.folds[fi]
            if held_w is None:
                continue
            sc = next(s for s in scored if id(s) == sc_id)
            v = dict(p.values)
            for k in self.engine.release_keys([held_w]):
                v[k] = sc.values[k]
            stage2.append(Problem(effects=sc.effects, values=v, free=self.engine.release_keys([held_w]),
                                  masks={held_w: np.ones(self.engine.windows[held_w].n, bool)}, tag=p.tag))
        c0 = self.engine.n_calls
        self.engine.fit(stage2, max_iter=self.s.state_iter)
        self.log(f"   cv stage2: {len(stage2)} problems, {self.engine.n_calls - c0} calls")
        by_tag = {p.tag: p for p in stage2}
        for sc in scored:
            pred = {w.index: np.full(w.n, np.nan) for w in self.prep.windows}
            for fi, (train, held_w, held_masks) in enumerate(self.folds):
                p = by_tag.get((id(sc), fi)) if held_w is not None else next(
                    q for q in stage1 if q.tag == (id(sc), fi))
                for w, m in held_masks.items():
                    pred[w][m] = p.pred[w][m]
            sc.cv_pred = pred
            sq = [np.nansum((pred[w.index] - w.y) ** 2) for w in self.prep.windows]
            n = sum(int(np.sum(np.isfinite(pred[w.index]))) for w in self.prep.windows)
            sc.cv_rmse = math.sqrt(sum(sq) / max(n, 1))

    def score(self, sc: Scored, reference: Scored | None = None) -> None:
        sc.rho1 = lag1(residuals(self.prep, sc.full.pred))
        n = sc.full.n
        sc.bic = bic(sc.full.rss, n, sc.full.k, n)
        if reference is not None:
            sc.delta_bic = sc.bic - bic(reference.full.rss, reference.full.n, reference.full.k, n)

    def explained(self, sc: Scored, reference: Scored) -> float:
        """Mean squared residual the model removes relative to `reference`, in noise variances."""
        return (reference.full.rss - sc.full.rss) / sc.full.n / self.prep.fit_noise ** 2

    def failures(self, sc: Scored, reference: Scored, base: Scored, ci: dict | None = None) -> list:
        """Every condition of the keep rule that `sc` fails against `reference`, in the rule's
        order, as (condition, why) with condition "bic", "heldout", "material" or "itself"
        (`ci`: sc's 95% intervals, when the caller has them)."""
        s = self.s
        out = []
        if not sc.delta_bic < -s.bic_min:
            out.append(("bic", f"delta BIC {sc.delta_bic:.1f} not below -{s.bic_min:g}"))
        if not sc.cv_rmse < (1.0 - s.cv_gain) * reference.cv_rmse:
            out.append(("heldout", f"held-out RMS {sc.cv_rmse:.4g} not {s.cv_gain:.0%} below {reference.cv_rmse:.4g}"))
        need = max(s.material_noise, s.material_share * base.cv_rmse ** 2 / self.prep.fit_noise ** 2)
        gain = self.heldout_gain(sc, reference)
        if not gain >= need:
            out.append(("material", f"lowers the held-out mean square by {gain:.3g} noise variances, below {need:.3g}"))
        why = self.not_itself(sc, sc.effects[-1], ci)
        if why:
            out.append(("itself", why))
        return out

    def heldout_gain(self, sc: Scored, reference: Scored) -> float:
        """Held-out mean square `sc` removes relative to `reference`, in noise variances."""
        return (reference.cv_rmse ** 2 - sc.cv_rmse ** 2) / self.prep.fit_noise ** 2

    def qualifies(self, sc: Scored, reference: Scored, base: Scored) -> tuple[bool, str]:
        """The keep rule: information criterion, held-out error, materiality, significance."""
        fails = self.failures(sc, reference, base)
        return (False, fails[0][1]) if fails else (True, "kept")

    def white(self, sc: Scored) -> bool:
        return sc.rho1 < self.s.white_rho and sc.rmse <= self.s.white_factor * self.prep.fit_noise

    # ---- confidence intervals -------------------------------------------------------------
    def ci95(self, sc: Scored) -> dict:
        p = sc.full
        J = p.J
        n, k = J.shape
        s2 = p.rss / max(n - k, 1)
        infl = n / n_eff(n, sc.rho1)
        scale = np.array([max(np.linalg.norm(J[:, j]), 1e-300) for j in range(k)])
        Js = J / scale
        try:
            cov = np.linalg.pinv(Js.T @ Js) / np.outer(scale, scale) * s2 * infl
        except np.linalg.LinAlgError:
            cov = np.full((k, k), np.nan)
        out = {}
        for j, key in enumerate(p.free):
            sd = math.sqrt(max(cov[j, j], 0.0))
            out[key] = (p.values[key] - 1.96 * sd, p.values[key] + 1.96 * sd)
        return out

    def not_itself(self, sc: Scored, effect: str, ci: dict | None = None) -> str:
        """Why the fitted `effect` is not shown to be itself ("" when it is): the 95% interval
        of its magnitude includes zero, or that of a parameter at whose zero it becomes a
        simpler vocabulary entry (backlash whose free play may be zero is linear stiffness,
        which is then the effect to report: fewer parameters, the same fit)."""
        ci = ci if ci is not None else self.ci95(sc)
        eff = fx.LIBRARY[effect]
        simpler = dict(eff.reduces_to)
        for name in eff.defining_params():
            lo, hi = ci[f"{effect}.{name}"]
            if lo <= 0.0 <= hi:
                if name in simpler:
                    return f"95% interval of {name} includes zero: {effect} with {name} = 0 is {simpler[name]}"
                return "95% interval of its magnitude includes zero"
        return ""

    # ---- the selection ----------------------------------------------------------------------
    def run(self) -> Diagnosis:
        t_start = time.perf_counter()
        s = self.s
        eng = self.engine
        base_p = self.full_problem((), eng.initial_values())
        base = Scored(effects=(), full=base_p)
        self.cross_validate([base], cofit=True)
        self.score(base)
        self.log(f"baseline: rmse {base.rmse:.4g}, held-out {base.cv_rmse:.4g}, rho1 {base.rho1:.3f}")
        timings = {"baseline_s": time.perf_counter() - t_start}
        current = base
        chosen: list = []
        steps = []
        while len(chosen) < s.max_effects and not self.white(current):
            cands = [c for c in self.model.candidates if c not in chosen]
            if not cands:
                break
            # Start each candidate from the best grid point of two families of starts: the
            # current model's values, and "nominal" ones (baseline parameters at their
            # defaults, release states at the hold levels, the effects already chosen rescaled
            # by 0.1 to 1.6: a later effect often takes over part of what an earlier one
            # absorbed).  A model that misses strong physics distorts its own fit (the
            # viscous coefficient soaks up dry friction, say), and the cost of dry friction has
            # narrow basins, so a start from the distorted values alone can miss the optimum.
            nominal = dict(eng.initial_values())
            nominal.update({k: v for k, v in current.values.items() if "." in k})
            variants = _rescaled(nominal, chosen)
            pairs = [x for c in cands for x in ((self.full_problem(tuple(chosen) + (c,), current.values), c,
                                                 current.values),
                                                (self.full_problem(tuple(chosen) + (c,), nominal), c, variants))]
            starts = eng.best_starts(pairs)
            pairs = [(p, c) for p, c, _ in pairs]
            for (p, _), v in zip(pairs, starts):
                v.pop("_cost", None)
                p.values = v
            eng.fit([p for p, _ in pairs], max_iter=s.screen_iter)
            probs = [min(pairs[2 * i][0], pairs[2 * i + 1][0], key=lambda p: p.rss) for i in range(len(cands))]
            order = sorted(range(len(cands)), key=lambda i: probs[i].rss)
            top = [Scored(effects=probs[i].effects, full=probs[i]) for i in order[: s.top_k]
                   if probs[i].rss < current.full.rss]
            self.cross_validate(top, cofit=True)
            round_info = []
            for i in order:
                p = probs[i]
                sc = next((t for t in top if t.full is p), None)
                if sc is None:
                    sc = Scored(effects=p.effects, full=p)
                self.score(sc, current)
                keys = effect_keys(p.effects[-1:])
                info = dict(effect=p.effects[-1], rmse=sc.rmse, cv_rmse=sc.cv_rmse,
                            delta_bic=sc.delta_bic, rho1=sc.rho1, explained=self.explained(sc, current),
                            params={k: p.values[k] for k in keys})
                if sc in top:
                    ci = self.ci95(sc)
                    fails = self.failures(sc, current, base, ci)
                    info.update(qualifies=not fails, reason=fails[0][1] if fails else "kept",
                                failed=[name for name, _ in fails], heldout_gain=self.heldout_gain(sc, current),
                                ci95={k: list(ci[k]) for k in keys})
                else:
                    info.update(qualifies=False, reason="not among the best screened", failed=["screened"])
                info["kept"] = False
                round_info.append(info)
            eligible = [sc for sc, info in zip([next((t for t in top if t.full is probs[i]), None) for i in order],
                                               round_info) if info["qualifies"]]
            summary = ", ".join(f"{i['effect']} dBIC {i['delta_bic']:.4g} cv {i['cv_rmse']:.4g} "
                                f"expl {i['explained']:.3g} ({i['reason']})" for i in round_info[: s.top_k + 1])
            steps.append(round_info)
            if not eligible:
                self.log("round: nothing qualifies: " + summary)
                break
            best = min(eligible, key=lambda sc: sc.bic)
            for info in round_info:
                info["kept"] = info["effect"] == best.effects[-1]
            self.log(f"round: keep {best.effects[-1]}; " + summary)
            chosen.append(best.effects[-1])
            current = best
        timings["forward_s"] = time.perf_counter() - t_start - timings["baseline_s"]
        # Backward pass: drop effects a later pick made redundant.
        if len(chosen) > 1:
            t0 = time.perf_counter()
            changed = True
            while changed and len(chosen) > 1:
                changed = False
                reduced = []
                # The last effect has just passed the keep rule against the model without it.
                candidates_out = chosen[:-1]
                for e in candidates_out:
                    rest = tuple(c for c in chosen if c != e)
                    v = {k: x for k, x in current.values.items() if not k.startswith(e + ".")}
                    reduced.append(Scored(effects=rest, full=self.full_problem(rest, v)))
                self.cross_validate(reduced, cofit=True)
                for e, r in zip(candidates_out, reduced):
                    self.score(current, r)
                    needed, why = self.qualifies(_reordered(current, e), r, base)
                    if not needed:
                        self.log(f"backward: drop {e} ({why})")
                        chosen.remove(e)
                        current = r
                        changed = True
                        break
            timings["backward_s"] = time.perf_counter() - t0
        if len(chosen) >= 2:
            t0 = time.perf_counter()
            current, chosen = self.swaps(current, list(chosen), base)
            timings["swap_s"] = time.perf_counter() - t0
        if chosen:
            self.score(current, base)
        ci = self.ci95(current) if chosen else {}
        verdict = self.verdict(base, current, chosen)
        timings["total_s"] = time.perf_counter() - t_start
        timings["simulations"] = eng.n_sims
        timings["batched_calls"] = eng.n_calls
        return Diagnosis(prep=self.prep, model=self.model, settings=s, baseline=base, final=current,
                         chosen=list(chosen), steps=steps, ci95=ci, verdict=verdict, noise=self.prep.noise,
                         timings=timings, folds=self.folds)

    def swaps(self, current: Scored, chosen: list, base: Scored, max_swaps: int = 2):
        """Replace a chosen effect by an unchosen one when that fits clearly better.

        Greedy selection can take a path through an effect that imitates a combination (on a
        ramp run over a narrow speed range, linear damping imitates drag plus rolling
        resistance); each chosen effect is swapped in turn for every unchosen candidate, refitted
        from grid starts, and the best swap is taken when it lowers the BIC by more than
        `bic_min` and does not raise the held-out error."""
        s, eng = self.s, self.engine
        for _ in range(max_swaps):
            others = [c for c in self.model.candidates if c not in chosen]
            trials = []
            for e in chosen:
                keep = [c for c in chosen if c != e]
                v = {k: x for k, x in current.values.items() if not k.startswith(e + ".")}
                for u in others:
                    trials.append((self.full_problem(tuple(keep) + (u,), v), u, _rescaled(v, keep)))
            if not trials:
                break
            starts = eng.best_starts(trials)
            for (p, _, _), st in zip(trials, starts):
                st.pop("_cost", None)
                p.values = st
            probs = [p for p, _, _ in trials]
            eng.fit(probs, max_iter=s.screen_iter)
            best_p = min(probs, key=lambda p: p.rss)
            if not best_p.rss < current.full.rss:
                break
            cand = Scored(effects=best_p.effects, full=best_p)
            self.cross_validate([cand], cofit=True)
            self.score(cand, current)
            if cand.delta_bic < -s.bic_min and cand.cv_rmse <= current.cv_rmse and \
                    not self.not_itself(cand, cand.effects[-1]):
                out = next(e for e in chosen if e not in cand.effects)
                self.log(f"swap: {out} -> {cand.effects[-1]} (dBIC {cand.delta_bic:.1f}, held-out "
                         f"{cand.cv_rmse:.4g} vs {current.cv_rmse:.4g})")
                chosen = list(cand.effects)
                current = cand
            else:
                break
        return current, chosen

    def verdict(self, base: Scored, final: Scored, chosen) -> str:
        s, noise = self.s, self.prep.fit_noise
        if not chosen:
            structured = base.rho1 >= 0.5 and base.rmse > s.explained_factor * noise
            return "unexplained" if structured else "adequate"
        explained = final.rmse <= max(s.explained_factor * noise, s.explained_ratio * base.rmse)
        return "augmented" if explained else "unexplained"


def _rescaled(values: dict, effects, factors=(0.1, 0.3, 0.6, 1.0, 1.6), cap: int = 9) -> list:
    """Variants of `values` with the magnitudes (first parameters) of `effects` rescaled by
    each combination of `factors` (jointly when there would be more than `cap` variants)."""
    firsts = [f"{e}.{fx.LIBRARY[e].params[0].name}" for e in effects]
    if not firsts:
        return [dict(values)]
    combos = [[]]
    if len(factors) ** len(firsts) <= cap:
        for _ in firsts:
            combos = [c + [f] for c in combos for f in factors]
    else:
        combos = [[f] * len(firsts) for f in factors]
    out = []
    for c in combos:
        v = dict(values)
        for key, f in zip(firsts, c):
            v[key] = values[key] * f
        out.append(v)
    return out


def _reordered(sc: Scored, last: str) -> Scored:
    """The same fitted model with `last` named as its most recent effect (for `qualifies`)."""
    return Scored(effects=tuple(e for e in sc.effects if e != last) + (last,), full=sc.full, cv_rmse=sc.cv_rmse,
                  cv_pred=sc.cv_pred, rho1=sc.rho1, bic=sc.bic, delta_bic=sc.delta_bic)


def diagnose_prepared(prep: Prepared, settings: Settings | None = None, log=None,
                      model: ReducedModel | None = None) -> Diagnosis:
    """Run the selection on a prepared recording (against `model`, default: the kind's baseline)."""
    return Selector(prep, model=model, settings=settings, log=log).run()
