"""The best of a grid of starts without simulating every start to the end (Engine.best_starts).

A grid start's cost is a sum of squares over the window's samples, so what a start has
accumulated over the first seconds is a lower bound of its whole cost.  The grid's starts are
simulated together a stretch at a time (`STRETCH_S`); after the stretches `LEADER_STRETCHES` (1,
2, 4 and 8: the bound tightens most early, and a leader's run to the end is a whole window's
simulation) the `LEADERS` starts of lowest cost so far (not yet simulated to the end) are
simulated to the end, and after every stretch each start whose cost so far already exceeds the
best whole cost known is dropped from the later stretches: it cannot be the best.  A start
simulated to the end is not stepped again: its whole cost is known.  (A bound from the first
stretch's leaders alone was 2 to 100 times the grid's best on the real shell log and dropped three
starts in four only at the window's end.)  The starts left at the end get their whole cost the
plain way (Engine.predict, Engine._costs), and the best of all starts costed to the end is the
grid's best, the very start (to the bit, ties to the first) that simulating every start to the
end gives.  Most starts of a grid are hopeless within a second (a magnitude a decade off, a free
pendulum started in the wrong phase of its swing): on the real shell log with the pendulum free,
the grids were 80% of `roboball diagnose`'s time.

Used where the model runs a batch a stretch at a time (a compiled model's `stepper`), the
windows are raw samples and no sensor lag is fitted (a lag filters the whole run; a ramp's trend
averages across stretches): elsewhere every start is simulated to the end.
"""
from __future__ import annotations

import math

import numpy as np

from roboball.reduced.compiled import hermite_at
from roboball.reduced.jitcache import cached_jit

STRETCH_S = 0.5        # s simulated between two prunings
LEADERS = 2            # starts per grid simulated to the end for the bound, after each stretch of:
LEADER_STRETCHES = (1, 2, 4, 8)     # (counted from 1; none after the eighth: 4 s into the window)
MARGIN = 1e-9          # relative: a partial sum rounds otherwise than the whole one


def applies(engine) -> bool:
    """Whether `engine`'s grids can be bounded (module docstring)."""
    model = engine.model
    return (getattr(model, "compiled", False) and hasattr(model, "stepper") and not engine.sensor
            and all(not w.smooth_s for w in engine.prep.windows))


def best_costs(engine, items: list, spans: list) -> list:
    """For each span (start, candidates, windows used, problem) of `items` (values, window), the
    candidates' costs: the exact cost (Engine._costs) of those that could be the best, inf for
    those dropped."""
    owner, first = _owners(items, spans)
    g = sum(len(s[1]) for s in spans)
    partial = np.zeros(g)
    alive = np.ones(g, bool)
    exact = np.full(g, np.nan)
    masks = _item_masks(items, spans)
    runs = [_Run(engine, items, rows, owner, masks) for rows in _by_window(items)]
    bound = np.full(len(spans), math.inf)
    n_stretch = 0
    while any(r.left for r in runs):
        running = alive & np.isnan(exact)           # a start costed to the end is not run again
        for r in runs:
            r.stretch(partial, running)
        n_stretch += 1
        if n_stretch in LEADER_STRETCHES:
            _leaders(engine, items, spans, first, partial, alive, exact, bound)
        for k, (start, cands, used, _) in enumerate(spans):
            sl = slice(first[k], first[k] + len(cands))
            alive[sl] &= ~(partial[sl] > bound[k] * (1.0 + MARGIN))
    todo = [j for j in range(g) if alive[j] and np.isnan(exact[j])]
    _exact(engine, items, spans, first, todo, exact)
    return [np.where(np.isnan(exact[first[k]:first[k] + len(s[1])]), math.inf, exact[first[k]:first[k] + len(s[1])])
            for k, s in enumerate(spans)]


def _owners(items, spans) -> tuple:
    """(item -> its global candidate, span -> its first global candidate): the spans' candidates
    numbered one after another, each item (a candidate in one window) owned by its candidate."""
    owner = np.empty(len(items), dtype=np.int64)
    first = []
    g = 0
    for start, cands, used, _ in spans:
        first.append(g)
        for i in range(len(cands) * len(used)):
            owner[start + i] = g + i // len(used)
        g += len(cands)
    return owner, first


def _by_window(items) -> list:
    wins = np.fromiter((w for _, w in items), int, len(items))
    return [np.nonzero(wins == w)[0] for w in np.unique(wins)]


def _leaders(engine, items, spans, first, partial, alive, exact, bound) -> None:
    """The LEADERS starts of lowest cost so far of each grid, their exact costs, and the bound."""
    picks = []
    for k, (start, cands, used, _) in enumerate(spans):
        idx = np.arange(first[k], first[k] + len(cands))
        idx = idx[alive[idx] & np.isnan(exact[idx])]
        picks += [int(j) for j in idx[np.argsort(partial[idx], kind="stable")[:LEADERS]]]
    _exact(engine, items, spans, first, picks, exact)
    for k, (start, cands, used, _) in enumerate(spans):
        vals = exact[first[k]:first[k] + len(cands)]
        vals = vals[np.isfinite(vals)]
        if vals.size:
            bound[k] = float(vals.min())


