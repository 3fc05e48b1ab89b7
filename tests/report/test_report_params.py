"""`roboball report --params` renders posteriors and PME intervals from existing results
without rerunning anything; missing results give one line."""
import json
import subprocess
import sys

import pandas as pd
import pytest

from roboball.cli.main import main


def _fit(path, joint, law, params, converged=True):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({
        "recording": "steer_stand_r1", "joint": joint, "law": law,
        "parameters": {k: {"median": m, "ci95_low": lo, "ci95_high": hi} for k, (m, lo, hi) in params.items()},
        "convergence": {"steps": 6000, "max_tau": 40.0, "acceptance_fraction": 0.41, "ess_min": 3900.0,
                        "converged": converged},
        "fit": {"rmse_rad": 0.002}, "samples_csv": str(path.with_suffix(".samples.csv"))}))


@pytest.fixture
def results(tmp_path):
    res = tmp_path / "results"
    _fit(res / "friction" / "testbed" / "steer_majd.json", "steer", "majd",
         {"f_w": (0.2013, 0.1876, 0.2151), "f_c": (0.4487, 0.431, 0.466)})
    _fit(res / "friction" / "testbed" / "steer_viscous.json", "steer", "viscous", {"c": (0.1042, 0.1001, 0.1085)},
         converged=False)
    (res / "friction" / "testbed" / "chain_meta.json").write_text('{"note": "not a fit"}')
    pd.DataFrame({"law": ["viscous", "majd"], "bic": [-1200.0, -1452.5]}).to_csv(
        res / "friction" / "testbed" / "steer_comparison.csv", index=False)
    (res / "identify").mkdir(parents=True)
    (res / "identify" / "shell_regression.csv").write_text(
        "name,value,se,ci95_low,ci95_high,unit,n_points,dof\n"
        "zeta_a,0.2282,0.0043,0.2189,0.2376,1,15,13\nzeta_b,-0.03819,0.0016,-0.04174,-0.03465,1/kPa,15,13\n"
        "omega_n_c,2.702,0.0042,2.693,2.711,rad/s,15,13\nomega_n_d,0.02761,0.0003,0.02691,0.02831,rad/s/kPa,15,13\n")
    (res / "ramp").mkdir()
    pd.DataFrame({"recording": ["r1", "r2", "r1", "r2"], "pressure_kpa": [13.8, 13.8, 13.8, 13.8],
                  "contact": ["point", "point", "hydroelastic", "hydroelastic"],
                  "pme_percent": [30.0, 34.0, 4.0, -2.0], "pme_draw_low": [28.0, 31.0, 1.0, -5.0],
                  "pme_draw_high": [33.0, 37.0, 7.0, 1.0]}).to_csv(res / "ramp" / "summary.csv", index=False)
    return tmp_path


def _render(tmp_path, capsys, *extra):
    rc = main(["report", "--params", "--results", str(tmp_path / "results"), "--figures", str(tmp_path / "pf"), *extra])
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_report_lists_posteriors_regressions_and_pme(results, capsys):
    rc, md, _ = _render(results, capsys)
    assert rc == 0
    # friction: medians with intervals, convergence flags, the BIC recommendation
    assert "| steer_stand_r1 | steer | majd | f_w | 0.2013 | [0.1876, 0.2151] | yes |" in md
    assert "| steer_stand_r1 | steer | viscous | c | 0.1042 | [0.1001, 0.1085] | NO |" in md
    assert "**majd** by dBIC = 252.5" in md
    assert "not a fit" not in md
    # shell: regression rows with intervals and eq. 7-8 at 13.8 kPa (zeta 0.1347, omega_n 3.083)
    assert "| zeta_b | -0.03819 | [-0.04174, -0.03465] | 1/kPa | 15 |" in md
    row = next(line for line in md.splitlines() if line.startswith("| 13.8 |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert float(cells[1]) == pytest.approx(0.2282 * 2.718281828 ** (-0.03819 * 13.8), rel=1e-3)
    assert float(cells[2]) == pytest.approx(2.702 + 0.02761 * 13.8, rel=1e-3)
    # PME aggregated from the run table: mean, run range, posterior range, recommendation
    assert "| hydroelastic | 13.8 | 1.0 | [-2.0, 4.0] | [-5.0, 7.0] | 2 |" in md
    assert "| point | 13.8 | 32.0 | [30.0, 34.0] | [28.0, 37.0] | 2 |" in md
    assert "recommended contact model: **hydroelastic**" in md
    assert "Not available yet" not in md


def test_report_prefers_the_paper_pme_table_and_writes_a_file(results, capsys):
    pf = results / "pf"
    pf.mkdir()
    pd.DataFrame({"contact": ["injected"], "pressure_kpa": [6.9], "pme_mean_percent": [12.5], "pme_min_percent": [10.0],
                  "pme_max_percent": [15.0], "runs": [3], "pme_post_low_percent": [8.0],
                  "pme_post_high_percent": [17.0]}).to_csv(pf / "table_pme.csv", index=False)
    out = results / "report.md"
    rc, printed, _ = _render(results, capsys, "--out", str(out))
    assert rc == 0 and f"wrote {out}" in printed
    md = out.read_text()
    assert "| injected | 6.9 | 12.5 | [10.0, 15.0] | [8.0, 17.0] | 3 |" in md and "hydroelastic | 13.8" not in md


def test_partial_results_are_named_missing(results, capsys):
    (results / "results" / "ramp" / "summary.csv").unlink()
    rc, md, _ = _render(results, capsys)
    assert rc == 0 and "Not available yet:" in md and "ramp PME" in md and "Joint friction" in md


def test_no_results_is_one_line_error(tmp_path, capsys):
    rc, out, err = _render(tmp_path, capsys)
    assert rc != 0 and out == ""
    assert err.count("\n") == 1 and "no parameter results yet" in err and "make figures" in err


def test_bad_fit_json_is_one_line_error_naming_file_and_field(results, capsys):
    bad = results / "results" / "friction" / "testbed" / "drive_majd.json"
    bad.write_text(json.dumps({"joint": "drive", "law": "majd", "parameters": {"f_w": {"median": 1.7}}}))
    rc, _, err = _render(results, capsys)
    assert rc != 0 and err.count("\n") == 1
    assert str(bad) in err and "'f_w' has no 'ci95_low'" in err


def test_report_reruns_nothing(results):
    """Rendering must not even load Drake (so no simulation can run) and must be quick."""
    code = ("import sys; from roboball.report.params import render; "
            f"md = render({str(results / 'results')!r}, {str(results / 'pf')!r}); "
            "assert 'pydrake' not in sys.modules and 'emcee' not in sys.modules, sorted(sys.modules)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr[-2000:]


def test_report_never_recommends_an_unconverged_chain(results, capsys):
    pd.DataFrame({"law": ["viscous", "majd"], "bic": [-1200.0, -1452.5], "converged": [True, False]}).to_csv(
        results / "results" / "friction" / "testbed" / "steer_comparison.csv", index=False)
    rc, md, _ = _render(results, capsys)
    assert rc == 0
    assert "**viscous** (majd, of lower BIC, left out: its chain did not converge)" in md
    assert "**majd**" not in md
