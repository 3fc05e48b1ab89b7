"""Fitting by simulation error, many problems at once.

A *problem* is one least-squares fit: a set of effects added to the baseline, the parameters to
fit (baseline parameters such as the stand's viscous coefficient, the effects' parameters and the
release state of every release: value q0@i and instant shift ts@i, those of the model's
`release_params`) and which samples count (all of them for the full fit; all but a held-out
release or block for cross-validation).  The cost is the sum of squared differences between the
recording and the reduced model SIMULATED from each release over the whole free response, not a
regression on differentiated data (which noise ruins).

`Engine.fit` runs Levenberg-Marquardt on a list of problems together: every iteration, the
trial points of all unfinished problems and their finite-difference perturbations are simulated
in ONE batched call of the reduced model (`roboball.reduced`), so the per-step Python
cost is shared by hundreds of simulations.  The derivative with respect to a release instant is
analytic (minus the simulated rate), the others are forward differences.  Steps are bounded by
the parameters' physical bounds (roboball.physics.effects).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from roboball.physics import effects as fx
from roboball.diagnose.bounded import applies as bounded_grid, best_costs
from roboball.diagnose.data import Prepared
from roboball.diagnose.hidden import chosen_starts
from roboball.diagnose.sensor import LAG_BOUNDS, LAG_KEY, LAG_TYPICAL, lag_grid, lag_of
from roboball.reduced.base import DT, ReducedModel
from roboball.reduced.compiled import sample_outputs

Q0_BOUND = 0.1        # rad: release value may move this far from the hold level
FD_REL = 0.01         # forward-difference step, in units of the parameter's typical size
DIVERGED = 1e3        # value given to a simulation that blew up
SPLIT_MIN = 2000      # batches at least this large are simulated window by window (Engine.predict)
PROJECT_PASSES = 3    # solves per step that hold parameters at the bounds their step would leave


def effect_keys(effects, held=()) -> list:
    """The parameter keys ("effect.param") of `effects`, less those the model holds (`held`)."""
    return [f"{name}.{p.name}" for name in effects for p in fx.LIBRARY[name].params
            if f"{name}.{p.name}" not in held]


@dataclass
class Problem:
    """One fit.  `values` holds every parameter (free ones are starting values); `free` the
    keys to fit; `masks` maps window index -> boolean mask of the samples in the cost."""

    effects: tuple
    values: dict
    free: list
    masks: dict
    tag: object = None
    # results
    cost: float = math.inf
    rss: float = math.inf
    n: int = 0
    J: np.ndarray | None = None
    pred: dict = field(default_factory=dict)      # window -> predicted y (all samples)
    iterations: int = 0
    converged: bool = False
    max_iter: int | None = None      # per-problem limit (else the fit call's)

    @property
    def k(self) -> int:
        return len(self.free)

    def clone(self, **kw) -> "Problem":
        p = Problem(effects=tuple(kw.get("effects", self.effects)), values=dict(kw.get("values", self.values)),
                    free=list(kw.get("free", self.free)), masks=dict(kw.get("masks", self.masks)),
                    tag=kw.get("tag", self.tag))
        return p


class Engine:
    """Batched simulation and Levenberg-Marquardt for one prepared recording and model."""

    def __init__(self, model: ReducedModel, prep: Prepared, dt: float = DT):
        self.model, self.prep, self.dt = model, prep, dt
        self.windows = {w.index: w for w in prep.windows}
        self.p_keys = [b.name for b in model.base_params] + effect_keys(model.candidates)
        self.info = {}
        for b in model.base_params:
            self.info[b.name] = (b.typical, b.lo, b.hi)
        # each effect parameter's value where a batch member does not set it: the model's held
        # value, else the parameter's default (0 for a magnitude: the effect is absent)
        self.defaults = {}
        for name in model.candidates:
            for p in fx.LIBRARY[name].params:
                key = f"{name}.{p.name}"
                self.defaults[key] = float(model.held_params.get(key, p.default))
                self.info[key] = ((p.typical, p.lo, p.hi) if key not in model.held_params
                                  else (p.typical, self.defaults[key], self.defaults[key]))
        # How far a fitted release instant may move from the release finder's (s; 0 for a model
        # that fits no instant): bounds the fit and lengthens every simulation by as much.
        self.max_shift = model.ts_bound if "t_shift" in model.release_params else 0.0
        # release states of coordinates the recording does not observe (a free pendulum's steer
        # joint under a shell log): fitted per release like q0, passed to the model by name
        self.hidden = tuple(model.hidden_release)
        # each window's own experiment settings (a pooled ramp run's angle), passed per row
        self.window_values = {w.index: model.window_values(w) for w in prep.windows}
        self.hidden_cache: dict = {}     # values -> the starts chosen per release (diagnose.hidden)
        for w in prep.windows:
            self.info[f"q0@{w.index}"] = (0.01, w.q0 - Q0_BOUND, w.q0 + Q0_BOUND)
            if "t_shift" in model.release_params:
                self.info[f"ts@{w.index}"] = (0.01, -self.max_shift, self.max_shift)
            for h in self.hidden:
                self.info[f"{h.name}@{w.index}"] = (h.typical, h.lo, h.hi)
        # the sensor's own parameters (their values: starts of the fits where free) when the
        # recording calls for them (roboball.diagnose.sensor_fit); none: predictions are compared
        # as simulated
        self.sensor: dict = {}
        self.sensor_free: list = []
        self.info[LAG_KEY] = (LAG_TYPICAL, *LAG_BOUNDS)
        self.diverged = DIVERGED
        self.n_sims = 0
        self.n_calls = 0
        self.sim_time = 0.0

    # ---- starting values -------------------------------------------------------------------
    def _release_state(self, w) -> dict:
        """The fitted release state of window `w` (those of the model's `release_params`) with its
        starting values: the hold level and no shift of the detected instant."""
        start = {"q0": (f"q0@{w.index}", w.q0), "t_shift": (f"ts@{w.index}", 0.0)}
        out = dict(start[p] for p in ("q0", "t_shift") if p in self.model.release_params)
        out.update((f"{h.name}@{w.index}", h.start) for h in self.hidden)
        return out

    def initial_values(self) -> dict:
        v = {b.name: b.start for b in self.model.base_params}
        for w in self.prep.windows:
            v.update(self._release_state(w))
        v.update(self.sensor)
        return v

    def release_keys(self, windows=None) -> list:
        return [k for w in self.prep.windows if windows is None or w.index in windows
                for k in self._release_state(w)]

    # ---- batched prediction ----------------------------------------------------------------
    def predict(self, items, dt: float | None = None):
        """items: list of (values, window index).  Returns a list of (y, ydot) at the window's
        samples for each item, from one batched simulation (with step `dt`, default the fits').

        A batch of at least `SPLIT_MIN` items is simulated window by window, each for its own
        window's duration rather than the longest one's: rows are independent, so every row's
        numbers are the same (to the last bit of NumPy's vectorised exp and tanh, which may round
        by an element's place in the array), the grids of starts cost about a sixth less, and
        smaller batches (a screening fit's ~800 rows) keep the one call: split, their per-step
        Python cost would grow more than their arithmetic shrinks."""
        B = len(items)
        if B == 0:
            return []
        dt = dt or self.dt
        wins = np.fromiter((w for _, w in items), int, B)
        groups = ([np.arange(B)] if B < SPLIT_MIN else [np.nonzero(wins == w)[0] for w in np.unique(wins)])
        out = [None] * B
        for rows in groups:
            for b, result in zip(rows, self._simulate([items[r] for r in rows], dt)):
                out[b] = result
        self.n_calls += 1
        return out

    def batch_arrays(self, items):
        """The model's parameters by name, the release values and the instants' shifts of
        `items` ((values, window) each), as arrays over the batch."""
        B = len(items)
        P = {k: np.fromiter((v.get(k, d) for v, _ in items), float, B)
             for k, d in ((k, self.defaults.get(k, 0.0)) for k in self.p_keys)}
        q0 = np.fromiter((v.get(f"q0@{w}", self.windows[w].q0) for v, w in items), float, B)
        ts = np.fromiter((v.get(f"ts@{w}", 0.0) for v, w in items), float, B)
        for h in self.hidden:
            P[h.name] = np.fromiter((v.get(f"{h.name}@{w}", h.start) for v, w in items), float, B)
        for key in self.model.window_keys:
            P[key] = np.fromiter((self.window_values[w][key] for _, w in items), float, B)
        return P, q0, ts

    def _simulate(self, items, dt: float):
        """(y, ydot) at each item's window samples from one batched simulation of `items`."""
        B = len(items)
        P, q0, ts = self.batch_arrays(items)
        lag = np.fromiter((lag_of(v) for v, _ in items), float, B) if self.sensor else None
        horizon = max(self.windows[w].duration for _, w in items) + self.max_shift + 0.05
        n_steps = int(math.ceil(horizon / dt)) + 1
        t0 = time.process_time()
        with np.errstate(all="ignore"):      # a row asked twice is simulated once
            Y, Yd, simulated = self.model.simulate_distinct(q0, P, n_steps, dt)
        # A diverging candidate (e.g. a strongly softening stiffness) gets a huge but finite
        # residual, so the fit rejects it instead of propagating NaN.
        bad = ~np.isfinite(Y)
        if bad.any():
            Y[bad] = DIVERGED
            Yd[bad] = 0.0
        Yd[~np.isfinite(Yd)] = 0.0
        if lag is not None:             # as the lagging sensor reports it (roboball.diagnose.sensor)
            swinging = np.fromiter((self.windows[w].start == "turning point" for _, w in items), bool, B)
            Y, Yd = lag_grid(Y, Yd, dt, lag, swinging)
            # a diverged run's huge values can come out of the filter as inf - inf = NaN; a NaN
            # residual would compare false with every cost, and a grid start or a fit stuck on
            # it never leaves it (a cubic stiffness started at -70 N m/rad^3 in a lagged fit)
            bad = ~np.isfinite(Y)
            if bad.any():
                Y[bad] = DIVERGED
                Yd[bad] = 0.0
            Yd[~np.isfinite(Yd)] = 0.0
        self.sim_time += time.process_time() - t0
        self.n_sims += simulated
        out = [None] * B
        wins = np.fromiter((w for _, w in items), int, B)
        for w in np.unique(wins):
            cols = np.nonzero(wins == w)[0]
            win = self.windows[int(w)]
            tau = (win.t - win.t0)[None, :] - ts[cols][:, None]
            y, yd = sample_outputs(Y, Yd, dt, tau, cols)
            # seen as the recording's window is (a ramp's averaged trend; identity elsewhere)
            y, yd = win.observe(y), win.observe(yd)
            for j, b in enumerate(cols):
                out[b] = (y[j], yd[j])
        return out

    # ---- Levenberg-Marquardt -------------------------------------------------------------
    def _items_for(self, prob: Problem, values: dict):
        """Batch items for the residual and finite-difference Jacobian at `values`."""
        items, plan = [], []
        used = [w for w, m in prob.masks.items() if np.any(m)]
        base = {}
        for w in used:
            base[w] = len(items)
            items.append((values, w))
        steps = {}
        for key in prob.free:
            typ, lo, hi = self.info[key]
            if key.startswith("ts@"):
                continue
            h = FD_REL * typ
            if values[key] + h > hi:
                h = -h
            pv = dict(values)
            pv[key] = values[key] + h
            steps[key] = h
            if "@" in key:              # a release state: only its own window moves
                w = int(key.split("@")[1])
                plan.append((key, w, len(items)))
                items.append((pv, w))
            else:
                for w in used:
                    plan.append((key, w, len(items)))
                    items.append((pv, w))
        return items, base, plan, steps, used

    def _assemble(self, prob: Problem, values, outs, base, plan, steps, used):
        cols = {k: j for j, k in enumerate(prob.free)}
        offsets = {}
        n = 0
        for w in used:
            m = prob.masks[w]
            offsets[w] = (n, n + int(m.sum()))
            n += int(m.sum())
        r = np.empty(n)
        J = np.zeros((n, len(prob.free)))
        pred = {}
        for w, b in base.items():
            y, yd = outs[b]
            pred[w] = y
            if w in offsets:
                a, e = offsets[w]
                m = prob.masks[w]
                r[a:e] = (y - self.windows[w].y)[m]
                key = f"ts@{w}"
                if key in cols:
                    J[a:e, cols[key]] = -yd[m]
        for key, w, b in plan:
            if w not in offsets:
                continue
            a, e = offsets[w]
            m = prob.masks[w]
            J[a:e, cols[key]] = (outs[b][0][m] - pred[w][m]) / steps[key]
        J[~np.isfinite(J)] = 0.0
        return r, J, pred

    def evaluate(self, problems, values_list):
        """Residuals, Jacobians and predictions for each (problem, values) in one batch."""
        all_items, meta = [], []
        for prob, values in zip(problems, values_list):
            items, base, plan, steps, used = self._items_for(prob, values)
            off = len(all_items)
            all_items.extend(items)
            meta.append((off, len(items), base, plan, steps, used))
        outs = self.predict(all_items)
        res = []
        for prob, values, (off, n_items, base, plan, steps, used) in zip(problems, values_list, meta):
            o = outs[off:off + n_items]
            res.append(self._assemble(prob, values, o, base, plan, steps, used))
        return res

    def fit(self, problems, max_iter: int = 30, rtol: float = 1e-3, max_rejects: int = 3, verbose: bool = False):
        """Levenberg-Marquardt on every problem, batched.  Results are stored on the problems.

        A problem stops when an accepted step lowers the cost by less than `rtol` (relative),
        after `max_rejects` rejected steps in a row (the dry-friction laws make the cost
        slightly rough at the scale of a stick event, so the last digits are noise), or after
        `max_iter` iterations."""
        todo = [p for p in problems if p.free]
        for p in problems:
            if not p.free:
                (r, J, pred), = self.evaluate([p], [p.values])
                p.rss, p.cost, p.J, p.pred, p.n, p.converged = float(r @ r), 0.5 * float(r @ r), J, pred, len(r), True
        if not todo:
            return problems
        results = self.evaluate(todo, [p.values for p in todo])
        state = {}
        for p, (r, J, pred) in zip(todo, results):
            p.rss, p.cost, p.J, p.pred, p.n = float(r @ r), 0.5 * float(r @ r), J, pred, len(r)
            state[id(p)] = dict(r=r, lam=1e-3, rejects=0)
        active = list(todo)
        for it in range(max_iter):
            if not active:
                break
            trials = [self._lm_trial(p, state[id(p)]) for p in active]
            results = self.evaluate(active, trials)
            still = []
            for p, nv, result in zip(active, trials, results):
                if self._lm_update(p, nv, result, state[id(p)], rtol, max_rejects, verbose, it):
                    still.append(p)
            active = still
        return problems

    def _lm_trial(self, p: Problem, st: dict) -> dict:
        """The damped Gauss-Newton step of `p` from its current values (state `st`: residual r,
        damping lam), in units of the parameters' typical sizes, projected on the bounds.

        A parameter at a bound whose step would leave it is held there and the step is solved
        for the others (at most `PROJECT_PASSES` times): a step clipped after the solve is no
        descent direction for the rest, is rejected, and after `max_rejects` of them the fit
        stops short of the optimum (a release instant at its bound held the real shell log's
        damping + stiffness + offset fit at an RMS of 0.035 rad instead of 0.030)."""
        scale = np.array([self.info[k][0] for k in p.free])
        lo = np.array([self.info[k][1] for k in p.free])
        hi = np.array([self.info[k][2] for k in p.free])
        x = np.array([p.values[k] for k in p.free], dtype=float)
        Js = p.J * scale
        A = Js.T @ Js
        g = Js.T @ st["r"]
        d = np.maximum(np.diag(A), 1e-12 * max(np.max(np.diag(A)), 1e-300))
        free = np.ones(len(x), bool)
        for _ in range(PROJECT_PASSES):
            du = self._damped_step(A, g, d, st["lam"], free)
            held = free & (((x <= lo) & (du < 0)) | ((x >= hi) & (du > 0)))
            if not held.any():
                break
            free &= ~held
        nv = dict(p.values)
        for j, k in enumerate(p.free):
            nv[k] = float(np.clip(x[j] + du[j] * scale[j], lo[j], hi[j]))
        return nv

    @staticmethod
    def _damped_step(A, g, d, lam: float, free) -> np.ndarray:
        """The Levenberg-Marquardt step (A + lam diag(d)) du = -g on the `free` parameters (0 elsewhere)."""
        du = np.zeros(len(g))
        idx = np.nonzero(free)[0]
        try:
            du[idx] = np.linalg.solve(A[np.ix_(idx, idx)] + lam * np.diag(d[idx]), -g[idx])
        except np.linalg.LinAlgError:
            du[idx] = -g[idx] / (d[idx] * (1 + lam))
        if not np.all(np.isfinite(du)):
            du = np.zeros_like(du)
        return du

    def _lm_update(self, p: Problem, nv: dict, result, st: dict, rtol: float, max_rejects: int,
                   verbose: bool, it: int) -> bool:
        """Accept the trial values `nv` (evaluated: `result`) if they lower the cost, else raise
        the damping; returns whether `p` goes on iterating."""
        r, J, pred = result
        p.iterations += 1
        if p.max_iter is not None and p.iterations >= p.max_iter:
            p.converged = True
        with np.errstate(over="ignore", invalid="ignore"):   # a diverged trial step: rejected below
            rss = float(r @ r)
        if not math.isfinite(rss):
            rss = math.inf
        if verbose:
            print(f"  it {it} {p.effects} rss {p.rss:.6g} -> {rss:.6g} lam {st['lam']:.2g}")
        if rss < p.rss:
            gain = (p.rss - rss) / max(p.rss, 1e-300)
            p.values, p.rss, p.cost, p.J, p.pred, p.n = nv, rss, 0.5 * rss, J, pred, len(r)
            st["r"] = r
            st["lam"] = max(st["lam"] / 3.0, 1e-9)
            st["rejects"] = 0
            if gain < rtol:
                p.converged = True
                return False
        else:
            st["lam"] *= 6.0
            st["rejects"] += 1
            if st["lam"] > 1e7 or st["rejects"] >= max_rejects:
                p.converged = True
                return False
        return not p.converged

    # ---- grid starts ---------------------------------------------------------------------
    def hidden_variants(self, values: dict) -> list:
        """Copies of `values` with the unobserved release states (model.hidden_release) at starts
        chosen per release from the model's `hidden_starts` (roboball.diagnose.hidden): a free
        pendulum's state at the release has to be searched for, fits from a wrong swing phase end
        in local minima.  Empty when the model has none."""
        return chosen_starts(self, [values])[0]

    def best_of(self, prob: Problem, candidates: list) -> dict:
        """The candidate values of lowest cost over the problem's samples (one batched run)."""
        used = [w for w, m in prob.masks.items() if np.any(m)]
        outs = self.predict([(v, w) for v in candidates for w in used])
        costs = self._costs(outs, 0, len(candidates), used, prob)
        return dict(candidates[int(np.argmin(costs))])

    def _costs(self, outs, start: int, n: int, used: list, prob: Problem) -> np.ndarray:
        """Cost over the problem's samples of each of `n` candidates whose runs, window by window
        (`used`), sit in `outs` from `start`; a run sent far off (finite but ~1e160) or to NaN
        costs inf, which argmin skips."""
        costs = np.zeros(n)
        with np.errstate(over="ignore"):
            for i in range(n * len(used)):
                w = used[i % len(used)]
                m = prob.masks[w]
                costs[i // len(used)] += float(np.sum((outs[start + i][0] - self.windows[w].y)[m] ** 2))
        costs[~np.isfinite(costs)] = np.inf
        return costs

    def best_starts(self, probs_effects):
        """Best grid start of each (problem, effect, base) in one batched simulation.

        `base` is a dict of values or a list of such dicts (variants); every grid value of the
        effect's parameters (roboball.physics.effects.Param.grid_values) is tried on every
        variant, and the values with the lowest cost over the problem's samples are returned
        (with their cost under the key "_cost")."""
        all_items, spans = [], []
        for prob, effect, bases in probs_effects:
            if isinstance(bases, dict):
                bases = [bases]
            eff = fx.LIBRARY[effect]
            held = self.model.held_params
            grids = [[self.defaults[f"{effect}.{p.name}"]] if f"{effect}.{p.name}" in held else p.grid_values()
                     for p in eff.params]
            combos = [[]]
            for g in grids:
                combos = [c + [x] for c in combos for x in g]
            cands = []
            for base_values in bases:
                for c in combos:
                    v = dict(base_values)
                    for p, x in zip(eff.params, c):
                        v[f"{effect}.{p.name}"] = float(np.clip(x, p.lo, p.hi))
                    cands.append(v)
            used = [w for w, m in prob.masks.items() if np.any(m)]
            start = len(all_items)
            all_items.extend((v, w) for v in cands for w in used)
            spans.append((start, cands, used, prob))
        if bounded_grid(self):       # hopeless starts are not simulated to the end (diagnose.bounded)
            every = best_costs(self, all_items, spans)
        else:
            outs = self.predict(all_items)
            every = [self._costs(outs, start, len(cands), used, prob) for start, cands, used, prob in spans]
        best = []
        for (start, cands, used, prob), costs in zip(spans, every):
            j = int(np.argmin(costs))
            best.append(dict(cands[j], _cost=float(costs[j])))
        return best
