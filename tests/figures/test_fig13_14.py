"""Fig. 13/14 and the PME table from a ramp summary (roboball.figures.paper.fig13_14)."""
import pandas as pd
import pytest

from roboball.errors import RoboballError
from roboball.figures.paper import fig13_14


def _summary(path, shift_draws=0.0):
    rows = []
    for contact, base in (("point", 40.0), ("injected", -0.2), ("hydroelastic", 30.0), ("diagnosed", 0.3)):
        for p in (6.9, 13.8):
            for run, d in enumerate((-0.1, 0.0, 0.2)):
                row = {"recording": f"ramp_{p}kpa_r{run + 1}", "pressure_kpa": p, "contact": contact,
                       "pme_percent": base + d, "mape_percent": abs(base) + 0.5 + d, "rmse_rad_s": 0.01 * (1 + run)}
                if contact != "diagnosed":        # the paper's models carry friction-posterior draws
                    row.update(pme_draw_low=base + d - 0.3 + shift_draws, pme_draw_high=base + d + 0.3 + shift_draws,
                               pme_draw_median=base + d + shift_draws)
                rows.append(row)
    pd.DataFrame(rows).to_csv(path, index=False)
    return str(path)


def test_fig13_14_draw_every_model_and_a_two_decimal_table(tmp_path):
    out = {k: str(tmp_path / f) for k, f in (("13", "fig13.png"), ("14", "fig14.png"), ("csv", "t.csv"), ("md", "t.md"))}
    fig13_14(_summary(tmp_path / "s.csv"), out["13"], out["14"], out["csv"], out["md"])
    for f in ("fig13.png", "fig13.pdf", "fig14.png", "fig14.pdf"):
        assert (tmp_path / f).stat().st_size > 10_000, f
    table = pd.read_csv(out["csv"])
    assert set(table.contact) == {"point", "injected", "hydroelastic", "diagnosed"}
    md = (tmp_path / "t.md").read_text()
    assert "| injected | 6.9 | 3 | -0.17 | -0.30 | 0.00 | [-0.6, 0.3] | 0.73 | 0.0200 |" in md
    assert "| diagnosed | 0.33 | 0.83 | 0.0200 |" in md
    assert {"mape_mean_percent", "rmse_mean_rad_s"} <= set(table.columns)


def test_a_summary_without_the_unsigned_errors_is_a_one_line_error_and_writes_nothing(tmp_path):
    """The table's unsigned errors are required: a summary without them (written by an older
    roboball) is refused with the file and the missing columns named, and no figure or table
    is left behind."""
    src = pd.read_csv(_summary(tmp_path / "s.csv")).drop(columns=["mape_percent", "rmse_rad_s"])
    src.to_csv(tmp_path / "old.csv", index=False)
    out = [str(tmp_path / f) for f in ("fig13.png", "fig14.png", "t.csv", "t.md")]
    with pytest.raises(RoboballError) as err:
        fig13_14(str(tmp_path / "old.csv"), *out)
    msg = str(err.value)
    assert "\n" not in msg and "old.csv" in msg and "mape_percent, rmse_rad_s" in msg
    assert sorted(f.name for f in tmp_path.iterdir()) == ["old.csv", "s.csv"]


def test_posterior_whiskers_need_not_contain_the_bar(tmp_path):
    """The bar is the mean over runs of the posterior-median PME; with a few draws (the e2e
    configuration has two) it can lie outside the draws' range, which must still be drawn."""
    out = [str(tmp_path / f) for f in ("fig13.png", "fig14.png", "t.csv", "t.md")]
    fig13_14(_summary(tmp_path / "s.csv", shift_draws=5.0), *out)
    assert (tmp_path / "fig13.png").exists() and (tmp_path / "fig14.png").exists()


def test_fig13_names_the_campaign_and_leaves_room_for_its_key(tmp_path, monkeypatch):
    """The titles say where the recordings come from (config `campaign`), and the key line at the
    top of Fig. 13 sits above the tallest bar rather than on it."""
    import roboball.figures.paper as figures

    saved = []
    monkeypatch.setattr(figures, "save", lambda fig, path: saved.append(fig))
    out = [str(tmp_path / f) for f in ("fig13.png", "fig14.png", "t.csv", "t.md")]
    fig13_14(_summary(tmp_path / "s.csv"), *out, campaign="virtual test bed")
    fig13, fig14 = saved
    top = fig13.axes[0]
    assert top.get_title() == "Fig. 13: drive-speed error per pressure (virtual test bed recordings)"
    assert fig14._suptitle.get_text().endswith("(virtual test bed recordings)")
    # Fig. 14: the signed mean of eq. 12, and beside it the absolute one on a log scale
    signed, absolute = fig14.axes
    assert absolute.get_yscale() == "log" and "cannot cancel" in absolute.get_title()
    # mean |error| per model, a tick each: no bars, whose length on a log axis the axis' start sets
    assert not absolute.patches
    assert [round(c.get_segments()[0][0][1], 2) for c in absolute.collections] == [40.53, 0.73, 30.53, 0.83]
    tallest = max(b.get_height() for b in top.patches)
    assert top.get_ylim()[1] > 1.05 * tallest


