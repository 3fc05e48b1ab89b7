"""Outer-shell laws of the paper (section III).

* Injected shell (eq. 6-9): the pressure-dependent zeta(p), omega_n(p) fixed by the shell
  tests define K_inject = omega_n^2 M_eq - K_eq (eq. 7) and C_inject = 2 M_eq omega_n zeta
  (eq. 8); the generalised torque on the rolling coordinate is tau = -C phi_dot - K phi (eq. 9).
  In the drive direction only the damping term is kept, with phi_dot -> drive rate (sec. IV).
* Hydroelastic (eq. 10-11): modulus = f_n / V(p), dissipation = C_inject (numerically, as the
  paper does), each with a scale factor for the sensitivity sweep.

Contact-volume model V(p)
-------------------------
For an inflated membrane the gauge pressure carries the load over the contact patch, so the
patch area is A = f_n / p (membrane limit: the skin's bending stiffness is negligible).  The
undeformed sphere that has a flat of radius a = sqrt(A / pi) intersects the ground in a cap of
depth delta = R - sqrt(R^2 - a^2) and volume V = pi delta^2 (3 R - delta) / 3.  At 13.8 kPa for
the 41.3 kg robot this gives V = 2.33e-4 m^3 and a modulus of 1.74e6 Pa, near the authors' default
of 1.8e6 Pa (tests/physics/test_shell_laws.py).

Eq. 10 read the other way, V = f_n / modulus, turns the moduli the hydroelastic calibration fits
(roboball.identify.shell.hydro) into contact volumes; `contact_volume_power` is the power law
V(p) = V_ref (p / p_ref)^k that the calibration fits through them.
"""
from __future__ import annotations

import math

from roboball.physics.mathns import NP


# ---- regressions over pressure (Fig. 10) ----------------------------------------------
def zeta_of_p(p_kpa, a, b, m=NP):
    """Damping ratio regression: zeta(p) = a exp(b p), p in kPa."""
    return a * m.exp(b * p_kpa)


def omega_n_of_p(p_kpa, c, d):
    """Natural-frequency regression: omega_n(p) = c + d p (rad/s), p in kPa."""
    return c + d * p_kpa


# ---- injected dynamics (eq. 7-9) --------------------------------------------------------
def k_inject(omega_n, m_eq, k_eq):
    """Eq. 7: stiffness to add so that the shell rocks at omega_n (N m/rad)."""
    return omega_n ** 2 * m_eq - k_eq


def c_inject(zeta, omega_n, m_eq):
    """Eq. 8: damping to add so that the shell rocks with damping ratio zeta (N m s/rad)."""
    return 2.0 * m_eq * omega_n * zeta


def injected_torque(angle, rate, k, c):
    """Eq. 9: generalised torque on the rolling coordinate (N m)."""
    return -c * rate - k * angle


# ---- hydroelastic (eq. 10-11) ------------------------------------------------------------
def contact_volume(p_pa: float, weight_n: float, radius_m: float) -> float:
    """Membrane contact-volume model V(p) (m^3); see the module docstring."""
    if p_pa <= 0:
        raise ValueError("pressure must be positive")
    area = weight_n / p_pa
    a2 = area / math.pi
    if a2 >= radius_m ** 2:
        raise ValueError(f"pressure {p_pa:.0f} Pa too low: contact patch exceeds the shell")
    delta = radius_m - math.sqrt(radius_m ** 2 - a2)
    return math.pi * delta ** 2 * (3.0 * radius_m - delta) / 3.0


def hydro_modulus(p_pa: float, weight_n: float, radius_m: float) -> float:
    """Eq. 10: hydroelastic modulus f_n / V(p) (Pa), V(p) the membrane model."""
    return modulus_of_volume(weight_n, contact_volume(p_pa, weight_n, radius_m))


def modulus_of_volume(weight_n, volume_m3):
    """Eq. 10: hydroelastic modulus f_n / V (Pa) of a contact volume V (m^3)."""
    return weight_n / volume_m3


def volume_of_modulus(weight_n, modulus_pa):
    """Eq. 10 inverted: the contact volume V = f_n / modulus (m^3) a modulus (Pa) stands for."""
    return weight_n / modulus_pa


def contact_volume_power(p_pa, v_ref_m3, p_ref_pa, exponent):
    """Power-law contact volume V(p) = V_ref (p / p_ref)^k (m^3), the law fitted through the
    calibrated moduli (k < 0: the patch shrinks as the shell stiffens)."""
    return v_ref_m3 * (p_pa / p_ref_pa) ** exponent


def hydro_dissipation(zeta, omega_n, m_eq):
    """Eq. 11: Hunt-Crossley dissipation taken numerically equal to C_inject (s/m)."""
    return c_inject(zeta, omega_n, m_eq)
