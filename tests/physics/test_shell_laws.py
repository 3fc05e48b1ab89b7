"""The shell laws of roboball.physics.shell, checked against independent computations: the
injected stiffness and damping (eq. 7-8) give a rocking shell exactly the omega_n and zeta asked
for, eq. 9 opposes the motion, and the contact volume of eq. 10 is a spherical cap's volume."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from roboball.config import load_robot
from roboball.physics import shell

ROBOT = load_robot()


@pytest.mark.parametrize("zeta, omega_n", [(0.18, 2.45), (0.10, 2.75), (0.06, 3.05)])
def test_injected_terms_give_the_requested_frequency_and_damping_ratio(zeta, omega_n):
    m_eq, k_eq = ROBOT.M_eq, ROBOT.K_eq
    k = shell.k_inject(omega_n, m_eq, k_eq)
    c = shell.c_inject(zeta, omega_n, m_eq)
    # m_eq q'' + c q' + (k_eq + k) q = 0: eigenvalues -zeta w +- i w sqrt(1 - zeta^2)
    lam = np.roots([m_eq, c, k_eq + k])
    assert np.allclose(np.abs(lam), omega_n, rtol=1e-12)
    assert np.allclose(-lam.real / np.abs(lam), zeta, rtol=1e-12)


def test_eq9_torque_opposes_deflection_and_rate():
    assert shell.injected_torque(0.1, 0.0, 5.0, 2.0) == pytest.approx(-0.5)
    assert shell.injected_torque(0.0, -0.3, 5.0, 2.0) == pytest.approx(0.6)


@pytest.mark.parametrize("p_kpa", [6.9, 13.8, 20.7])
def test_contact_volume_is_the_cap_cut_off_by_the_patch(p_kpa):
    """Patch area W / p; the cap of a sphere of radius R whose flat has that area, integrated
    slice by slice."""
    w, r = ROBOT.weight_n, ROBOT.radius
    a2 = w / (p_kpa * 1e3) / math.pi
    depth = r - math.sqrt(r * r - a2)
    v, _ = quad(lambda z: math.pi * (r * r - z * z), r - depth, r)
    assert shell.contact_volume(p_kpa * 1e3, w, r) == pytest.approx(v, rel=1e-10)
    assert shell.hydro_modulus(p_kpa * 1e3, w, r) == pytest.approx(w / v, rel=1e-10)


def test_modulus_rises_with_pressure_and_is_near_the_authors_default_at_13_8_kpa():
    w, r = ROBOT.weight_n, ROBOT.radius
    e = [shell.hydro_modulus(p * 1e3, w, r) for p in (6.9, 10.3, 13.8, 17.2, 20.7)]
    assert all(b > a for a, b in zip(e, e[1:]))
    assert e[2] == pytest.approx(1.74e6, rel=0.005)                   # the module docstring's value
    assert e[2] == pytest.approx(ROBOT.data["hydroelastic_defaults"]["modulus_pa"], rel=0.05)


def test_regressions_and_injected_terms_at_hand_values():
    """Eq. 6 regressions and eq. 7-8 typed from the paper at one state."""
    assert shell.zeta_of_p(13.8, 0.3, -0.05) == pytest.approx(0.3 * 0.5015760690660556, rel=1e-12)  # e^-0.69
    assert shell.omega_n_of_p(13.8, 2.2, 0.04) == pytest.approx(2.752, rel=1e-12)
    assert shell.k_inject(2.5, 4.0, 10.0) == pytest.approx(15.0)        # 2.5^2 * 4 - 10
    assert shell.c_inject(0.1, 2.5, 4.0) == pytest.approx(2.0)          # 2 * 4 * 2.5 * 0.1


def test_contact_volume_at_a_hand_value_and_a_patch_as_wide_as_the_shell():
    """W = pi N, R = 1 m: at p = 4 Pa the patch has a = 0.5 m, depth 1 - sqrt(0.75), volume
    pi h^2 (3 - h) / 3 = 0.0538708 m^3; at p = 1 Pa the patch is the shell's equator (a = R),
    which the membrane model cannot carry and refuses."""
    assert shell.contact_volume(4.0, math.pi, 1.0) == pytest.approx(0.05387081762970044, rel=1e-12)
    with pytest.raises(ValueError, match="too low"):
        shell.contact_volume(1.0, math.pi, 1.0)


def test_impossible_pressures_are_refused():
    with pytest.raises(ValueError, match="positive"):
        shell.contact_volume(0.0, ROBOT.weight_n, ROBOT.radius)
    with pytest.raises(ValueError, match="too low"):
        shell.contact_volume(1e3, ROBOT.weight_n, ROBOT.radius)     # 1 kPa: patch wider than the shell


def test_eq11_dissipation_is_c_inject_and_the_drake_plant_takes_it_from_that_law(monkeypatch):
    from roboball.sim import shell as sim_shell
    from roboball.sim.shell import shell_tags
    from roboball.sim.spec import ShellParams, SimSpec

    assert shell.hydro_dissipation(0.1, 2.7, ROBOT.M_eq) == shell.c_inject(0.1, 2.7, ROBOT.M_eq)
    spec = SimSpec(kind="shell_rock", contact="hydroelastic", pressure_kpa=13.8,
                   shell=ShellParams(zeta=0.1, omega_n=2.7, dissipation_scale=1.5, modulus_scale=0.5))
    tags = shell_tags(ROBOT, spec)
    assert tags.hunt_crossley == pytest.approx(1.5 * shell.c_inject(0.1, 2.7, ROBOT.M_eq))
    assert tags.hydro_modulus == pytest.approx(0.5 * shell.hydro_modulus(13.8e3, ROBOT.weight_n, ROBOT.radius))
    # one source: editing eq. 11's function changes what Drake gets
    monkeypatch.setattr(sim_shell.shell_laws, "hydro_dissipation", lambda zeta, omega_n, m_eq: 7.0)
    assert shell_tags(ROBOT, spec).hunt_crossley == pytest.approx(10.5)
    # a hydroelastic spec without the shell's zeta and omega_n is refused
    with pytest.raises(ValueError, match="needs the shell's zeta and omega_n"):
        shell_tags(ROBOT, SimSpec(kind="shell_rock", contact="hydroelastic", pressure_kpa=13.8))


def test_the_pressure_schedule_takes_eq10_and_eq11_from_the_laws(monkeypatch):
    from roboball.sim import schedule_run
    from roboball.sim.schedule import ShellLaws
    from roboball.sim.spec import ShellParams

    laws = ShellLaws(zeta_a=0.3, zeta_b=-0.05, omega_n_c=2.2, omega_n_d=0.04)
    m, c = schedule_run.hydro_properties(ROBOT, ShellParams(dissipation_scale=2.0), laws, 10.0)
    assert c == pytest.approx(2.0 * shell.c_inject(laws.zeta(10.0), laws.omega_n(10.0), ROBOT.M_eq))
    assert m == pytest.approx(shell.hydro_modulus(10.0e3, ROBOT.weight_n, ROBOT.radius))
    monkeypatch.setattr(schedule_run.shell_laws, "hydro_dissipation", lambda zeta, omega_n, m_eq: 7.0)
    assert schedule_run.hydro_properties(ROBOT, ShellParams(), laws, 10.0)[1] == 7.0
