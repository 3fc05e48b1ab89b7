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
3. The best candidate (lowest BIC) is kept only if it passes the keep rule
   (roboball.diagnose.keep: BIC, held-out error, materiality, 95% intervals).
   Rounds stop when nothing qualifies, the residual is white (lag-1 autocorrelation below
   `white_rho` and RMS within `white_factor` noise levels), or `max_effects` were added.
4. A backward pass drops an earlier effect that no longer passes the keep rule against the
   model without it (made redundant by a later pick); a swap pass replaces a chosen effect by
   an unchosen one when that lowers the BIC by more than `bic_min` without raising the
   held-out error (greedy paths can go through an effect that imitates a combination).

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
from roboball.diagnose.keep import KeepRule, immaterial
from roboball.diagnose.scored import Scored, Settings
from roboball.diagnose.sensor_fit import fit_sensor_lag, run_with_sensor_lag, without_stale
from roboball.reduced.base import ReducedModel
from roboball.reduced.models import model_for


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


class Selector(KeepRule):
    """Runs the forward selection for one prepared recording (the keep rule and its statistics
    are inherited from roboball.diagnose.keep.KeepRule)."""

    def __init__(self, prep: Prepared, model: ReducedModel | None = None, settings: Settings | None = None,
                 log=None):
        self.prep = prep = without_stale(prep)     # a smooth estimate's stale repeats (sensor_fit)
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
        return ([b.name for b in self.model.base_params] + self.engine.sensor_free + effect_keys(effects)
                + self.engine.release_keys(windows))

    def full_problem(self, effects, values) -> Problem:
        return Problem(effects=tuple(effects), values=dict(values), free=self.free_keys(effects),
                       masks=dict(self.full_masks))

    # ---- cross-validation ---------------------------------------------------------------------
    def cross_validate(self, scored: list, cofit: bool = False) -> None:
        """Held-out RMSE of each scored model (batched over models and folds).  With `cofit`,
        the models' full fits are refined in the same batched iterations as the folds (which
        then start from the models' current, not final, values)."""
        if not scored:
            return
        stage1 = self._fold_problems(scored, cofit)
        c0 = self.engine.n_calls
        for p in stage1:
            p.max_iter = self.s.fold_iter if isinstance(p.tag, tuple) else self.s.fit_iter
        self.engine.fit(stage1, max_iter=self.s.fit_iter)
        self.log(f"   cv stage1: {len(stage1)} problems, {self.engine.n_calls - c0} calls")
        stage1 = [p for p in stage1 if isinstance(p.tag, tuple)]
        stage2 = self._heldout_state_problems(scored, stage1)
        c0 = self.engine.n_calls
        self.engine.fit(stage2, max_iter=self.s.state_iter)
        self.log(f"   cv stage2: {len(stage2)} problems, {self.engine.n_calls - c0} calls")
        by_tag = {p.tag: p for p in stage2}
        for sc in scored:
            self._heldout_score(sc, stage1, by_tag)

    def _fold_problems(self, scored: list, cofit: bool) -> list:
        """Stage 1: each model fitted on each fold's training data, tagged (id(model), fold)
        (preceded by the models' full fits with `cofit`), every problem unconverged."""
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
        return stage1

    def _heldout_state_problems(self, scored: list, stage1: list) -> list:
        """Stage 2: with a fold's model frozen, only the held-out release's state is fitted
        (starting from the full fit's); block folds (no held-out release) have none."""
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
        return stage2

    def _heldout_score(self, sc: Scored, stage1: list, by_tag: dict) -> None:
        """Assemble `sc`'s held-out prediction from its folds and its held-out RMSE."""
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

    def white(self, sc: Scored) -> bool:
        return sc.rho1 < self.s.white_rho and sc.rmse <= self.s.white_factor * self.prep.fit_noise

    # ---- the selection ----------------------------------------------------------------------
    def run(self) -> Diagnosis:
        t_start = time.perf_counter()
        base = fit_sensor_lag(self, self._baseline())     # the sensor's own lag, where called for
        timings = {"baseline_s": time.perf_counter() - t_start}
        current, chosen, steps = self._forward(base)
        timings["forward_s"] = time.perf_counter() - t_start - timings["baseline_s"]
        if len(chosen) > 1:
            t0 = time.perf_counter()
            current, chosen = self._backward(current, chosen, base)
            timings["backward_s"] = time.perf_counter() - t0
        if len(chosen) >= 2:
            t0 = time.perf_counter()
            current, chosen = self.swaps(current, list(chosen), base)
            timings["swap_s"] = time.perf_counter() - t0
        return self._result(base, current, chosen, steps, timings, t_start)

    def _baseline(self) -> Scored:
        """Step 1: the baseline fitted, cross-validated and scored."""
        base_p = self.full_problem((), self.engine.initial_values())
        base = Scored(effects=(), full=base_p)
        self.cross_validate([base], cofit=True)
        self.score(base)
        self.log(f"baseline: rmse {base.rmse:.4g}, held-out {base.cv_rmse:.4g}, rho1 {base.rho1:.3f}")
        return base

    def _forward(self, base: Scored):
        """Step 2: rounds of candidates until nothing qualifies, the residual is white or
        `max_effects` were added.  Returns (current model, chosen effects, per-round infos)."""
        s = self.s
        current = base
        chosen: list = []
        steps = []
        while len(chosen) < s.max_effects and not self.white(current):
            cands = [c for c in self.model.candidates if c not in chosen]
            if not cands:
                break
            probs = self._screen(current, chosen, cands)
            round_info, eligible = self._judge(probs, current, base)
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
        return current, chosen, steps

    def _screen(self, current: Scored, chosen: list, cands: list) -> list:
        """Each candidate added to the current model, started from its best grid point and
        fitted for a few screening iterations; the better of its two starts, per candidate."""
        eng = self.engine
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
        eng.fit([p for p, _ in pairs], max_iter=self.s.screen_iter)
        return [min(pairs[2 * i][0], pairs[2 * i + 1][0], key=lambda p: p.rss) for i in range(len(cands))]

    def _judge(self, probs: list, current: Scored, base: Scored):
        """The `top_k` best screened candidates (those that fit better than `current`)
        cross-validated; every candidate scored against `current`.  Returns the round's infos
        (best fit first) and the candidates that pass the keep rule."""
        order = sorted(range(len(probs)), key=lambda i: probs[i].rss)
        top = [Scored(effects=probs[i].effects, full=probs[i]) for i in order[: self.s.top_k]
               if probs[i].rss < current.full.rss]
        self.cross_validate(top, cofit=True)
        round_info = []
        for i in order:
            p = probs[i]
            sc = next((t for t in top if t.full is p), None)
            if sc is None:
                sc = Scored(effects=p.effects, full=p)
            self.score(sc, current)
            round_info.append(self._candidate_info(sc, sc in top, current, base))
        eligible = [sc for sc, info in zip([next((t for t in top if t.full is probs[i]), None) for i in order],
                                           round_info) if info["qualifies"]]
        return round_info, eligible

    def _candidate_info(self, sc: Scored, cross_validated: bool, current: Scored, base: Scored) -> dict:
        """One candidate's entry of the round (details.json "rounds"): its scores and, if it
        was cross-validated, the keep rule's decision with its 95% intervals."""
        p = sc.full
        keys = effect_keys(p.effects[-1:])
        info = dict(effect=p.effects[-1], rmse=sc.rmse, cv_rmse=sc.cv_rmse,
                    delta_bic=sc.delta_bic, rho1=sc.rho1, explained=self.explained(sc, current),
                    params={k: p.values[k] for k in keys})
        if cross_validated:
            ci = self.ci95(sc)
            fails = self.failures(sc, current, base, ci)
            info.update(qualifies=not fails, reason=fails[0][1] if fails else "kept",
                        failed=[name for name, _ in fails], heldout_gain=self.heldout_gain(sc, current),
                        ci95={k: list(ci[k]) for k in keys})
        else:
            info.update(qualifies=False, reason="not among the best screened", failed=["screened"])
        info["kept"] = False
        return info

    def _backward(self, current: Scored, chosen: list, base: Scored):
        """Step 4a: drop effects a later pick made redundant, one at a time, until none is."""
        chosen = list(chosen)
        while len(chosen) > 1:
            dropped, current = self._redundant(current, chosen, base)
            if dropped is None:
                break
            chosen.remove(dropped)
        return current, chosen

    def _redundant(self, current: Scored, chosen: list, base: Scored):
        """The first earlier effect of `chosen` that no longer passes the keep rule against the
        model without it, with that model; (None, current) when every one still does."""
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
                return e, r
        return None, current

    def swaps(self, current: Scored, chosen: list, base: Scored, max_swaps: int = 2):
        """Step 4b: replace a chosen effect by an unchosen one when that fits clearly better.

        Greedy selection can take a path through an effect that imitates a combination (on a
        ramp run over a narrow speed range, linear damping imitates drag plus rolling
        resistance); each chosen effect is swapped in turn for every unchosen candidate, refitted
        from grid starts, and the best swap is taken when it lowers the BIC by more than
        `bic_min` and does not raise the held-out error."""
        s = self.s
        for _ in range(max_swaps):
            probs = self._swap_fits(current, chosen)
            if not probs:
                break
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

    def _swap_fits(self, current: Scored, chosen: list) -> list:
        """Every chosen effect replaced in turn by every unchosen candidate, started from the
        best grid point and fitted for the screening iterations ([] when there is none)."""
        eng = self.engine
        others = [c for c in self.model.candidates if c not in chosen]
        trials = []
        for e in chosen:
            keep = [c for c in chosen if c != e]
            v = {k: x for k, x in current.values.items() if not k.startswith(e + ".")}
            for u in others:
                trials.append((self.full_problem(tuple(keep) + (u,), v), u, _rescaled(v, keep)))
        if not trials:
            return []
        starts = eng.best_starts(trials)
        for (p, _, _), st in zip(trials, starts):
            st.pop("_cost", None)
            p.values = st
        probs = [p for p, _, _ in trials]
        eng.fit(probs, max_iter=self.s.screen_iter)
        return probs

    def _result(self, base: Scored, current: Scored, chosen: list, steps: list, timings: dict,
                t_start: float) -> Diagnosis:
        """The final model scored against the baseline, its intervals, verdict and timings."""
        if chosen:
            self.score(current, base)
        ci = self.ci95(current) if chosen else {}
        verdict = self.verdict(base, current, chosen)
        timings["total_s"] = time.perf_counter() - t_start
        timings["simulations"] = self.engine.n_sims
        timings["batched_calls"] = self.engine.n_calls
        return Diagnosis(prep=self.prep, model=self.model, settings=self.s, baseline=base, final=current,
                         chosen=list(chosen), steps=steps, ci95=ci, verdict=verdict, noise=self.prep.noise,
                         timings=timings, folds=self.folds)

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
    return run_with_sensor_lag(Selector(prep, model=model, settings=settings, log=log))
