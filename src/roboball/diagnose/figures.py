"""The report's figures: overlay.png (the recording, the baseline and the augmented model,
both simulated in DRAKE from the fitted release states, with the residual before and after and
the held-out (cross-validated) predictions, so the improvement is shown on data the fit did
not see), regimes.png (the residual by regime) and windows.png (the residual in time, with the
located windows)."""
from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np

from roboball.atomic import savefig_atomic
from roboball.diagnose.crossval import time_blocks
from roboball.diagnose.select import Diagnosis


def write_figures(d: Diagnosis, out: Path, drake_base, drake_aug, located_base, located_final,
                  engine: str = "Drake") -> list:
    """Draw the three figures into `out`; returns their file names.  `engine` names what made
    `drake_base`/`drake_aug` (with --no-drake they are the reduced model's predictions)."""
    import matplotlib
    matplotlib.use("Agg")

    return [_overlay(d, out, drake_base, drake_aug, engine),
            _regimes(d, out, located_base, located_final),
            _windows(d, out, located_base)]


def _save(fig, out: Path, name: str) -> str:
    import matplotlib.pyplot as plt

    fig.tight_layout()
    f = out / name
    savefig_atomic(fig, f, dpi=110)
    plt.close(fig)
    return f.name


def _overlay(d: Diagnosis, out: Path, drake_base, drake_aug, engine: str) -> str:
    import matplotlib.pyplot as plt

    prep = d.prep
    wins = prep.windows
    n = len(wins)
    # layout="none", then tight_layout: these figures look the same whatever layout an importer
    # of matplotlib made the default (roboball.figures.style makes it constrained)
    fig, axes = plt.subplots(2, n, figsize=(5.2 * n, 6.4), squeeze=False, sharex="col", layout="none",
                             gridspec_kw={"height_ratios": [2, 1.3]})
    for j, w in enumerate(wins):
        ax, axr = axes[0, j], axes[1, j]
        _overlay_release(d, ax, axr, w, drake_base, drake_aug, engine)
        if j == 0:
            name = prep.signal.rsplit("_rad", 1)[0].replace("_", " ")     # steer_angle_rad -> steer angle
            ax.set_ylabel(f"{name} ({prep.unit})")
            axr.set_ylabel(f"model - recording ({prep.unit})")
            ax.legend(fontsize=7, loc="best")
            axr.legend(fontsize=7, loc="best")
    # wrapped to the figure's width: a long path and three effects ran off a one-column figure
    title = f"{prep.label}: {d.verdict}" + (f" (+ {', '.join(d.chosen)})" if d.chosen else "")
    fig.suptitle(textwrap.fill(title, width=int(60 * n)), fontsize=10)    # ~60 characters fit 5.2 in at 10 pt
    return _save(fig, out, "overlay.png")


