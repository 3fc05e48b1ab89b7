"""Issue 25, acceptance 2: the tuned hydroelastic model reproduces the recorded zeta and omega_n
within 10% at every pressure, with intervals.  Checked on the calibration stage's output as
committed with the figures (paper_figures/table_hydro_tuned.csv, written by `make figures` from
results/identify/hydro_tuned.csv), and, where a run's results/ are present, on the independent
Drake shell runs of the tuned model (results/shell_sim/hydro_tuned) against the recorded releases."""
import numpy as np
import pandas as pd
import pytest
from conftest import REPO

from roboball.identify.shell.hydro import acceptance_failures
from roboball.ingest.manifest import read_manifest

TABLE = REPO / "paper_figures" / "table_hydro_tuned.csv"
RESULTS = REPO / "results"


# Not met on the twin's campaign (docs/modelling.md): its locked shell rocks at 3.67-4.31 rad/s and
# Drake's hydroelastic shell reaches 3.16-3.17 at the softest modulus that still holds the robot
# (1e4 Pa, 138 mm deep; softer, past half its radius): -14.0% to -26.5%, zeta within 0.4%.
NOT_MET = ("measured: 6.9 kPa omega_n 3.167 (Drake) vs 4.307 rad/s (recorded), -26.5%: no hydroelastic "
           "shell that holds the robot is that stiff")


def test_every_campaign_pressure_is_calibrated_with_an_interval():
    table = pd.read_csv(TABLE)
    shell = [float(r["pressure_kpa"]) for r in read_manifest(str(REPO / "raw_data")).values()
             if r["kind"] == "shell_rock"]
    assert sorted(set(shell)) == sorted(table.pressure_kpa)
    assert (table.hydro_modulus_ci95_high_pa > table.hydro_modulus_ci95_low_pa).sum() >= len(table) - table.at_grid_bound.sum()


@pytest.mark.xfail(strict=True, reason=NOT_MET)
def test_tuned_hydroelastic_reproduces_the_recorded_shell_within_10_percent():
    assert acceptance_failures(pd.read_csv(TABLE)) == []


def test_the_check_fails_on_a_miss_and_on_a_broken_interval():
    table = pd.read_csv(TABLE)
    # the committed rows made to pass (Drake's values set to the recorded ones), so each planted
    # fault is the only failure; the committed table itself fails (above)
    table["zeta_drake"], table["omega_n_drake_rad_s"] = table.zeta_recorded, table.omega_n_recorded_rad_s
    assert len(table) >= 2 and acceptance_failures(table) == []
    bad = table.copy()
    bad.loc[0, "omega_n_drake_rad_s"] = 1.11 * bad.loc[0, "omega_n_recorded_rad_s"]
    assert len(acceptance_failures(bad)) == 1
    bad = table.copy()
    bad.loc[len(bad) - 1, "hydro_dissipation_ci95_high_s_m"] = 0.5 * bad.loc[len(bad) - 1, "hydro_dissipation_s_m"]
    assert "outside its interval" in acceptance_failures(bad)[0]


@pytest.mark.xfail(strict=True, reason=NOT_MET)
def test_independent_drake_runs_of_the_tuned_shell_agree_with_the_recordings():
    sims, points = RESULTS / "shell_sim" / "summary.csv", RESULTS / "identify" / "shell_points.csv"
    if not (sims.is_file() and points.is_file()):
        pytest.skip("no pipeline results here (run make figures)")
    s = pd.read_csv(sims)
    s = s[s.contact == "hydro_tuned"]
    if s.empty:
        pytest.skip("results/ predate the tuned hydroelastic model")
    sim = s.groupby("pressure_kpa")[["zeta", "omega_n_rad_s"]].mean()
    rec = pd.read_csv(points).groupby("pressure_kpa")[["zeta", "omega_n_rad_s"]].mean()
    err = 100 * (sim / rec.loc[sim.index] - 1)
    assert set(sim.index) == set(rec.index)
    assert np.all(err.abs().to_numpy() <= 10), err
