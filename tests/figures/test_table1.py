"""Table I (roboball.figures.friction.table1): parameters next to the paper's values, with
units, the stand each fit calibrated, and the state of each posterior chain, so an unconverged
chain cannot pass unnoticed and is never recommended."""
from __future__ import annotations

import json

import pandas as pd

from roboball.figures.friction import table1


def _fit(path, law, converged, tau, stand=None, wall=None):
    params = {"c": {"median": 0.30, "map": 0.30, "ci95_low": 0.29, "ci95_high": 0.31},
              "noise_rad": {"median": 0.04, "map": 0.04, "ci95_low": 0.039, "ci95_high": 0.041},
              "release_1_rad": {"median": 0.8, "map": 0.8, "ci95_low": 0.79, "ci95_high": 0.81}}
    extra = {}
    if stand:
        params.update({"delta_i": {"median": 0.0498, "map": 0.05, "ci95_low": 0.0475, "ci95_high": 0.0522,
                                   "unit": "kg m^2"},
                       "rest_offset": {"median": 0.0041, "map": 0.004, "ci95_low": 0.0016, "ci95_high": 0.0067,
                                       "unit": "rad"}})
        extra = {"release_shifts_s": [{"median": 0.165, "ci95_low": 0.16, "ci95_high": 0.17},
                                      {"median": -0.045, "ci95_low": -0.05, "ci95_high": -0.04}]}
    conv = {"steps": 2500 if not converged else 600, "burn_in": 200, "max_tau": tau,
            "chain_over_tau": (2500 - 641) / tau if not converged else 55.0, "ess_min": 450.0,
            "autocorr_multiple": 50.0, "converged": converged}
    path.write_text(json.dumps({"joint": "steer", "law": law, "recording": path.stem, "parameters": params,
                                "convergence": conv, **extra, **({"timing": {"wall_s": wall}} if wall else {})}))
    return str(path)


def test_table1_gives_units_marks_missing_paper_values_and_reports_each_chain(tmp_path):
    fits = [_fit(tmp_path / "stand_a.json", "viscous", True, 11.0),
            _fit(tmp_path / "stand_b.json", "viscous", False, 131.0)]
    table1(fits, str(tmp_path / "t.csv"), str(tmp_path / "t.md"))
    md = (tmp_path / "t.md").read_text()
    assert "| stand_a | steer | viscous | c | 0.3 | [0.29, 0.31] | 0.3 | 0.104 | N m s/rad |" in md
    assert "| stand_a | steer | viscous | noise_rad | 0.04 | [0.039, 0.041] | 0.04 | - | rad |" in md
    assert "nan" not in md and "release" not in md
    assert "| stand_a | steer | viscous | 600 | 200 | 11 | 55.0 (needs 50) | 450 | yes |" in md
    assert "| stand_b | steer | viscous | 2500 | 200 | 131 | 14.2 (needs 50) | 450 | **no** |" in md
    # the parameters of an unconverged chain are flagged where they are read
    assert "| stand_b | steer | viscous (**chain not converged**) | c | 0.3 |" in md
    csv = pd.read_csv(tmp_path / "t.csv")
    assert csv.set_index(["source", "parameter"]).loc[("stand_a", "noise_rad"), "unit"] == "rad"


