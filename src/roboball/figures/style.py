"""Plotting shared by every stage that draws: the house style, the atomic, timestamp-free saver
(PNG + PDF twin) and the ingest stage's QC plot.  Kept apart from roboball.figures.paper so
that editing a paper figure does not change the code fingerprint of the ingest stage (and with
it every job of the DAG)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from roboball.atomic import savefig_atomic  # noqa: E402

CONTACT_COLOURS = {"point": "#7f7f7f", "injected": "#1f77b4", "hydroelastic": "#d62728", "hydro_tuned": "#ff7f0e",
                   "diagnosed": "#2ca02c"}
plt.rcParams.update({"font.size": 10, "axes.grid": True, "grid.alpha": 0.3, "savefig.dpi": 150,
                     "pdf.fonttype": 42, "svg.hashsalt": "roboball", "figure.constrained_layout.use": True})
_META = {"png": {"Software": None}, "pdf": {"CreationDate": None, "Producer": None, "Creator": None}}


def save(fig, path: str | Path) -> None:
    """Save `fig` to path (and its PDF twin when path ends in .png), atomically, no timestamps."""
    path = Path(path)
    targets = [path] + ([path.with_suffix(".pdf")] if path.suffix == ".png" else [])
    for target in targets:
        # Through the shared atomic writer: its scratch file ends in .tmp, so a killed run
        # never leaves a hidden file that looks like a figure.
        fmt = target.suffix[1:]
        savefig_atomic(fig, target, format=fmt, metadata=_META.get(fmt))
    plt.close(fig)


def _unit(sig: str) -> str:
    return "rad/s" if sig.endswith("_rad_s") else "rad"


def qc_plot(rec, releases, path) -> None:
    """Whole recording with each release marked (hand phase shaded, release instant, free
    response).  The main signal, and beside it every other signal of its unit (a coupled test's
    steer angle with its pipe angle); a trimmed log's release has no hold, and none is shaded."""
    sig = rec.main_signal()
    unit = _unit(sig)
    shown = [sig] + [s for s in rec.signals if s != sig and _unit(s) == unit]
    fig, ax = plt.subplots(figsize=(9, 3.2))
    colours = ("k", "tab:green", "tab:brown", "tab:olive")     # not the spans' orange, blue, red, purple
    for k, s in enumerate(shown):
        ax.plot(rec.time, rec.signal(s), lw=0.8, color=colours[k % len(colours)], label=s)
    held = [r for r in releases if r.t_release_s > r.held_from_s]
    for i, r in enumerate(held):
        ax.axvspan(r.held_from_s, r.t_release_s, color="orange", alpha=0.25, label="hand hold" if i == 0 else None)
    for i, r in enumerate(releases):
        ax.axvspan(r.t_release_s, r.t_end_s, color="tab:blue", alpha=0.08, label="free response" if i == 0 else None)
        ax.axvline(r.t_release_s, color="tab:red", lw=1, label="release" if i == 0 else None)
    if rec.meta.get("ramp_exit_s"):
        ax.axvline(rec.meta["ramp_exit_s"], color="tab:purple", ls="--", label="leaves ramp")
    ax.set_xlabel("time (s)")
    name = sig.rsplit("_", 1)[0] if unit == "rad" else sig[:-6]
    ax.set_ylabel(f"{name if len(shown) == 1 else 'angle' if unit == 'rad' else 'rate'} ({unit})")
    p = rec.pressure_kpa
    ax.set_title(f"QC: {Path(str(rec.path)).stem} ({rec.kind}{'' if p is None else f', {p:g} kPa'}): "
                 f"{len(releases)} release(s)")
    ax.legend(loc="upper right", fontsize=8)
    save(fig, path)
