"""The discrete contact approximation is chosen on purpose: `lagged` honours eq. 11's
Hunt-Crossley dissipation; `sap` would silently ignore it (drake-notes.md)."""
import pytest
from pydrake.multibody.plant import DiscreteContactApproximation

from conftest import fit_damped
from roboball.sim.plant import APPROXIMATION, ShellParams, SimSpec, build
from roboball.sim.scenarios import simulate


def _zeta(approximation, dissipation):
    spec = SimSpec(kind="shell_rock", contact="hydroelastic", pressure_kpa=6.9, approximation=approximation,
                   shell=ShellParams(hydro_dissipation=dissipation, hydro_modulus=4.2e5))
    df = simulate(spec, 0.1, 6.0, sample_rate_hz=100)
    return fit_damped(df.time_s, df.pipe_angle_rad)["zeta"]


def test_default_approximation_is_lagged():
    assert APPROXIMATION == "lagged"
    built = build(SimSpec(kind="shell_rock"))
    assert built.plant.get_discrete_contact_approximation() == DiscreteContactApproximation.kLagged


def test_lagged_uses_hunt_crossley_and_sap_does_not():
    lo, hi = _zeta("lagged", 1.0), _zeta("lagged", 2.0)
    # Rolling dissipation of the hydroelastic shell scales with the Hunt-Crossley coefficient.
    assert hi / lo == pytest.approx(2.0, rel=0.25)
    assert lo > 0.02
    s_lo, s_hi = _zeta("sap", 1.0), _zeta("sap", 2.0)
    assert s_hi / s_lo == pytest.approx(1.0, abs=0.1)
