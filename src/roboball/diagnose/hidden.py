"""Choosing the starts of the hidden release states (a free pendulum's steer joint under a shell
log, roboball.reduced.shell_steer) that the grids of starts try (Engine.hidden_variants,
Engine.best_starts, roboball.diagnose.select).

The model's `hidden_starts` are points of the unobserved state at a release (the pendulum at rest
and swinging at three amplitudes in eight phases: 25).  The windows are independent: a release's
hidden state changes only that release's simulation, so each window's best start can be chosen
on its own.  For a parent's values every start is simulated in every window once (one batched
call), the starts are ranked per window by that window's cost, and variant i puts in each window
that window's i-th best start.  Putting the same point in every window instead (as before) needs
all 25 variants, and a grid tried on each of them, to hold each window's best start somewhere,
and still leaves out the combinations of different points that releases of different swings need
(one release with the pendulum at rest, the next with it swinging).

With several releases the `K_SEVERAL` best per window are kept: the grids then cost K / 25 of
theirs.  With one release every start is kept, in `hidden_starts`' order without the ranking's
simulation: the very grids (same candidates, same order) as before, so the same answer to the bit.
"""
from __future__ import annotations

import numpy as np

K_SEVERAL = 7          # variants kept when the recording has several releases


def chosen_starts(engine, values_list: list) -> list:
    """For each of `values_list` (dicts of values), the copies of it with the model's hidden
    release states at chosen starts (module docstring; with several releases the best first, with
    one in the model's order): a list per entry, empty when the model has no hidden states.  One
    batched simulation for all entries; the choice is cached on the engine by the values, so a
    parent's is made once."""
    if not engine.hidden:
        return [[] for _ in values_list]
    starts = engine.model.hidden_starts()
    wins = list(engine.windows)
    cache = engine.hidden_cache
    keys = [_key(v) for v in values_list]
    todo = {}
    for key, v in zip(keys, values_list):
        if key not in cache and key not in todo:
            todo[key] = v
    if len(wins) == 1:
        order = np.arange(len(starts))[:, None]                 # (rank, window) -> start
        for key in todo:
            cache[key] = order
    elif todo:
        items = [(_with(v, point, wins), w) for v in todo.values() for point in starts for w in wins]
        outs = engine.predict(items)
        n_s, n_w = len(starts), len(wins)
        for j, key in enumerate(todo):
            costs = np.empty((n_s, n_w))
            for i in range(n_s):
                for k, w in enumerate(wins):
                    y = outs[(j * n_s + i) * n_w + k][0]
                    with np.errstate(over="ignore", invalid="ignore"):
                        costs[i, k] = float(np.sum((y - engine.windows[w].y) ** 2))
            costs[~np.isfinite(costs)] = np.inf
            cache[key] = np.argsort(costs, axis=0, kind="stable")[:K_SEVERAL]
    out = []
    for key, v in zip(keys, values_list):
        order = cache[key]
        out.append([_with(v, {name: {w: starts[order[r, k]][name] for k, w in enumerate(wins)}
                              for name in starts[0]}, wins) for r in range(order.shape[0])])
    return out


def _with(values: dict, point: dict, wins: list) -> dict:
    """`values` with each hidden state `name` of `point` set in every window: point[name] is a
    value (the same in every window) or {window: value}."""
    v = dict(values)
    for name, x in point.items():
        v.update({f"{name}@{w}": float(x[w] if isinstance(x, dict) else x) for w in wins})
    return v


def _key(values: dict) -> tuple:
    return tuple(sorted(values.items()))