def test_fig14_absolute_panel_says_when_a_model_has_no_error_to_show(tmp_path, monkeypatch):
    """A log axis cannot draw 0 or NaN: such a model is labelled, not dropped, and a summary
    without any finite absolute error still makes both figures and the table."""
    import roboball.figures.paper as figures

    saved = []
    monkeypatch.setattr(figures, "save", lambda fig, path: saved.append(fig))
    src = pd.read_csv(_summary(tmp_path / "s.csv"))
    src.loc[src.contact == "diagnosed", "mape_percent"] = 0.0
    src.to_csv(tmp_path / "zero.csv", index=False)
    out = [str(tmp_path / f) for f in ("fig13.png", "fig14.png", "t.csv", "t.md")]
    fig13_14(str(tmp_path / "zero.csv"), *out)
    absolute = saved[-1].axes[1]
    assert len(absolute.collections) == 3 and "0%" in [t.get_text() for t in absolute.texts]
    src["mape_percent"] = float("nan")
    src.to_csv(tmp_path / "nan.csv", index=False)
    fig13_14(str(tmp_path / "nan.csv"), *out)
    assert (tmp_path / "t.md").exists() and len(saved) == 4


def test_fig14_mean_labels_sit_above_their_runs_and_whiskers(tmp_path, monkeypatch):
    """Each bar's written mean is anchored above the bar, every run's dot and the posterior
    whisker, so no label covers a dot (the runs spread well above the mean here)."""
    import roboball.figures.paper as figures

    saved = []
    monkeypatch.setattr(figures, "save", lambda fig, path: saved.append(fig))
    src = pd.read_csv(_summary(tmp_path / "s.csv"))
    first = src.recording.str.endswith("r1")
    src.loc[first, "pme_percent"] += 6.0          # one run per pressure far above the others
    src.loc[first, "mape_percent"] *= 3.0
    src.to_csv(tmp_path / "spread.csv", index=False)
    out = [str(tmp_path / f) for f in ("fig13.png", "fig14.png", "t.csv", "t.md")]
    fig13_14(str(tmp_path / "spread.csv"), *out)
    signed, absolute = saved[1].axes
    for ax, col in ((signed, "pme_percent"), (absolute, "mape_percent")):
        labels = [a for a in ax.texts if a.get_text().endswith("%")]
        assert len(labels) == 4
        for i, (lab, contact) in enumerate(zip(labels, ("point", "injected", "hydroelastic", "diagnosed"))):
            runs = src[src.contact == contact]
            top = runs[col].max()
            if col == "pme_percent" and runs.pme_draw_high.notna().any():
                top = max(top, runs.pme_draw_high.mean())
            assert lab.xy[0] == i and lab.xy[1] >= top - 1e-9, (col, contact, lab.xy, top)


def test_the_pme_table_says_which_hydroelastic_variant_its_key_names(tmp_path):
    """The table's `hydroelastic` is the sweep's carried-forward variant, as the figures' legend says."""
    out = {k: str(tmp_path / f) for k, f in (("13", "fig13.png"), ("14", "fig14.png"), ("csv", "t.csv"), ("md", "t.md"))}
    fig13_14(_summary(tmp_path / "s.csv"), out["13"], out["14"], out["csv"], out["md"], hydro_setting="dissipation x0.5")
    md = (tmp_path / "t.md").read_text()
    assert "Models as in Figs. 13/14: `hydroelastic`: hydroelastic (dissipation x0.5)." in md
    fig13_14(_summary(tmp_path / "s.csv"), out["13"], out["14"], out["csv"], out["md"])
    assert "Models as in" not in (tmp_path / "t.md").read_text()


def test_a_diagnosed_run_scored_in_sample_is_said_in_the_table_and_both_figures(tmp_path, monkeypatch):
    """Where a pressure has one ramp run its diagnosed model is scored on the run its diagnosis
    was fitted on (roboball.pipeline.diagnosis.ramp_diagnosed: scored_in_sample); the table and
    Figs. 13, 14 say at which pressures, and say nothing when every score is out of sample."""
    import roboball.figures.paper as figures

    saved = []
    monkeypatch.setattr(figures, "save", lambda fig, path: saved.append(fig))
    src = pd.read_csv(_summary(tmp_path / "s.csv"))
    src["scored_in_sample"] = None                     # the paper's models have no such column value
    diag = src.contact == "diagnosed"
    src.loc[diag, "scored_in_sample"] = False
    src.to_csv(tmp_path / "out.csv", index=False)
    out = [str(tmp_path / f) for f in ("fig13.png", "fig14.png", "t.csv", "t.md")]
    fig13_14(str(tmp_path / "out.csv"), *out)
    assert "in sample" not in (tmp_path / "t.md").read_text()
    assert not any("in sample" in t.get_text() for f in saved for a in f.axes for t in a.texts)
    assert "\n" not in saved[1]._suptitle.get_text()
    src.loc[diag & (src.pressure_kpa == 13.8), "scored_in_sample"] = True
    src.to_csv(tmp_path / "in.csv", index=False)
    saved.clear()
    fig13_14(str(tmp_path / "in.csv"), *out)
    note = "diagnosed at 13.8 kPa: scored in sample"
    assert f"Out of sample except: {note}" in (tmp_path / "t.md").read_text()
    fig13, fig14 = saved
    assert any(t.get_text().startswith(note) for t in fig13.axes[1].texts)
    assert fig14._suptitle.get_text().split("\n")[1].startswith(note)
