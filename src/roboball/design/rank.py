"""Rank the experiments of a choice by how clearly its candidates would differ in the recording.

For candidates A and B and an experiment (its releases R, each left to settle for d seconds),
with the difference of their predictions D(t) at their fitted values, the variance of each
over its parameter draws, and the log's own noise sigma:

    expected chi^2 gap   G = sum over the samples of D^2 / (sigma^2 + var_A + var_B)
    separation           s = sqrt(G / n)     (RMS of D in noise levels, the uncertainty included)

G is the expected gap in BIC between the two explanations when one of them is true and the
recording is diagnosed with the user's (both have the same number of parameters); s is what
a person reads off a plot: how many noise levels apart the curves are.  With more than two
candidates, an experiment settles the choice as well as it separates its closest pair.  An
experiment `settles` a choice when s is at least `SETTLES` = 2 noise levels, the diagnosis's own
materiality (a mean-square change of 4 noise variances, docs/diagnosis.md).
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from roboball.design.experiments import SETTLE_FACTORS, Grid, user_timing

SETTLES = 2.0           # noise levels: the diagnosis's materiality (RMS of two noise levels)
KEEP = 40               # experiments kept per choice in design.json (the best by G)


@dataclass
class Scores:
    """Per release and settle duration, the sums that make G and s for the closest pair."""

    gap: np.ndarray         # (S, W) sum D^2 / (sigma^2 + var)
    sq: np.ndarray          # (S, W) sum D^2 (rad^2)
    n: np.ndarray           # (S, W) samples counted per release (while the body moves)
    durations: np.ndarray   # (S,) s
    pair: list              # (S, W) -> the closest pair's labels


def scores(g: Grid, noise: float, window_s: float, factors=SETTLE_FACTORS) -> Scores:
    """Per (settle duration, release) the closest pair's sums (module docstring)."""
    durations = np.array([f * window_s for f in factors])
    labels = list(g.central)
    S, W = len(durations), len(g.releases)
    gap = np.full((S, W), np.inf)
    sq = np.zeros((S, W))
    pair = [[None] * W for _ in range(S)]
    within = [g.moving & (g.t <= d + 1e-9)[None, :] for d in durations]
    ns = np.array([np.maximum(m.sum(axis=1), 1) for m in within])
    for a, b in itertools.combinations(labels, 2):
        d2 = (g.central[a] - g.central[b]) ** 2
        z = d2 / (noise ** 2 + g.var[a] + g.var[b])
        for i, m in enumerate(within):
            gi, si = (z * m).sum(axis=1), (d2 * m).sum(axis=1)
            # a candidate that diverges at a release (NaN or inf) says nothing there: no separation
            bad = ~(np.isfinite(gi) & np.isfinite(si))
            gi, si = np.where(bad, 0.0, gi), np.where(bad, 0.0, si)
            for w in range(W):
                if gi[w] < gap[i, w]:
                    gap[i, w], sq[i, w], pair[i][w] = gi[w], si[w], (a, b)
    return Scores(gap, sq, ns, durations, pair)


def same_experiment(a: dict, b: dict) -> bool:
    """Whether two ranked experiments are the same recording (releases, settle, steer clamp, ramp)."""
    return all(a.get(k) == b.get(k) for k in ("release_rad", "settle_s", "steer_joint", "ramp_angle_deg"))


def experiments(src, choice, g: Grid, rest: float) -> list:
    """The ranked experiments of `choice` on grid `g`: one release or two in one recording, each
    settling the user's window or longer, feasible ones only; best (largest G) first."""
    dt, window_s = user_timing(src.prep)
    sc = scores(g, src.noise, window_s)
    ok = np.nonzero(g.feasible)[0]
    rows = []
    for i in range(len(sc.durations)):
        for k in (1, 2):
            for combo in itertools.combinations(ok, k):
                rows.append(_entry(src, choice, g, sc, i, combo, rest, dt))
    rows.sort(key=lambda r: (-r["expected_chi2_gap"], r["recording_s"]))
    return rows


def _entry(src, choice, g: Grid, sc: Scores, i: int, combo, rest: float, dt: float) -> dict:
    gap = float(sum(sc.gap[i, w] for w in combo))
    sq = float(sum(sc.sq[i, w] for w in combo))
    n = int(sum(sc.n[i, w] for w in combo))
    rel = [float(g.releases[w]) for w in combo]
    entry = {"kind": src.kind, "release_rad": [round(r, 4) for r in rel],
             "release_from_rest_rad": [round(r - rest, 4) for r in rel],
             "settle_s": round(float(sc.durations[i]), 3), "recording_s": round(len(combo) * float(sc.durations[i]), 3),
             "sample_interval_s": round(dt, 6), "pressure_kpa": src.prep.recording.pressure_kpa}
    if src.kind == "shell_rock":
        entry["steer_joint"] = g.steer_joint
    rms = (sq / n) ** 0.5
    entry.update({"choice": choice.name, "candidates": [c.label for c in choice.candidates],
                  "closest_pair": list(sc.pair[i][combo[0]]),
                  "separation": round((gap / n) ** 0.5, 4), "refitted": False,
                  "separation_predicted": round((gap / n) ** 0.5, 4),
                  "separation_fixed_params": round(rms / src.noise, 4),
                  "rms_difference_rad": round(rms, 6),
                  "separation_vs_residual": round(rms / src.residual, 4),
                  "expected_chi2_gap": round(gap, 2)})
    entry["settles"] = entry["separation"] >= SETTLES
    entry["rolls_over"] = sorted(c for c, r in g.runaway.items() if any(r[w] for w in combo))
    return entry
