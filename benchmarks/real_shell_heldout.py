"""The held-out test of the real shell log's single release, block by block (issue 24).

    .venv/bin/python benchmarks/real_shell_heldout.py [--log PATH]

For each effect set of the shell's vocabulary that the diagnosis's search reaches on
`../shared/data/roboball_real/dynamic_data.csv`, fitted to the whole release: the fitted RMS
in each of the three 2 s blocks, and the held-out RMS in each block (and pooled) under both
rules for the block that holds the release (roboball.diagnose.crossval):

* `old`: every block predicted by a fit to the other two, the release state included, so the
  first block's state is extrapolated backwards from the later blocks;
* `new`: as `old`, then only the release state refitted on the first block with the fold's model
  frozen (what a held-out release of a multi-release recording gets).

The fold fits are the diagnosis's own (`Selector.cross_validate`, from the full fit).  Also
printed: each block's share of the release's squared swing about its final rest.  About 1 min.
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from roboball.diagnose.data import pool, prepare, read  # noqa: E402
from roboball.diagnose.scored import Scored  # noqa: E402
from roboball.diagnose.select import Selector  # noqa: E402

SETS = (("viscous_damping",), ("rolling_resistance",), ("viscous_damping", "com_offset"),
        ("rolling_resistance", "com_offset"), ("viscous_damping", "linear_stiffness"),
        ("viscous_damping", "linear_stiffness", "com_offset"),
        ("viscous_damping", "linear_stiffness", "com_offset", "cubic_stiffness"),
        ("viscous_damping", "linear_stiffness", "com_offset", "rolling_resistance"),
        ("rolling_resistance", "com_offset", "linear_stiffness"))


def rms(x) -> float:
    return math.sqrt(float(np.mean(np.square(x)))) if len(x) else math.nan


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--log", default=str(ROOT.parent / "shared" / "data" / "roboball_real" / "dynamic_data.csv"))
    args = ap.parse_args(argv)
    sel = Selector(pool([prepare(read(args.log))]))
    w = sel.prep.windows[0]
    blocks = [held[w.index] for _, _, held in sel.folds]
    rest = float(np.mean(w.y[-50:]))
    sq = [float(np.sum((w.y[b] - rest) ** 2)) for b in blocks]
    print("blocks (s from the turning point): "
          + ", ".join(f"{w.t[b][0] - w.t0:.2f}-{w.t[b][-1] - w.t0:.2f}" for b in blocks)
          + "; share of the squared swing: " + ", ".join(f"{s / sum(sq):.2%}" for s in sq))
    new_folds = sel.folds
    old_folds = [(train, None, held) for train, _, held in new_folds]
    base = Scored(effects=(), full=sel.full_problem((), sel.engine.initial_values()))
    sel.engine.fit([base.full], max_iter=sel.s.fit_iter)
    fits = {frozenset(): base}
    print("| effects | fitted RMS | fitted, per block | held out, old rule: per block (pooled) "
          "| held out, new rule: per block (pooled) |")
    print("|---|---|---|---|---|")
    for effects in SETS:
        parent = fits[frozenset(effects[:-1])]
        grown = sel.grow([parent], only={parent.key: [effects[-1]]})[0]
        sc = Scored(effects=tuple(effects), full=grown.full)
        sc.full.converged = False
        sel.engine.fit([sc.full], max_iter=40)
        fits[frozenset(effects)] = sc
        res = sc.full.pred[w.index] - w.y
        cells = []
        for folds in (old_folds, new_folds):
            sel.folds = folds
            sel.cross_validate([sc])
            cv = sc.cv_pred[w.index] - w.y
            cells.append(" / ".join(f"{rms(cv[b]):.4f}" for b in blocks) + f" ({sc.cv_rmse:.4f})")
        print(f"| {' + '.join(effects)} | {sc.rmse:.4f} | " + " / ".join(f"{rms(res[b]):.4f}" for b in blocks)
              + f" | {cells[0]} | {cells[1]} |", flush=True)


if __name__ == "__main__":
    main()
