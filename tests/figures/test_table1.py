"""Table I (roboball.figures.friction.table1): parameters next to the paper's values, with
units, and the state of each posterior chain, so an unconverged chain cannot pass unnoticed."""
from __future__ import annotations

import json

import pandas as pd

from roboball.figures.friction import table1


def _fit(path, law, converged, tau):
    params = {"c": {"median": 0.30, "map": 0.30, "ci95_low": 0.29, "ci95_high": 0.31},
              "noise_rad": {"median": 0.04, "map": 0.04, "ci95_low": 0.039, "ci95_high": 0.041},
              "release_1_rad": {"median": 0.8, "map": 0.8, "ci95_low": 0.79, "ci95_high": 0.81}}
    conv = {"steps": 2500 if not converged else 600, "burn_in": 200, "max_tau": tau,
            "chain_over_tau": (2500 - 641) / tau if not converged else 55.0, "ess_min": 450.0,
            "autocorr_multiple": 50.0, "converged": converged}
    path.write_text(json.dumps({"joint": "steer", "law": law, "recording": path.stem, "parameters": params,
                                "convergence": conv}))
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
    csv = pd.read_csv(tmp_path / "t.csv")
    assert csv.set_index(["source", "parameter"]).loc[("stand_a", "noise_rad"), "unit"] == "rad"
