"""The common base of the diagnosis's reduced models (stand, shell, ramp), batched over
parameter sets.

The diagnosis fits every candidate effect by SIMULATION error, many parameter sets at a time
(all candidates, all finite-difference perturbations, all releases and cross-validation folds
in one batch).  Each model integrates its experiment's equation of motion for a batch of B
parameter sets at once with NumPy arrays of shape (B,), so the per-step Python overhead is paid
once for the whole batch.  The effect torques come from `roboball.physics.effects`, the same law
functions that the Drake augmented model evaluates symbolically; :class:`ReducedModel` binds them
to the batch.

Models (coordinates measured from the baseline model's rest; robot facts from configs/robot.yaml):
`roboball.reduced.stand.StandModel`, `roboball.reduced.shell.ShellModel`,
`roboball.reduced.ramp.RampModel`; `roboball.reduced.models.model_for` picks one per kind.
Time stepping: `roboball.reduced.integrate` (`midpoint`); output sampling:
`roboball.reduced.compiled.sample_outputs`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from roboball.physics import effects as fx
from roboball.physics.mathns import NP

DT = 2e-3          # s: the models' fixed step (roboball.reduced.integrate, explicit midpoint)
SPARSE_SHARE = 0.5  # an effect active on at most this share of a batch is evaluated on those rows only


def _columns(P: dict, B: int) -> dict:
    """Every parameter of a batch as a float array of its B rows (a scalar repeated)."""
    return {k: np.broadcast_to(np.asarray(v, dtype=float), (B,)) for k, v in P.items()}


@dataclass
class BaseParam:
    """A parameter fitted inside the baseline (never reported as missing physics)."""

    name: str
    unit: str
    lo: float
    hi: float
    typical: float
    start: float


class ReducedModel:
    """Common interface of the reduced models.

    kind, signal (recording column), unit, dof (name used in diagnosis.json), rest (rest value
    of the signal in the model), context (experiment constants for the effect laws),
    base_params (fitted in the baseline), candidates (vocabulary entries that apply), and
    `simulate(q0, P, n_steps, dt) -> (Y, Ydot)`, each (n_steps + 1, B).
    """

    kind: str = ""
    signal: str = ""
    unit: str = "rad"
    dof: str = ""
    rest: float = 0.0
    base_params: tuple = ()
    candidates: tuple = ()
    release_params: tuple = ("q0", "t_shift")
    # BaseParams of release states of coordinates the recording does not show (fitted per
    # release, passed to simulate in P by name; roboball.reduced.shell_steer)
    hidden_release: tuple = ()
    # settings of a window's own experiment the model takes per batch row (passed in P by name,
    # from `window_values`; a ramp run's angle, roboball.reduced.ramp)
    window_keys: tuple = ()
    # a shell release's steer joint: "locked" (the contract's baseline) or "free" (shell_steer)
    steer_joint: str = "locked"
    # rounds of the diagnosis's search run even when a round keeps nothing (roboball.diagnose.select)
    search_rounds: int = 1
    ts_bound: float = 0.1      # s: how far the fitted release instant may move from the finder's
    context: dict = {}
    # effect parameters the model holds at a value instead of fitting them ("effect.param" ->
    # value): a joint's breakaway fades within the creep band (roboball.physics.effects, stiction)
    held_params: dict = {"stiction.v_s": fx.V_STRIBECK}
    description: str = ""
    # run the compiled loop (roboball.reduced.compiled) where the model has one; False: the
    # NumPy loop, its reference (tests compare the two)
    compiled: bool = True

    def window_values(self, window) -> dict:
        """The window's own settings ({key of `window_keys`: value})."""
        return {}

    def hidden_starts(self) -> list:
        """Starting points ({name: value}) of the hidden release states' fits."""
        return [{h.name: h.start for h in self.hidden_release}] if self.hidden_release else []

    def effect_torque(self, q, v, P: dict, active: list):
        """Sum of the active effects' torques (NumPy laws, batch arrays)."""
        return self.bind_effects(P, active)(q, v, np.zeros_like(np.asarray(q, dtype=float)))

    def bind_effects(self, P: dict, active: list):
        """A function add(q, v, tau) that adds the active effects' torques to `tau` in place
        (and returns it), with the parameters bound.

        Each effect is evaluated only on the rows where it is active: a slice when those rows
        form one contiguous block (the diagnosis orders its batches by candidate, so a candidate
        screened alone occupies one block), else their indices when they are at most
        `SPARSE_SHARE` of the batch (a search that grows several models at once scatters each
        effect over the batch), else the whole batch (zero magnitude -> zero torque).  Every row
        gets the same value either way, to the last bit that NumPy's vectorised exp and tanh may
        round differently by an element's place in the array (a stiff stiction row's trajectory
        then moves by up to 1e-6 rad).
        """
        full, part = [], []
        for name, sl in self.effect_plan(P, active):
            eff = fx.LIBRARY[name]
            # a parameter with a value of its own (stiction's width) may be absent: the law's default
            kw = {p.name: np.asarray(P[f"{name}.{p.name}"], dtype=float)[sl if sl is not None else slice(None)]
                  for p in eff.params if f"{name}.{p.name}" in P or not p.optional}
            for key in eff.context:
                kw[key] = self.context[key]
            kw["m"] = NP
            if sl is None:
                full.append((eff.law, kw))
            else:
                part.append((eff.law, sl, kw))

        def add(q, v, tau):
            for law, kw in full:
                tau += law(q, v, **kw)
            for law, sl, kw in part:
                tau[sl] += law(q[sl], v[sl], **kw)
            return tau
        return add

    def effect_plan(self, P: dict, active: list) -> list:
        """The active force effects in the order `bind_effects` adds them, each with the rows it
        is evaluated on: [(name, rows)], rows None (the whole batch: it comes first), a slice or
        an index array (see `bind_effects`).  The compiled loops (roboball.reduced.compiled) add
        the effects in this order too, so that each row's sum is rounded alike."""
        full, part = [], []
        for name in active:
            eff = fx.LIBRARY[name]
            if eff.kind == "inertia":      # no torque: the model adds it to its inertia (bind_inertia)
                continue
            first = np.asarray(P[f"{name}.{eff.params[0].name}"])
            rows = np.nonzero(first != 0.0)[0]
            sl = None
            if rows.size and rows[-1] - rows[0] + 1 == rows.size and rows.size < first.size:
                sl = slice(int(rows[0]), int(rows[-1]) + 1)
            elif rows.size and rows.size <= SPARSE_SHARE * first.size:
                sl = rows
            if sl is None:
                full.append((name, None))
            else:
                part.append((name, sl))
        return full + part

    def distinct_rows(self, q0, P: dict):
        """The distinct rows of a batch: (the first row of each, in batch order; for every row,
        its distinct row's place), or None when no two rows are alike.  Rows are alike when their
        start and every parameter agree bit for bit.  A row's numbers depend on the others only
        through the order in which `effect_plan` adds the effects (whole-batch effects first), so
        the distinct rows are returned only where they keep that order: simulating them and
        copying each result to its duplicates then gives every row's numbers to the bit.  (A
        diagnosis's batches repeat rows: a ramp grid of starts is screened for the pooled fit and
        for each held-out fold, which share most of their windows.)"""
        q0 = np.asarray(q0, dtype=float)
        B = q0.size
        cols = _columns(P, B)
        M = np.empty((B, 1 + len(P)))
        M[:, 0] = q0
        for j, k in enumerate(sorted(P), start=1):
            M[:, j] = cols[k]
        _, first, inverse = np.unique(M.view(np.dtype((np.void, M.itemsize * M.shape[1]))).ravel(),
                                      return_index=True, return_inverse=True)
        if first.size == B:
            return None
        order = np.argsort(first)
        rows = first[order]
        active = active_effects(P, self.candidates)
        sub = {k: v[rows] for k, v in cols.items()}
        if [n for n, _ in self.effect_plan(P, active)] != [n for n, _ in self.effect_plan(sub, active)]:
            return None
        place = np.empty_like(order)
        place[order] = np.arange(order.size)
        return rows, place[inverse.ravel()]

    def simulate_distinct(self, q0, P: dict, n_steps: int, dt: float = DT):
        """`simulate`, each distinct row once (`distinct_rows`): (Y, Ydot) as `simulate` gives
        them for the whole batch, and the number of rows simulated."""
        q0 = np.asarray(q0, dtype=float)
        found = self.distinct_rows(q0, P)
        if found is None:
            return (*self.simulate(q0, P, n_steps, dt), q0.size)
        rows, place = found
        Y, Yd = self.simulate(q0[rows], {k: v[rows] for k, v in _columns(P, q0.size).items()}, n_steps, dt)
        return Y[:, place], Yd[:, place], rows.size

    def bind_inertia(self, P: dict, active: list):
        """The inertia (kg m^2) the active inertia effects add to the coordinate's, one value per
        batch row (zero where inactive), or None when none is active: the model's inertia M
        becomes M + this (roboball.physics.effects.added_inertia)."""
        names = [name for name in active if fx.LIBRARY[name].kind == "inertia"]
        if not names:
            return None
        values = {name: {p: np.asarray(P[f"{name}.{p}"], dtype=float) for p in fx.LIBRARY[name].param_names}
                  for name in names}
        return np.asarray(fx.total_inertia(values), dtype=float)


def active_effects(P: dict, names) -> list:
    """Effects with any non-zero magnitude in the batch (the others cost nothing)."""
    out = []
    for name in names:
        eff = fx.LIBRARY[name]
        first = f"{name}.{eff.params[0].name}"
        if first in P and np.any(np.asarray(P[first]) != 0.0):
            out.append(name)
    return out