def test_table1_gives_the_calibrated_stand_with_intervals_and_recommends_only_converged_chains(tmp_path):
    fits = [_fit(tmp_path / "real_a.json", "coulomb_viscous", True, 8.0, stand=True, wall=43.0),
            _fit(tmp_path / "real_b.json", "majd", False, 131.0, stand=True, wall=130.0)]
    cmp_ = tmp_path / "cmp.csv"
    pd.DataFrame({"joint": ["steer", "steer"], "law": ["majd", "coulomb_viscous"], "recording": ["r", "r"],
                  "bic": [-4500.0, -4480.0], "converged": [False, True],
                  "recommended": [False, True]}).to_csv(cmp_, index=False)
    table1(fits, str(tmp_path / "t.csv"), str(tmp_path / "t.md"), comparison_csv=str(cmp_))
    md = (tmp_path / "t.md").read_text()
    assert "calibrated stand" in md and "## Stand calibration" in md
    assert "| real_a | steer | coulomb_viscous | 0.0498 [0.0475, 0.0522] | 0.0041 [0.0016, 0.0067] | +0.165, -0.045 |" in md
    assert "| real_a | steer | coulomb_viscous | delta_i | 0.0498 | [0.0475, 0.0522] | 0.05 | - | kg m^2 |" in md
    assert "| real_a | steer | coulomb_viscous | 600 | 200 | 8 | 55.0 (needs 50) | 450 | yes |" in md
    assert ("Recommended: **coulomb_viscous** (majd, of lower BIC, left out: its chain did not converge)." in md), md


def test_table1_lists_a_held_parameter_as_held_with_its_value(tmp_path):
    """Majd's n, held by a point prior, is a row of its own: its value, "held (not fitted)" for
    an interval, no MAP; the CSV marks it (`held`) and leaves its interval empty."""
    path = tmp_path / "stand_m.json"
    _fit(path, "majd", True, 9.0)
    d = json.loads(path.read_text())
    d["fixed"] = {"n": 1.6}
    path.write_text(json.dumps(d))
    table1([str(path)], str(tmp_path / "t.csv"), str(tmp_path / "t.md"))
    md = (tmp_path / "t.md").read_text()
    assert "| stand_m | steer | majd | n | 1.6 | held (not fitted) | - | 1 | 1 |" in md     # paper (steer): 1
    assert "nan" not in md
    csv = pd.read_csv(tmp_path / "t.csv").set_index("parameter")
    assert bool(csv.loc["n", "held"]) and pd.isna(csv.loc["n", "ci95_low"]) and not bool(csv.loc["c", "held"])


def test_table1_is_the_same_bytes_whatever_the_fits_wall_times(tmp_path):
    """paper_figures/ reproduces byte for byte: a fit's wall time (different every run) is not in it."""
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    a = _fit(tmp_path / "a" / "real_a.json", "coulomb_viscous", True, 8.0, stand=True, wall=43.0)
    b = _fit(tmp_path / "b" / "real_a.json", "coulomb_viscous", True, 8.0, stand=True, wall=97.0)
    table1([a], str(tmp_path / "a.csv"), str(tmp_path / "a.md"))
    table1([b], str(tmp_path / "b.csv"), str(tmp_path / "b.md"))
    assert (tmp_path / "a.md").read_bytes() == (tmp_path / "b.md").read_bytes()
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()


def test_corner_plot_labels_each_parameter_with_its_own_unit(tmp_path, monkeypatch):
    """The stand's calibration in its units (delta_i kg m^2, rest_offset rad), the law's from
    the friction table, the noise in rad: no parameter is labelled '(-)'."""
    import corner
    import numpy as np

    from roboball.figures.friction import corner_plot

    path = tmp_path / "fit.json"
    _fit(path, "viscous", True, 8.0, stand=True)
    d = json.loads(path.read_text())
    cols = ["c", "delta_i", "rest_offset", "noise_rad"]
    rng = np.random.default_rng(0)
    pd.DataFrame(rng.normal(1.0, 0.1, (200, 4)), columns=cols).to_csv(tmp_path / "s.csv", index=False)
    d["samples_csv"] = str(tmp_path / "s.csv")
    path.write_text(json.dumps(d))
    seen = {}
    real = corner.corner

    def spy(*a, **kw):
        seen["labels"] = kw["labels"]
        return real(*a, **kw)

    monkeypatch.setattr(corner, "corner", spy)
    corner_plot(str(path), str(tmp_path / "c.png"))
    assert seen["labels"] == ["c (N m s/rad)", "delta_i (kg m^2)", "rest_offset (rad)", "noise_rad (rad)"]
