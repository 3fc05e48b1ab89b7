"""Write a design: design.json (the ranked experiments and each choice's verdict), design.md (a
short readable account) and design.png (the best experiment's predicted recordings, one curve
per candidate, over the log's noise band)."""
from __future__ import annotations


import numpy as np

from roboball.atomic import output_folder, savefig_atomic, write_json_atomic, write_text_atomic
from roboball.design.rank import same_experiment
from roboball.diagnose.report import json_safe

OUTPUT_FILES = ("design.json", "design.md", "design.png")


def write(src, js: dict, grids: dict, out_dir) -> None:
    out = output_folder(out_dir, files=OUTPUT_FILES)
    figure = _figure(src, js, grids, out / "design.png")
    js["figure"] = figure
    write_json_atomic(out / "design.json", json_safe(js))
    write_text_atomic(out / "design.md", markdown(js))


def _settings(r: dict) -> str:
    if r["kind"] == "ramp":
        own = " (the user's)" if r["users_angle"] else ""
        return (f"a descent from rest on a ramp of {r['ramp_angle_deg']:g} deg{own}, as long as the user's "
                f"({r['recording_s']:.1f} s of recording until the first candidate leaves it)")
    rel = ", ".join(f"{x:+.2f}" for x in r["release_from_rest_rad"])
    abs_ = ", ".join(f"{x:+.3f}" for x in r["release_rad"])
    text = f"release{'s' if len(r['release_rad']) > 1 else ''} at {rel} rad from rest ({abs_} rad as recorded)"
    text += f", each left {r['settle_s']:.1f} s to settle ({r['recording_s']:.1f} s of recording)"
    if r.get("steer_joint"):
        text += f", steer joint {r['steer_joint']}"
    return text


def markdown(js: dict) -> str:
    unit = js.get("unit", "rad")
    u = unit.replace("/", "_")
    lines = [f"# Which recording would decide: {js['recording']}", "",
             f"Kind `{js['kind']}`; the log's noise {js[f'noise_{u}']:.3g} {unit}, the diagnosed model's residual on it "
             f"{js[f'residual_{u}']:.3g} {unit}. An experiment settles a choice when its candidates' predicted recordings "
             f"differ by at least {js['settles_at_separation']:g} noise levels (RMS, the parameters' uncertainty "
             "included; the diagnosis's own materiality).", ""]
    if not js["choices"]:
        lines += ["The diagnosis left no choice undecided: no alternatives, a recorded steer setting, every "
                  "parameter pinned. Nothing to design.", ""]
    for c in js["choices"]:
        lines += [f"## {c['choice']}", ""]
        for cand in c["candidates"]:
            mech = f": {cand['mechanism']}" if cand.get("mechanism") else ""
            lines.append(f"- `{cand['label']}`{mech}")
        lines.append("")
        best = c["best"]
        if best is None:
            lines += ["No feasible experiment.", ""]
            continue
        verdict = "settles it" if c["settled"] else "does not settle it"
        lines += [f"**Best experiment** ({verdict}): {_settings(best)}: separation {best['separation']:.3g} noise levels "
                  f"(fixed parameters {best['separation_fixed_params']:.3g}; {best['separation_vs_residual']:.2g} times "
                  f"the diagnosed model's residual), expected chi^2 gap {best['expected_chi2_gap']:.4g}.", ""]
        other = c.get("best_other_clamp")
        if other:
            lines += [f"With the steer clamp changed ({_settings(other)}) the candidates part further: separation "
                      f"{other['separation']:.3g} noise levels{', refitted' if other['refitted'] else ''}, were both "
                      "recordings diagnosed together. `roboball diagnose` takes one steer setting at a time, so that "
                      "recording would be diagnosed on its own, which the separation does not measure; the best "
                      "experiment above keeps the clamp as the user's.", ""]
        single = c.get("best_single_release")
        if single and single is not best:
            lines += [f"Best single release of the user's length: {_settings(single)}: predicted separation "
                      f"{single['separation_predicted']:.3g} noise levels (at the fitted values, the parameters' "
                      f"uncertainty included; not refitted).", ""]
        u = c.get("user_like")
        if u and same_experiment(u, best):
            own = ("another run on the user's own ramp: of the ramps considered, the one" if u["kind"] == "ramp" else
                   "the user's own first release, recorded again: of the releases the rig allows, the one")
            lines += [f"This is {own} where the candidates part most.", ""]
        elif u:
            what = "Another run on the user's ramp" if u["kind"] == "ramp" else "A repeat of the user's release"
            lines += [f"{what} ({_settings(u)}): separation {u['separation']:.3g}.", ""]
        lines += [f"Why: {c['why']}", ""]
        if not c["settled"]:
            lines += [f"No feasible experiment separates them. What would: {c['sensor']}.", ""]
        if c.get("refit"):
            lines += [f"Refitted: {c['refit']}", ""]
    lines += [f"The figure `{js.get('figure', 'design.png')}` shows the best experiment's predicted recordings; "
              f"`design.json` ranks {len(js['experiments'])} experiments. Designed in {js['time_s']:.1f} s.", ""]
    return "\n".join(lines)


