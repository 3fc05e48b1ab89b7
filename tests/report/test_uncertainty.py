"""The parameter-uncertainty report (roboball.report.uncertainty): the friction section says the
stand was calibrated and gives delta_i and the rest offset with intervals, shows an unconverged
chain in red wherever it appears, never recommends it, and lists red flags for it and for every
recommendation resting on it; the sweep is a real table, pressures sort as numbers."""
from __future__ import annotations

import json
import re

import pandas as pd
import pytest

from roboball.errors import RoboballError
from roboball.report.tables import table_page
from roboball.report.uncertainty import uncertainty_report


def _fit(path, law, converged, bic, joint="steer"):
    params = {"c": {"median": 0.34, "ci95_low": 0.32, "ci95_high": 0.36},
              "delta_i": {"median": 0.0485, "ci95_low": 0.0462, "ci95_high": 0.0509},
              "rest_offset": {"median": 0.0037, "ci95_low": 0.0010, "ci95_high": 0.0065},
              "noise_rad": {"median": 0.049, "ci95_low": 0.047, "ci95_high": 0.051}}
    path.write_text(json.dumps({
        "joint": joint, "law": law, "recording": "real_steer_stand", "parameters": params,
        "release_shifts_s": [{"median": 0.166, "ci95_low": 0.16, "ci95_high": 0.17}],
        "convergence": {"steps": 1450 if converged else 3000, "max_tau": 19.1 if converged else 90.0,
                        "chain_over_tau": 51.3 if converged else 25.0, "acceptance_fraction": 0.28,
                        "ess_min": 2400.0, "converged": converged},
        "fit": {"rmse_rad": 0.0492, "bic": bic}, "timing": {"wall_s": 40.3}}))
    return str(path)


SWEEP_MD = """# Hydroelastic sensitivity sweep (section III-D)

Mean absolute error:

| case | mean abs error (%) |
|---|---|
| modulus x0.5 | 30.2 |
| control | 38.7 |

Setting carried forward (config `shell.carried_forward`): **dissipation x0.5**.
"""


def _report(tmp_path, majd_converged=False, ramp_friction=()):
    fits = [_fit(tmp_path / "cv.json", "coulomb_viscous", True, -4480.0),
            _fit(tmp_path / "majd.json", "majd", majd_converged, -4500.0)]
    cmp_ = tmp_path / "steer_comparison.csv"
    pd.DataFrame({"joint": ["steer"] * 2, "law": ["majd", "coulomb_viscous"], "recording": ["real_steer_stand"] * 2,
                  "bic": [-4500.0, -4480.0], "converged": [majd_converged, True],
                  "recommended": [majd_converged, not majd_converged]}).to_csv(cmp_, index=False)
    (tmp_path / "reg.csv").write_text("name,value\nzeta_a,0.2\n")
    (tmp_path / "pme.csv").write_text("contact,pressure_kpa,pme_mean_percent,pme_post_low_percent\n"
                                      "point,20.7,30.0,\npoint,6.9,70.0,\ninjected,13.8,1.0,0.5\n")
    (tmp_path / "sweep.md").write_text(SWEEP_MD)
    out = tmp_path / "report.html"
    uncertainty_report(fits, [str(cmp_)], str(tmp_path / "reg.csv"), str(tmp_path / "pme.csv"),
                       str(tmp_path / "sweep.md"), [], str(out), ramp_friction=[str(tmp_path / f) for f in ramp_friction])
    return out.read_text()


def test_friction_section_gives_the_calibration_and_flags_unconverged_chains(tmp_path):
    page = _report(tmp_path, ramp_friction=["majd.json"])
    assert "calibrated stand" in page and "Stand calibration" in page
    assert ("<td>0.0485 [0.0462, 0.0509]</td><td>0.0037 [0.001, 0.0065]</td><td>+0.166</td>" in page)
    # the unconverged Majd fit: red in the parameter, calibration, convergence and comparison tables
    red = [row.split("</tr>")[0] for row in page.split("<tr") if row.startswith(' class="bad"')]
    assert len(red) >= 4 and all("majd" in row for row in red)
    assert not any("coulomb_viscous" in row for row in red)
    assert "recommended law <b>coulomb_viscous</b> <span class='bad'>(majd, of lower BIC, left out" in page
    # the red flags: the chain itself, the comparison resting on leaving it out, the PME resting on its draws
    flags = page.split('<div class="flags"', 1)[1].split("</div>", 1)[0]
    assert "Red flags (3)" in flags
    assert "Chain not converged: real_steer_stand steer majd" in flags
    assert "recommendation of coulomb_viscous rests on an unconverged chain" in flags
    assert "rest on friction from unconverged chains: real_steer_stand steer majd" in flags


