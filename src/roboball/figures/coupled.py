"""Fig. S2: the coupled steer test, each repeat's pipe angle and steer joint angle, recording
against every shell model (issue 27; roboball.pipeline.coupled draws it)."""
from __future__ import annotations

import pandas as pd

# colour, line style per model; the recording is drawn as dots
STYLE = {
    "point": ("#7f7f7f", ":"), "injected": ("#1f77b4", "-"), "hydroelastic": ("#d62728", "-"),
    "hydro_half": ("#ff7f0e", "--"), "hydro_tuned": ("#bcbd22", "-"), "authors_nm": ("#9467bd", "-."), "authors_hand": ("#8c564b", ":"),
    "ours_nm": ("#e377c2", "--"), "diagnosed": ("#2ca02c", "-"),
}
LABELS = {"ours_nm": "ours: authors' objective refitted", "diagnosed": "diagnosed (held out)",
          "hydro_tuned": "hydroelastic, calibrated (Fig. S3)"}
COORDS = (("pipe_angle_rad", "pipe angle phi (rad)"), ("steer_angle_rad", "steer joint angle theta (rad)"))


def label(name: str) -> str:
    """What a model key of Fig. S2 and its table stands for."""
    from roboball.sim.coupled import MODEL_NAMES, model
    return model(name).label if name in MODEL_NAMES else LABELS.get(name, name)


_WORDS = {2: "two", 3: "three", 4: "four", 5: "five"}


def count_word(n: int) -> str:
    """A small count as a word in prose and titles ("three repeats"); larger ones as digits."""
    return _WORDS.get(n, str(n))


def plot(traces: pd.DataFrame, table: pd.DataFrame, out_png: str, campaign: str = "",
         pressure_free: bool = False, left_out: dict | None = None, logged_kpa: float | None = None) -> None:
    """Two rows (pipe angle, steer angle) by one column per repeat; PNG + PDF.  `campaign` names
    where the repeats come from in the title; `pressure_free`: the shell laws did not depend on
    pressure, so no pressure was fitted; `left_out` ({model: why}) is said under the title;
    `logged_kpa`: the repeats' logged pressure, at which every model ran."""
    from roboball.figures.style import plt, save

    repeats = list(dict.fromkeys(traces.repeat))
    models = [m for m in dict.fromkeys(traces.model) if m != "recording"]
    # two repeats or fewer: three legend columns on a wider figure, so that the labels fit
    ncol = 4 if len(repeats) >= 3 else 3
    fig, axes = plt.subplots(2, len(repeats), figsize=(max(4.6 * len(repeats), 11.0), 6.6), sharex="col",
                             squeeze=False)
    for j, rep in enumerate(repeats):
        d = traces[traces.repeat == rep]
        for i, (col, ylabel) in enumerate(COORDS):
            ax = axes[i, j]
            rec = d[d.model == "recording"]
            ax.plot(rec.time_s, rec[col], "k.", ms=2.5, label="recording", zorder=5)
            for m in models:
                dm = d[d.model == m]
                colour, ls = STYLE.get(m, ("k", "-"))
                ax.plot(dm.time_s, dm[col], color=colour, ls=ls, lw=2.0 if m == "diagnosed" else 1.2,
                        label=label(m))
            if j == 0:
                ax.set_ylabel(ylabel)
            if i == 1:
                ax.set_xlabel("time since let-go (s)")
        axes[0, j].set_title(f"repeat {rep.rsplit('_', 1)[-1]}", fontsize=10)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=ncol, fontsize=8)
    n = traces["repeat"].nunique()
    where = f" of {campaign}" if campaign else ""
    if pressure_free:
        how = "shell laws held at the campaign's shell releases; pressure not fitted"
    elif logged_kpa is not None:
        how = f"at the logged pressure, {logged_kpa:g} kPa"
    else:
        how = "pressure models at each held-out repeat's fold pressure"
    # a model the stage could not run is named, not silently missing
    not_run = "".join(f"\nnot run: {label(m)}: {why}" for m, why in (left_out or {}).items())
    fig.suptitle(f"Fig. S2: coupled steer test, {count_word(n)} repeats{where} against every shell model "
                 f"({how}){not_run}", fontsize=10)
    save(fig, out_png)
