"""Decide which physics the baseline leaves out: a beam search over small sets of effects, by
simulation error.

1. Fit the baseline (its own parameters and every release state) to the whole recording and
   cross-validate it.
2. Each round grows every model of the beam by one more vocabulary effect that applies to the
   experiment, in turn, and fits it with everything else by Levenberg-Marquardt on the
   SIMULATION error over all releases (`roboball.diagnose.fit`).  Starts: the best point of a
   dense grid of the effect's magnitudes (roboball.physics.effects.Param.grid_values), tried on
   the parent model's values and on "nominal" values (baseline parameters at their defaults,
   release states at the hold levels, the parent's effects rescaled by 0.1-1.6), because a
   model that misses strong physics distorts its own fit and dry friction's cost has narrow
   basins.  A set reached from two parents keeps the better fit.
3. The grown models that beat the best model kept so far on BIC are judged, the `top_k` best
   by BIC, and the next `top_k` in turn while none judged passes: each is refitted to convergence and cross-validated (leave one release out, or
   three contiguous time blocks of a single release: roboball.diagnose.crossval) and kept only
   if EVERY effect in it passes the keep rule (roboball.diagnose.keep: BIC, held-out error,
   materiality, 95% intervals) against the same model without that effect.  The next round's
   beam is the `beam_width` grown models of lowest BIC that lower their parent's BIC by more
   than `bic_min` (and the best kept model, if grown this round).
4. Rounds stop after `max_effects`, or when no model of the beam is left to grow (none lowers
   its parent's BIC, or their residuals are white: lag-1 autocorrelation below `white_rho` and
   RMS within `white_factor` noise levels).  The diagnosis is the kept model of lowest BIC.

Why a beam: effects that only help together (a stiffness and a damping: the stiffness alone
leaves an undamped swing) are missed by a single greedy path that first takes an effect
imitating part of both (a rolling resistance); a model that passes the keep rule effect by
effect is found from whichever of its parts the beam holds.  Equivalent explanations of the
chosen model's effects are then looked for (roboball.diagnose.equivalents).

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
from roboball.diagnose.crossval import CrossValidation
from roboball.diagnose.data import Prepared
from roboball.diagnose.equivalents import bic_on, equivalents
from roboball.diagnose.fit import Engine, Problem, effect_keys
from roboball.diagnose.hidden import chosen_starts
from roboball.diagnose.keep import KeepRule, immaterial
from roboball.diagnose.profile import profiled_ci95
from roboball.diagnose.restarts import restart_rough_fits
from roboball.diagnose.scored import Scored, Settings
from roboball.diagnose.sensor_fit import fit_sensor_lag, run_with_sensor_lag, without_stale
from roboball.reduced.base import ReducedModel
from roboball.reduced.models import model_for

FIT_RTOL = 1e-3         # Engine.fit's relative stopping tolerance (its `rtol`)


@dataclass
class Diagnosis:
    """Everything the report and diagnosis.json need."""

    prep: Prepared
    model: ReducedModel
    settings: Settings
    baseline: Scored
    final: Scored
    chosen: list
    steps: list                     # per round: the grown models with their scores and decisions
    ci95: dict
    verdict: str
    noise: float
    timings: dict = field(default_factory=dict)
    folds: list = field(default_factory=list)
    drop_bic: dict = field(default_factory=dict)       # effect -> BIC change of the final model without it
    alternatives: dict = field(default_factory=dict)   # effect -> equivalent explanations (equivalents.py)
    # a shell release of unrecorded steer setting: each setting's effects and held-out RMS
    steer_settings: dict = field(default_factory=dict)
    # ... and which was reported, whether the data decided it, and the paired test (diagnose.steer)
    steer_decision: dict = field(default_factory=dict)
    profiles: dict = field(default_factory=dict)       # a rough magnitude -> its profile (diagnose.profile)

    @property
    def effects(self) -> tuple:
        return self.final.effects

    @property
    def immaterial(self) -> list:
        return immaterial(self.steps, self.chosen)


class Selector(KeepRule, CrossValidation):
    """Runs the search for one prepared recording (the keep rule and its statistics are inherited
    from roboball.diagnose.keep.KeepRule, the held-out errors from roboball.diagnose.crossval)."""

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
        self.fits: dict = {}        # frozenset of effects -> the best fit of that model found (Scored)
        self.baseline_holds_sensor = False      # True: the models with effects alone fit the sensor (sensor_fit)

    # ---- problems -----------------------------------------------------------------------------
    def free_keys(self, effects, windows=None) -> list:
        sensor = [] if self.baseline_holds_sensor and not effects else self.engine.sensor_free
        return ([b.name for b in self.model.base_params] + sensor + effect_keys(effects, self.model.held_params)
                + self.engine.release_keys(windows))

    def full_problem(self, effects, values) -> Problem:
        held = {k: self.engine.defaults[k] for k in effect_keys(effects) if k in self.model.held_params}
        return Problem(effects=tuple(effects), values={**dict(values), **held}, free=self.free_keys(effects),
                       masks=dict(self.full_masks))

    def white(self, sc: Scored) -> bool:
        return sc.rho1 < self.s.white_rho and sc.rmse <= self.s.white_factor * self.prep.fit_noise

    def remember(self, sc: Scored) -> Scored:
        """Store `sc` as its set's fit unless a better (lower RSS) one is known; returns the kept one
        (a fit whose RSS is not finite, a diverged one, is never better)."""
        old = self.fits.get(sc.key)
        if old is None or sc.full.rss < old.full.rss or not math.isfinite(old.full.rss):
            self.fits[sc.key] = sc
            return sc
        return old

    # ---- the search ---------------------------------------------------------------------------
    def run(self) -> Diagnosis:
        t_start = time.perf_counter()
        base = fit_sensor_lag(self, self._baseline())     # the sensor's own lag, where called for
        self.fits = {base.key: base}
        timings = {"baseline_s": time.perf_counter() - t_start}
        final, steps = self._search(base)
        timings["search_s"] = time.perf_counter() - t_start - timings["baseline_s"]
        t0 = time.perf_counter()
        final, alternatives = equivalents(self, final, base)
        timings["equivalents_s"] = time.perf_counter() - t0
        mark_kept(steps, final)
        return self._result(base, final, steps, alternatives, timings, t_start)

    def _baseline(self) -> Scored:
        """Step 1: the baseline fitted, cross-validated and scored."""
        start = self.engine.initial_values()
        base_p = self.full_problem((), start)
        if self.engine.hidden:
            base_p.values = self.engine.best_of(base_p, [start] + self.engine.hidden_variants(start))
        base = Scored(effects=(), full=base_p)
        self.cross_validate([base], cofit=True)
        self.score(base)
        self.log(f"baseline: rmse {base.rmse:.4g}, held-out {base.cv_rmse:.4g}, rho1 {base.rho1:.3f}")
        return base

    def _search(self, base: Scored):
        """Steps 2-4: rounds of the beam search.  Returns (the kept model of lowest BIC, per-round
        infos of every grown model)."""
        best, beam, steps, kept = base, [base], [], []
        for n_round in range(1, self.s.max_effects + 1):
            parents = [p for p in beam if not self.white(p)]
            children = self.grow(parents, prefer=best) if parents else []
            if not children:
                break
            judged = self._judge(children, best, base)
            best = self._refitted_best(best, base)
            passed = [sc for sc, checks in judged if all(not fails for _, _, fails in checks)]
            sidelined = {}
            for sc in sorted(passed, key=lambda x: x.bic):
                why = self.not_better_than_smaller(sc, kept, base)
                if why:
                    sidelined[id(sc)] = why
                elif sc.bic < best.bic:
                    best = sc
            kept += passed
            steps.append(self._round_info(children, dict((id(sc), checks) for sc, checks in judged), best, base,
                                          sidelined))
            self.log(f"round: best so far {'+'.join(best.effects) or 'baseline'}; "
                     + ", ".join(f"{'+'.join(i['set'])} dBIC {i['delta_bic']:.4g} cv {i['cv_rmse']:.4g} ({i['reason']})"
                                 for i in steps[-1][: self.s.top_k + 2]))
            # a round that keeps nothing ends the search, as a greedy path would; a model that says
            # its effects may only help together searches its first `search_rounds` regardless
            if not passed and n_round >= self.model.search_rounds:
                break
            beam = self._next_beam(children, best)
        return best, steps

    def not_better_than_smaller(self, sc: Scored, kept: list, base: Scored) -> str:
        """Why `sc`, which passes the keep rule effect by effect, may not replace the kept models
        with fewer effects that are no part of it ("" when it may): against each it must lower the
        mean square of the fit materially (by the keep rule's 4 noise variances).  A search that
        reaches {A, B} on another branch than the kept {C} would otherwise choose it by BIC alone,
        and the BIC counts the sub-noise corrections that materiality refuses: the true C, refused
        a small second effect as immaterial, lost to a stand-in for C with that small effect
        beside it, the stand-in's partner made material by the stand-in's own misfit (an added
        inertia lost to a negative stiffness with a cubic one, 1.5 noise variances closer).
        The fit's mean square, not the held-out one: the models are not nested, and the keep
        rule's held-out test has judged every effect of both already; a single release's held-out
        blocks extrapolate (the real shell log's first swing from the later ones), and there a
        rolling resistance with an offset predicts them better (0.041 rad) than the damping,
        stiffness and offset (0.049) that fit the log far better (0.030 against 0.040)."""
        s = self.s
        need = max(s.material_noise, s.material_share * base.cv_rmse ** 2 / self.prep.fit_noise ** 2)
        for m in kept:
            if len(m.effects) >= len(sc.effects) or m.key < sc.key:
                continue
            gain = self.explained(sc, m)
            if not gain >= need:
                return (f"passes the keep rule but is not chosen over {'+'.join(m.effects)}: lowers its mean "
                        f"square by {gain:.3g} noise variances, below {need:.3g}")
        return ""

    def _refitted_best(self, best: Scored, base: Scored) -> Scored:
        """`best`, or the better fit of its set found since (`restart_references`: judging a
        larger model refits the model without an effect from the larger model's values) when that
        fit, too, passes the keep rule effect by effect."""
        new = self.fits.get(best.key, best)
        if new is best or not best.effects:
            return best
        self.validate([new])
        if all(not fails for _, _, fails in self.checks(new, base)):
            self.log(f"   better fit of {'+'.join(best.effects)}: rms {best.rmse:.4g} -> {new.rmse:.4g}, "
                     f"held out {best.cv_rmse:.4g} -> {new.cv_rmse:.4g}")
            return new
        return best

    def grow(self, parents: list, only: dict | None = None, prefer: Scored | None = None) -> list:
        """Every parent grown by each candidate it lacks (or, with `only`, parent key -> the
        candidates to add), screened from grid starts; the better fit per set, scored against its
        parent and remembered.  A set that `prefer` (the best model kept so far) grows into is
        named as grown from it, whichever parent gave the fit: the report and `immaterial` read
        the effects that extend the kept model.  Returns the grown models, lowest BIC first."""
        pairs = [(p, c) for p in parents for c in (only[p.key] if only else self.model.candidates)
                 if c not in p.effects]
        if not pairs:
            return []
        probs = self._screen(pairs)
        grown = {}
        for (parent, _), prob in zip(pairs, probs):
            old = grown.get(frozenset(prob.effects))       # (parent, problem): the better fit per set
            if old is None or prob.rss < old[1].rss:
                grown[frozenset(prob.effects)] = (parent, prob)
        out = []
        for key, (parent, prob) in grown.items():
            if prefer is not None and prefer.key < key and len(key - prefer.key) == 1:
                parent = prefer
            effects = tuple(parent.effects) + tuple(key - parent.key)
            sc = Scored(effects=effects, full=prob, parent=parent.effects)
            self.score(sc, parent)
            out.append(self.remember(sc))
        return sorted(out, key=lambda sc: sc.bic)

    def _screen(self, pairs: list) -> list:
        """Each (parent, candidate) fitted for a few screening iterations from the best grid start
        of two families of starts; the better of the two per pair."""
        eng = self.engine
        # The parent's values, and "nominal" ones (baseline parameters at their defaults, release
        # states at the hold levels, the parent's effects rescaled by 0.1 to 1.6: a later effect
        # often takes over part of what an earlier one absorbed).  A model that misses strong
        # physics distorts its own fit (the viscous coefficient soaks up dry friction, say), and
        # the cost of dry friction has narrow basins, so a start from the distorted values alone
        # can miss the optimum.  The beam's other parents add diversity of their own, so they get
        # the nominal values unscaled: their grids cost a sixth of the first parent's.
        trials = []
        first = pairs[0][0]
        nominals = {id(p): {**eng.initial_values(), **{k: v for k, v in p.values.items() if "." in k}} for p, _ in pairs}
        chosen = dict(zip(nominals, chosen_starts(eng, list(nominals.values()))))    # per release, one batch
        for parent, c in pairs:
            nominal = nominals[id(parent)]
            effects = tuple(parent.effects) + (c,)
            trials.append((self.full_problem(effects, parent.values), c, parent.values))
            variants = _rescaled(nominal, parent.effects) if parent is first else [nominal]
            variants += chosen[id(parent)]
            trials.append((self.full_problem(effects, nominal), c, variants))
        starts = eng.best_starts(trials)
        for (p, _, _), v in zip(trials, starts):
            v.pop("_cost", None)
            p.values = v
        eng.fit([p for p, _, _ in trials], max_iter=self.s.screen_iter)
        return [min(trials[2 * i][0], trials[2 * i + 1][0], key=lambda p: p.rss) for i in range(len(pairs))]

    def _judge(self, children: list, best: Scored, base: Scored) -> list:
        """[(model, checks)] of the grown models that beat `best` on BIC, judged `top_k` at a time in order of
        BIC until one passes (the first `top_k` alone pruned a free imbalanced shell's stiffness + damping)."""
        todo = [sc for sc in children if sc.bic < best.bic]
        out = []
        for k in range(0, len(todo), self.s.top_k):
            out += self._judge_batch(todo[k:k + self.s.top_k], base)
            if any(all(not fails for _, _, fails in checks) for _, checks in out):
                break
        return out

    def _judge_batch(self, todo: list, base: Scored) -> list:
        """`todo` judged (a joint's breakaway refitted from several starts first: diagnose.restarts): the newest
        effect against the parent; only where it passes, the models without each other effect too."""
        restart_rough_fits(self, todo)
        self.restart_references(todo, newest_only=True)
        self.validate(todo + [self.fits[frozenset(sc.parent)] for sc in todo], references=False)
        out = [(sc, [self.check(sc, sc.effects[-1], self.fits[frozenset(sc.parent)], base)]) for sc in todo]
        rest = [sc for sc, checks in out if not checks[0][2] and len(sc.effects) > 1]
        self.restart_references(rest)
        self.validate(rest)
        return [(sc, self.checks(sc, base) if sc in rest else checks) for sc, checks in out]

    def validate(self, models: list, references: bool = True, only: str | None = None) -> None:
        """Cross-validate `models` (refitting them to convergence) and, with `references`, every
        model each of their effects (or only effect `only`) is judged against (`references`),
        where not done yet (those never fitted start from the model's own values, the effect left
        out or simplified)."""
        targets = [(e, key, effects, values) for sc in (models if references else [])
                   for e, key, effects, values in self.references(sc) if only is None or e == only]
        for _, key, effects, values in targets:
            if key not in self.fits:
                self.fits[key] = Scored(effects=effects, full=self.full_problem(effects, values))
        others = [self.fits[key] for _, key, _, _ in targets]
        need = list({id(x): x for x in list(models) + others if math.isnan(x.cv_rmse)}.values())
        self.cross_validate(need, cofit=True)
        for x in need:
            self.score(x, self.fits.get(frozenset(x.parent)) if x.parent is not None else None)

    def restart_references(self, models: list, newest_only: bool = False) -> None:
        """Fit each model that an effect of `models` is judged against (`references`; with `newest_only`,
        only the newest effect's) also from that larger model's values with the effect left out, and keep
        the better fit of the set (`remember`).  A set's stored fit may sit in a poorer basin than the larger
        model reached (the stored {Coulomb, offset} at 5.9 mrad RMS, where {Coulomb, offset, stiffness}
        reached 0.68 mrad, the set without the stiffness 0.69 mrad from there): judged against the poorer
        fit, an effect is credited with the shared parameters' better basin and passes.
        The keep rule compares with the same model without the effect, at its best fit found
        (a fit lower by less than the fits' own stopping tolerance, FIT_RTOL, is the same fit)."""
        trials = []
        for sc in models:
            for e, key, effects, values in self.references(sc):
                if (newest_only and e != sc.effects[-1]) or key not in self.fits:
                    continue        # a set never fitted starts from these values anyway (validate)
                trials.append((key, self.full_problem(effects, values)))
        if not trials:
            return
        self.engine.fit([p for _, p in trials], max_iter=self.s.fit_iter)
        for key, prob in trials:
            old = self.fits[key]
            if math.isfinite(prob.rss) and not prob.rss >= (1.0 - FIT_RTOL) * old.full.rss:
                self.log(f"   {'+'.join(old.effects) or 'baseline'} refitted from a larger model: rms "
                         f"{old.rmse:.4g} -> {math.sqrt(prob.rss / max(prob.n, 1)):.4g}")
                self.remember(Scored(effects=old.effects, full=prob, parent=old.parent))

    def references(self, sc: Scored) -> list:
        """What each effect of `sc` is judged against, the newest effect first: [(effect, key,
        effects, starting values)] of the same model without the effect, and, for an effect that
        becomes a simpler vocabulary entry at a parameter's zero (backlash with no free play is
        linear stiffness) or as a fitted parameter grows without bound (a breakaway that never
        fades is a constant dry torque), of the model with the simpler entry in its place: its
        extra parameter must earn its keep by the same rule (a search that grows both sets would
        otherwise choose between them by BIC alone)."""
        out = []
        for e in reversed(sc.effects):
            rest = tuple(x for x in sc.effects if x != e)
            v = {k: x for k, x in sc.values.items() if not k.startswith(e + ".")}
            out.append((e, frozenset(rest), rest, v))
            eff = fx.LIBRARY[e]
            simplers = [x for _, x in eff.reduces_to] + [      # a fitted width's unfaded limit
                next((x for x in options if x in self.model.candidates), None)
                for param, options in eff.widens_to if f"{e}.{param}" not in self.model.held_params]
            for simpler in simplers:
                if simpler is None or simpler in sc.effects:
                    continue
                plain = rest + (simpler,)
                first = fx.LIBRARY[simpler].params[0].name
                out.append((e, frozenset(plain), plain, {**v, f"{simpler}.{first}": sc.values[f"{e}.{eff.params[0].name}"]}))
        return out

    def checks(self, sc: Scored, base: Scored, only: str | None = None) -> list:
        """The keep rule for every effect of `sc` (or only effect `only`) against each model it is
        judged against (`references`): [(effect, that model, failures)]; `sc` is kept only if
        every failure list is empty."""
        ci = self.ci95(sc)
        return [self.check(sc, e, self.fits[key], base, ci) for e, key, _, _ in self.references(sc)
                if only is None or e == only]

    def check(self, sc: Scored, e: str, ref: Scored, base: Scored, ci: dict | None = None) -> tuple:
        """(e, ref, the keep rule's failures of effect `e` of `sc` against `ref`, `sc` without it)."""
        as_last = sc.reordered(e)
        self.score(as_last, ref)
        return e, ref, self.failures(as_last, ref, base, ci)

    def _next_beam(self, children: list, best: Scored) -> list:
        """The grown models of lowest BIC that clearly improve on their parent, and `best` if it
        is of this size (its own extensions are the greedy path's)."""
        size = len(children[0].effects)
        beam = [sc for sc in children if sc.delta_bic < -self.s.bic_min][: self.s.beam_width]
        if len(best.effects) == size and all(sc is not best for sc in beam):
            beam.append(best)
        return beam

    # ---- what the report reads ---------------------------------------------------------------
    def _round_info(self, children: list, judged: dict, best: Scored, base: Scored, sidelined: dict) -> list:
        """One entry per grown model (details.json "rounds"): its scores against its parent and,
        if it was judged, the keep rule's decision for each of its effects."""
        out = []
        for sc in children:
            newest = sc.effects[-1]
            keys = effect_keys((newest,))
            parent = self.fits[frozenset(sc.parent)]
            info = dict(effect=newest, set=sorted(sc.effects), parent=sorted(sc.parent), rmse=sc.rmse,
                        cv_rmse=sc.cv_rmse, delta_bic=sc.bic - bic_on(parent, sc), rho1=sc.rho1,
                        explained=self.explained(sc, parent), params={k: sc.values[k] for k in keys})
            checks = judged.get(id(sc))
            if checks is None:
                why = ("does not beat the best model kept so far on BIC" if sc.bic >= best.bic or sc is best
                       else "not among the best judged")
                info.update(qualifies=False, reason=why, failed=["screened"])
            else:
                info.update(_decision(self, sc, parent, checks))
                if id(sc) in sidelined:     # passes the keep rule, not chosen over a smaller model
                    info.update(reason=sidelined[id(sc)], sidelined=True)
            info["kept"] = False
            out.append(info)
        return out

    def _result(self, base: Scored, final: Scored, steps: list, alternatives: dict, timings: dict,
                t_start: float) -> Diagnosis:
        """The final model scored against the baseline, its intervals, verdict and timings."""
        chosen = list(final.effects)
        drop = {}
        if chosen:
            self.validate([final])
            for e, ref, _ in self.checks(final, base):
                if ref.key == final.key - {e}:
                    drop[e] = final.reordered(e).bic - bic_on(ref, final)
            self.score(final, base)
        ci, profiles = profiled_ci95(self, final) if chosen else ({}, {})
        verdict = self.verdict(base, final, chosen)
        timings["total_s"] = time.perf_counter() - t_start
        timings["simulations"] = self.engine.n_sims
        timings["batched_calls"] = self.engine.n_calls
        return Diagnosis(prep=self.prep, model=self.model, settings=self.s, baseline=base, final=final,
                         chosen=chosen, steps=steps, ci95=ci, verdict=verdict, noise=self.prep.noise,
                         timings=timings, folds=self.folds, drop_bic=drop, alternatives=alternatives, profiles=profiles)

    def verdict(self, base: Scored, final: Scored, chosen) -> str:
        return self.s.verdict(bool(chosen), base.rmse, final.rmse, base.rho1, self.prep.fit_noise)


def _decision(sel: Selector, sc: Scored, parent: Scored, checks: list) -> dict:
    """The keep rule's decision on a judged model for the round's table: the newest effect's
    statistics against its parent, and the first failure of any effect (or "kept")."""
    newest = sc.effects[-1]
    ci = sel.ci95(sc)
    failed, reason = [], "every effect passes the keep rule"
    for e, ref, fails in checks:
        for name, why in fails:
            if name not in failed:
                failed.append(name)
        if fails and reason.startswith("every"):
            if ref.key == sc.key - {e}:
                reason = fails[0][1] if e == newest else f"{e} is not needed beside the others: {fails[0][1]}"
            else:
                simpler = "+".join(sorted(ref.key - sc.key))
                reason = f"{e} does not earn its keep against {simpler}: {fails[0][1]}"
    return dict(qualifies=not failed, reason=reason, failed=failed, heldout_gain=sel.heldout_gain(sc, parent),
                ci95={k: list(ci[k]) for k in effect_keys((newest,))})


def mark_kept(steps: list, final: Scored) -> None:
    """Mark, in every round, the grown model that is the final one or part of it (the path)."""
    chosen = set(final.effects)
    for step in steps:
        for info in step:
            info["kept"] = bool(info.get("qualifies")) and set(info["set"]) <= chosen


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


def diagnose_prepared(prep: Prepared, settings: Settings | None = None, log=None,
                      model: ReducedModel | None = None) -> Diagnosis:
    """Run the selection on a prepared recording (against `model`, default: the kind's baseline)."""
    return run_with_sensor_lag(Selector(prep, model=model, settings=settings, log=log))