def test_no_flags_when_every_chain_converged(tmp_path):
    page = _report(tmp_path, majd_converged=True, ramp_friction=["majd.json"])
    assert "No red flags" in page and 'class="flags"' not in page and ' class="bad"' not in page


def test_a_readable_page_real_tables_yes_no_and_numeric_pressures(tmp_path):
    page = _report(tmp_path)
    assert "<pre>" not in page and "| case |" not in page and "**" not in page
    assert "<th>case</th>" in page and "<b>dissipation x0.5</b>" in page
    assert "<nav>" in page and 'href="#sweep"' in page and 'id="sweep"' in page
    assert not re.search(r">(True|False|NO|nan)<", page)            # yes/no, and a dash for a missing number
    assert "<td>yes</td>" in page and "<td>no</td>" in page and "&mdash;" in page
    rows = re.findall(r"<tr><td>point</td><td class='num'>([\d.]+)</td>", page)
    assert rows == ["6.9", "20.7"]                                  # numeric, not string, order


def test_figures_have_captions_that_say_what_they_show(tmp_path):
    from matplotlib.figure import Figure
    fig = Figure(figsize=(2, 1))
    fig.add_subplot().plot([0, 1], [0, 1])
    png = tmp_path / "fig13_ramp_pme.png"
    fig.savefig(png)
    (tmp_path / "sweep.md").write_text(SWEEP_MD)
    (tmp_path / "reg.csv").write_text("name,value\nzeta_a,0.2\n")
    (tmp_path / "pme.csv").write_text("contact,pressure_kpa,pme_mean_percent\npoint,6.9,70.0\n")
    out = tmp_path / "r.html"
    uncertainty_report([], [], str(tmp_path / "reg.csv"), str(tmp_path / "pme.csv"), str(tmp_path / "sweep.md"),
                       [str(png)], str(out))
    page = out.read_text()
    assert "<figcaption>Fig. 13: drive-speed point mean error" in page and "data:image/png;base64," in page
    with pytest.raises(RoboballError, match="missing.png: figure not found"):
        uncertainty_report([], [], str(tmp_path / "reg.csv"), str(tmp_path / "pme.csv"), str(tmp_path / "sweep.md"),
                           [str(tmp_path / "missing.png")], str(tmp_path / "r2.html"))
    assert not (tmp_path / "r2.html").exists()


def test_table_page_renders_the_markdown_table(tmp_path):
    md = tmp_path / "table_sweep.md"
    md.write_text(SWEEP_MD)
    out = tmp_path / "t.html"
    table_page(str(md), str(out))
    page = out.read_text()
    assert "<title>Hydroelastic sensitivity sweep (section III-D)</title>" in page
    assert "<td>modulus x0.5</td><td class='num'>30.2</td>" in page and "|" not in page.split("<body>")[1]


def test_the_report_is_the_same_bytes_whatever_the_fits_wall_times(tmp_path):
    """The report is committed in paper_figures/, which reproduces byte for byte: a fit's wall
    time (different every run) is not in it."""
    first = _report(tmp_path)
    for name in ("cv.json", "majd.json"):
        d = json.loads((tmp_path / name).read_text())
        d["timing"]["wall_s"] = 97.5
        (tmp_path / name).write_text(json.dumps(d))
    fits = [str(tmp_path / "cv.json"), str(tmp_path / "majd.json")]
    out = tmp_path / "again.html"
    uncertainty_report(fits, [str(tmp_path / "steer_comparison.csv")], str(tmp_path / "reg.csv"), str(tmp_path / "pme.csv"),
                       str(tmp_path / "sweep.md"), [], str(out), ramp_friction=[])
    assert out.read_text() == first
