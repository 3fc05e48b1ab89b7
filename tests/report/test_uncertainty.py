"""The parameter-uncertainty report (roboball.report.uncertainty): the friction section says the
stand was calibrated and gives delta_i and the rest offset with intervals, shows an unconverged
chain in red wherever it appears, and never recommends it."""
from __future__ import annotations

import json

import pandas as pd

from roboball.report.uncertainty import uncertainty_report


def _fit(path, law, converged, bic):
    params = {"c": {"median": 0.34, "ci95_low": 0.32, "ci95_high": 0.36},
              "delta_i": {"median": 0.0485, "ci95_low": 0.0462, "ci95_high": 0.0509},
              "rest_offset": {"median": 0.0037, "ci95_low": 0.0010, "ci95_high": 0.0065},
              "noise_rad": {"median": 0.049, "ci95_low": 0.047, "ci95_high": 0.051}}
    path.write_text(json.dumps({
        "joint": "steer", "law": law, "recording": "real_steer_stand", "parameters": params,
        "release_shifts_s": [{"median": 0.166, "ci95_low": 0.16, "ci95_high": 0.17}],
        "convergence": {"steps": 1450 if converged else 3000, "max_tau": 19.1 if converged else 90.0,
                        "chain_over_tau": 51.3 if converged else 25.0, "acceptance_fraction": 0.28,
                        "ess_min": 2400.0, "converged": converged},
        "fit": {"rmse_rad": 0.0492, "bic": bic}, "timing": {"wall_s": 40.3}}))
    return str(path)


def test_friction_section_gives_the_calibration_and_flags_unconverged_chains(tmp_path):
    fits = [_fit(tmp_path / "cv.json", "coulomb_viscous", True, -4480.0),
            _fit(tmp_path / "majd.json", "majd", False, -4500.0)]
    cmp_ = tmp_path / "steer_comparison.csv"
    pd.DataFrame({"joint": ["steer"] * 2, "law": ["majd", "coulomb_viscous"], "recording": ["real_steer_stand"] * 2,
                  "bic": [-4500.0, -4480.0], "converged": [False, True],
                  "recommended": [False, True]}).to_csv(cmp_, index=False)
    (tmp_path / "reg.csv").write_text("name,value\nzeta_a,0.2\n")
    (tmp_path / "pme.csv").write_text("contact,pressure_kpa,pme_mean_percent\npoint,13.8,30.0\n")
    (tmp_path / "sweep.md").write_text("sweep\n")
    out = tmp_path / "report.html"
    uncertainty_report(fits, [str(cmp_)], str(tmp_path / "reg.csv"), str(tmp_path / "pme.csv"),
                       str(tmp_path / "sweep.md"), [], str(out))
    page = out.read_text()
    assert "calibrated stand" in page and "Stand calibration" in page
    assert "<td>0.0485 [0.0462, 0.0509]</td><td>0.0037 [0.001, 0.0065]</td><td>+0.166</td>" in page
    # the unconverged Majd fit: red in the parameter, calibration, convergence and comparison tables
    red = [row.split("</tr>")[0] for row in page.split("<tr") if row.startswith(" class='bad'")]
    assert len(red) >= 4 and all("majd" in row for row in red)
    assert not any("coulomb_viscous" in row for row in red)
    assert ("recommended law <b>coulomb_viscous</b> (majd, of lower BIC, left out: its chain did not converge)"
            in page)