def _exact(engine, items, spans, first, cands: list, exact) -> None:
    """Exact costs (Engine.predict + Engine._costs, as without bounds) of global candidates `cands`."""
    if not cands:
        return
    span_of = np.searchsorted(np.asarray(first), np.asarray(cands), side="right") - 1
    batch, where = [], []
    for j, k in zip(cands, span_of):
        start, cs, used, prob = spans[k]
        i = j - first[k]
        where.append((j, len(batch), used, prob))
        batch += [items[start + i * len(used) + u] for u in range(len(used))]
    outs = engine.predict(batch)
    for j, at, used, prob in where:
        exact[j] = engine._costs(outs, at, 1, used, prob)[0]


class _Run:
    """The items of one window, simulated a stretch at a time, their samples' costs accumulated."""

    def __init__(self, engine, items, rows, owner, masks):
        self.diverged = engine.diverged      # as Engine._simulate scores a run that blew up
        self.rows, self.owner = rows, owner[rows]
        w = items[rows[0]][1]
        win = engine.windows[w]
        self.y = win.y
        P, q0, ts = engine.batch_arrays([items[r] for r in rows])
        self.dt = engine.dt
        n_total = int(math.ceil((win.duration + engine.max_shift + 0.05) / self.dt)) + 1
        # as Engine._simulate samples the run (roboball.reduced.compiled.sample_outputs)
        tau = (win.t - win.t0)[None, :] - ts[:, None]
        x = np.clip(tau / self.dt, 0.0, n_total - 1e-9)
        self.cell = np.floor(x).astype(int)
        self.s = x - self.cell
        # a row's cells grow with the sample's time, so a stretch's samples lie in the columns
        # between these two bounds (all rows'; a row dropped later only narrows what is inside)
        self.col_max, self.col_min = self.cell.max(axis=0), self.cell.min(axis=0)
        self.mask = np.array([masks[r] for r in rows])
        self.stepper = engine.model.stepper(q0, P, self.dt)
        self.done, self.n_total = 0, n_total
        self.Y0 = self.Yd0 = None

    @property
    def left(self) -> bool:
        return self.done < self.n_total and self.rows.size > 0

    def stretch(self, partial, running) -> None:
        """Drop the rows of candidates no longer `running` (dropped, or costed to the end), simulate
        one more stretch, add its samples' costs."""
        keep = np.nonzero(running[self.owner])[0]
        if keep.size < self.rows.size:
            self.rows, self.owner = self.rows[keep], self.owner[keep]
            self.cell, self.s, self.mask = self.cell[keep], self.s[keep], self.mask[keep]
            self.stepper.keep(keep)
        if not self.left:
            return
        n = min(int(round(STRETCH_S / self.dt)), self.n_total - self.done)
        Y, Yd = self.stepper.advance(n)
        lo, hi = self.done, self.done + n          # steps lo .. hi: cells lo .. hi - 1
        # only the columns a row's cells can be inside (the same samples, in the same order, as
        # the whole matrix gives: a stretch is a sixteenth of an 8 s window)
        a = int(np.searchsorted(self.col_max, lo, side="left"))
        b = max(a, int(np.searchsorted(self.col_min, hi, side="left")))
        _add_costs(Y, Yd, self.dt, lo, hi, a, b, self.cell, self.s, self.mask, self.y, self.owner,
                   float(self.diverged), partial)
        self.done = hi


def _item_masks(items, spans) -> list:
    """Each item's cost mask: its problem's mask of the item's window."""
    out = [None] * len(items)
    for start, cands, used, prob in spans:
        m = [np.asarray(prob.masks[w], bool) for w in used]
        for i in range(len(cands) * len(used)):
            out[start + i] = m[i % len(used)]
    return out


@cached_jit()
def _add_costs(Y, Yd, dt, lo, hi, a, b, cell, s, mask, y_rec, owner, diverged, partial):
    """Each row's samples whose cells lie in steps lo .. hi - 1 (in columns a .. b - 1 only: a
    row's cells grow with the sample's time), interpolated as Engine._simulate does
    (roboball.reduced.compiled.hermite_at on the steps' values Y and rates Yd, (n + 1, rows)),
    their squared errors added to the row's candidate in `partial`, rows then columns.  Compiled:
    as NumPy expressions, at a grid's thousands of rows, they took a second of the free
    pendulum's diagnosis in one thread."""
    for r in range(cell.shape[0]):
        for c in range(a, b):
            k = cell[r, c]
            if k < lo or k >= hi or not mask[r, c]:
                continue
            y = hermite_at(Y, Yd, k - lo, r, s[r, c], dt)
            if not np.isfinite(y):
                y = diverged
            e = y - y_rec[c]
            partial[owner[r]] += e * e