def _overlay_release(d: Diagnosis, ax, axr, w, drake_base, drake_aug, engine: str) -> None:
    """One release's column of the overlay: the signal (`ax`) and the residuals (`axr`)."""
    t = w.t - w.t0
    ax.plot(t, w.y, ".", ms=2.2, color="0.35", label="recording")
    ax.plot(t, drake_base[w.index], color="tab:red", lw=1.0, label=f"baseline ({engine})")
    if d.chosen:
        ax.plot(t, drake_aug[w.index], color="tab:blue", lw=1.0, label=f"augmented ({engine})")
    # a pooled diagnosis cuts its windows from several recordings: name the one each comes from
    # (its window number counts across them)
    pooled = len({id(v.source) for v in d.prep.windows}) > 1 and w.source is not None and w.source.path
    what = f"{Path(w.source.path).stem}: release" if pooled else f"release {w.index + 1}"
    if w.start == "turning point":
        title = f"{what} (let go {w.release.t_release_s:.2f} s), fitted from its first turning point, {w.t0:.2f} s"
    else:
        title = f"{what} at {w.t0:.2f} s"
    ax.set_title(textwrap.fill(title, width=60), fontsize=9)
    axr.plot(t, drake_base[w.index] - w.y, color="tab:red", lw=0.8, label="baseline, fitted")
    if d.chosen:
        axr.plot(t, drake_aug[w.index] - w.y, color="tab:blue", lw=0.8, label="augmented, fitted")
    cvb = d.baseline.cv_pred.get(w.index)
    if cvb is not None and np.any(np.isfinite(cvb)):
        # broad and pale beneath the fitted lines: where a held-out curve equals its fit both show
        axr.plot(t, cvb - w.y, color="tab:purple", lw=2.4, alpha=0.4, zorder=1, label="baseline, held out")
    cv = d.final.cv_pred.get(w.index)
    if d.chosen and cv is not None and np.any(np.isfinite(cv)):
        axr.plot(t, cv - w.y, color="tab:green", lw=2.4, alpha=0.4, zorder=1, label="augmented, held out")
    if len(d.prep.windows) == 1 and cvb is not None:
        # a single release is held out in time blocks: the held-out curves jump where they meet
        for lo, _ in time_blocks(w, d.settings.n_blocks)[1:]:
            axr.axvline(t[lo], color="0.5", lw=0.6, ls=":")
        axr.text(0.01, 0.02, "dotted: held-out blocks' edges", transform=axr.transAxes, fontsize=7, color="0.35")
    axr.axhline(0, color="k", lw=0.5)
    axr.set_xlabel("time since the window's start (s)")


def _regimes(d: Diagnosis, out: Path, located_base, located_final) -> str:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3.6), layout="none")
    regs = [r["regime"] for r in located_base.regimes]
    x = np.arange(len(regs))
    ax.bar(x - 0.27, [r["share_of_samples"] for r in located_base.regimes], 0.27, color="0.7", label="share of samples")
    ax.bar(x, [r["share_of_residual"] for r in located_base.regimes], 0.27, color="tab:red",
           label="share of squared residual, baseline")
    if d.chosen:
        fin = {r["regime"]: r["share_of_residual"] for r in located_final.regimes}
        ax.bar(x + 0.27, [fin.get(r, 0.0) for r in regs], 0.27, color="tab:blue",
               label="share of squared residual, augmented")
    ax.set_xticks(x)
    ax.set_xticklabels(regs, rotation=30, ha="right", fontsize=8)
    ax.set_ylabel("share (-)")
    ax.legend(fontsize=7)
    ax.set_title("residual by regime (regimes overlap)", fontsize=10)
    return _save(fig, out, "regimes.png")


def _windows(d: Diagnosis, out: Path, located_base) -> str:
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    fig, ax = plt.subplots(figsize=(10, 3.2), layout="none")
    for w in d.prep.windows:
        ax.plot(w.t, (d.baseline.full.pred[w.index] - w.y) ** 2, color="tab:red", lw=0.7,
                label="baseline" if w.index == 0 else None)
        if d.chosen:
            ax.plot(w.t, (d.final.full.pred[w.index] - w.y) ** 2, color="tab:blue", lw=0.7,
                    label="augmented" if w.index == 0 else None)
    for k, loc in enumerate(located_base.windows):
        ax.axvspan(loc["start_s"], loc["end_s"], color="orange", alpha=0.25)
        # three heights in turn: neighbouring windows' labels ran into each other on one line
        ax.text(loc["start_s"], ax.get_ylim()[1] * (0.9 - 0.12 * (k % 3)),
                f"{loc['regime']} {loc['share_of_residual']:.0%}", fontsize=7)
    ax.set_xlabel("recording time (s)")
    ax.set_ylabel(f"squared residual (({d.prep.unit})$^2$)")
    handles, _ = ax.get_legend_handles_labels()
    ax.legend(handles=handles + [Patch(color="orange", alpha=0.25, label="located windows (baseline)")],
              fontsize=7, loc="upper right")
    ax.set_title("where the baseline's residual sits", fontsize=9)
    return _save(fig, out, "windows.png")
