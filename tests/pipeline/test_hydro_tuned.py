"""The tuned hydroelastic contact model's parameters at a pressure (roboball.pipeline.simulation):
the calibration's values at its pressures, log-interpolated between them, refused outside, and
handed to Drake as hydroelastic contact with that modulus and dissipation."""
import math

import pandas as pd
import pytest

from roboball.errors import RoboballError
from roboball.pipeline.simulation import shell_params, tuned_at


@pytest.fixture
def files(tmp_path):
    fit = tmp_path / "hydro_tuned.csv"
    pd.DataFrame({"pressure_kpa": [13.8, 6.9], "hydro_modulus_pa": [1.0e4, 4.0e4],
                  "hydro_dissipation_s_m": [0.4, 0.9]}).to_csv(fit, index=False)
    reg = tmp_path / "shell_regression.csv"
    pd.DataFrame({"name": ["zeta_a", "zeta_b", "omega_n_c", "omega_n_d"],
                  "value": [0.23, -0.0386, 2.70, 0.0276]}).to_csv(reg, index=False)
    return str(fit), str(reg)


def test_tuned_values_at_and_between_the_calibrated_pressures(files):
    fit, _ = files
    assert tuned_at(fit, 6.9) == pytest.approx((4.0e4, 0.9))
    m, d = tuned_at(fit, 10.35)                       # halfway: the geometric mean
    assert m == pytest.approx(2.0e4) and d == pytest.approx(math.sqrt(0.4 * 0.9))
    with pytest.raises(RoboballError, match="outside the calibrated"):
        tuned_at(fit, 20.7)
    with pytest.raises(RoboballError, match="needs the hydroelastic calibration"):
        tuned_at("", 13.8)


def test_hydro_tuned_is_drakes_hydroelastic_contact_with_the_calibrated_values(files):
    fit, reg = files
    contact, sp = shell_params("hydro_tuned", 13.8, reg, fit)
    assert contact == "hydroelastic"
    assert (sp.hydro_modulus, sp.hydro_dissipation) == pytest.approx((1.0e4, 0.4))
    contact, sp = shell_params("hydroelastic", 13.8, reg, fit, dissipation_scale=0.5)
    assert contact == "hydroelastic" and sp.hydro_modulus is None and sp.dissipation_scale == 0.5
