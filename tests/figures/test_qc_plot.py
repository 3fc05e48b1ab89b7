"""The ingest QC plot: what it draws for a coupled test (both angles, no hold before a trimmed
log's let-go) and for a stand log (one signal, its hand holds shaded)."""
from pathlib import Path

import pytest

from roboball.ingest.importers import read_any
from roboball.ingest.recording import normalise

REPO = Path(__file__).resolve().parents[2]


def _drawn(monkeypatch, path, tmp_path):
    import roboball.figures.style as style
    from roboball.ingest.releases.find import require_releases
    seen = {}
    monkeypatch.setattr(style, "save", lambda fig, out: seen.update(
        lines=[ln.get_label() for ln in fig.axes[0].get_lines()],
        legend=[t.get_text() for t in fig.axes[0].get_legend().get_texts()],
        ylabel=fig.axes[0].get_ylabel()))
    rec = normalise(read_any(path))
    style.qc_plot(rec, require_releases(rec), str(tmp_path / "qc.png"))
    return seen


def test_a_coupled_log_shows_both_angles_and_no_hold_before_its_trimmed_let_go(monkeypatch, tmp_path):
    seen = _drawn(monkeypatch, REPO / "raw_data/steer_coupled/steer_coupled_6.9kpa_r1.csv", tmp_path)
    assert seen["lines"][:2] == ["pipe_angle_rad", "steer_angle_rad"] and seen["ylabel"] == "angle (rad)"
    assert "hand hold" not in seen["legend"] and {"free response", "release"} <= set(seen["legend"])


@pytest.mark.parametrize("path, ylabel", [("raw_data/steer_stand/steer_stand_r1.csv", "steer_angle (rad)"),
                                          ("raw_data/shell_rock/shell_rock_6.9kpa_r1.csv", "pipe_angle (rad)")])
def test_a_held_release_log_shows_its_signal_and_its_hand_holds(monkeypatch, tmp_path, path, ylabel):
    seen = _drawn(monkeypatch, REPO / path, tmp_path)
    assert seen["lines"][0] == Path(ylabel.split()[0] + "_rad").name and seen["ylabel"] == ylabel
    assert "rad_s" not in " ".join(seen["lines"])                 # a rate is another unit: not drawn
    assert "hand hold" in seen["legend"]