def _figure(src, js: dict, grids: dict, path) -> str:
    """The best experiment of each choice (a row each): its predicted recordings, one curve per
    candidate, and their differences from the first candidate over the noise band."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [(c, grids[c["choice"]]) for c in js["choices"] if c["choice"] in grids]
    if not rows:
        fig, ax = plt.subplots(figsize=(7, 2))
        ax.text(0.5, 0.5, "no undecided choice: nothing to design", ha="center", va="center")
        ax.axis("off")
        savefig_atomic(fig, path, dpi=110)
        plt.close(fig)
        return path.name
    ncol = max(len(best.get("release_rad", [0])) for _, (_, best) in rows)
    # a block (prediction over difference) per choice, each laid out on its own: one gridspec for
    # all spread every gap to the widest one, the legend below a difference panel; one-release
    # choices sit two across, so that five of them read on a screen, not down a 40-inch column
    across = 2 if ncol == 1 and len(rows) > 1 else 1
    down = -(-len(rows) // across)
    fig = plt.figure(figsize=(6.5 * ncol * across, 6.6 * down), layout="constrained")
    blocks = fig.subfigures(down, across, squeeze=False, hspace=0.04, wspace=0.03)
    for r, (c, (g, best)) in enumerate(rows):
        axes = blocks[r // across, r % across].subplots(2, ncol, squeeze=False,
                                                         gridspec_kw={"height_ratios": [3, 2]})
        for j in range(ncol):
            top, bottom = axes[0, j], axes[1, j]
            if j >= len(best.get("release_rad", [0])):
                top.axis("off")
                bottom.axis("off")
                continue
            _panel(top, bottom, src, c, g, best, j)
    for b in blocks.flat[len(rows):]:
        b.set_visible(False)
    savefig_atomic(fig, path, dpi=110, bbox_inches="tight")     # the legends below the panels included
    plt.close(fig)
    return path.name


def _panel(top, bottom, src, c: dict, g, best: dict, j: int) -> None:
    ramp = best["kind"] == "ramp"
    w = int(np.argmin(np.abs(g.releases - (best["ramp_angle_deg"] if ramp else best["release_rad"][j]))))
    # a ramp's run is shown up to a little past where the first candidate leaves the ramp: beyond
    # it the models roll on, off any ramp, and would set the axes' scale
    keep = g.t <= (min(best["recording_s"] * 1.15 + 0.1, g.t[-1]) if ramp else best["settle_s"]) + 1e-9
    t = g.t[keep]
    labels = list(g.central)
    ref = g.central[labels[0]][w][keep]
    colours = ["tab:blue", "tab:orange", "tab:green", "tab:red"]
    sig = src.prep.signal
    for k, lab in enumerate(labels):
        y = g.central[lab][w][keep]
        s = np.sqrt(g.var[lab][w][keep])
        top.plot(t, y, color=colours[k % 4], lw=1.3, label=lab)
        top.fill_between(t, y - 2 * s, y + 2 * s, color=colours[k % 4], alpha=0.2, lw=0)
        if k:
            bottom.plot(t, y - ref, color=colours[k % 4], lw=1.3, label=f"{lab} - {labels[0]}")
        # one legend entry for the bands: their colours are the lines' (the top panel's legend)
        bottom.fill_between(t, y - ref - 2 * s, y - ref + 2 * s, color=colours[k % 4], alpha=0.2, lw=0,
                            label=None if k else "2 sd of each candidate's parameter draws")
    unit = src.prep.unit
    bottom.axhspan(-2 * src.noise, 2 * src.noise, color="0.3", alpha=0.45, lw=0,
                   label=f"log's noise, +-2 sigma ({2 * src.noise:.2g} {unit})")
    still = t[~g.moving[w][keep]]
    if still.size:        # not counted: the body has stopped (experiments.moving) or left the ramp (design.ramp)
        gone = "off the ramp: not counted" if ramp else "at rest: not counted"
        for ax in (top, bottom):
            ax.axvspan(still[0], t[-1], color="0.85", zorder=0, label=gone if ax is bottom else None)
    if ramp:
        setting = f"ramp of {best['ramp_angle_deg']:g} deg" + (" (the user's)" if best["users_angle"] else "")
    else:
        joint = f", steer joint {best['steer_joint']}" if best.get("steer_joint") else ""
        setting = f"release at {best['release_from_rest_rad'][j]:+.2f} rad from rest{joint}"
    top.set_title(f"{c['choice']}\n{setting}: separation {best['separation']:.3g} noise levels", fontsize=10)
    top.set_ylabel(f"predicted {sig} ({unit})")
    # a descent's rate rises from the lower left: its upper left is free
    top.legend(fontsize=8, loc="upper left" if ramp else "best", title="candidate (band: 2 sd of parameter draws)", title_fontsize=7)
    bottom.set_xlabel("time since release (s)")
    bottom.set_ylabel(f"difference ({unit})")
    # below the panel, not over it: the differences fill the panel's whole height
    bottom.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.3), frameon=False)
    for ax in (top, bottom):
        ax.grid(alpha=0.3)
