"""The shell in a Drake run: the injected force term and the bedliner's contact tags of a spec.

* injected contact: eq. 9 as a force term (`injected_term`, planar or 3-D) with K_inject and
  C_inject from the spec's zeta and omega_n (eq. 7-8, `shell_coefficients`);
* hydroelastic contact: the bedliner's modulus (eq. 10) and Hunt-Crossley dissipation (eq. 11)
  written into the URDF (`shell_tags`).

The laws themselves are `roboball.physics.shell`'s; nothing here re-implements one.
"""
from __future__ import annotations

from dataclasses import replace

from roboball.config import RobotFacts
from roboball.physics import shell as shell_laws
from roboball.sim.forces import ForceTerm, InjectedShell
from roboball.sim.shell3d import InjectedShell3D
from roboball.sim.spec import GEOMETRIES, ShellParams, SimSpec
from roboball.sim.urdf import ShellTags


def _require_shell_rocking(spec: SimSpec) -> None:
    """Refuse a spec whose contact needs the shell's zeta and omega_n but lacks them."""
    if spec.shell.zeta is None or spec.shell.omega_n is None:
        raise ValueError(f"contact '{spec.contact}' needs the shell's zeta and omega_n at the pressure "
                         "(pass --zeta/--omega-n or a shell regression table)")


def shell_coefficients(robot: RobotFacts, spec: SimSpec) -> tuple[float, float]:
    """(K_inject, C_inject) from the spec's zeta and omega_n (eq. 7-8)."""
    _require_shell_rocking(spec)
    sp = spec.shell
    k = shell_laws.k_inject(sp.omega_n, robot.M_eq, robot.K_eq)
    c = shell_laws.c_inject(sp.zeta, sp.omega_n, robot.M_eq)
    return k, c


def injected_term(k, c, shell: ShellParams, normal=(0.0, 0.0, 1.0)) -> ForceTerm:
    """The injected-shell force term for `shell.geometry`: the paper's planar eq. 9 or the 3-D
    version (roboball.sim.shell3d).  k, c may be numbers or symbolic expressions."""
    if shell.geometry == "planar":
        return InjectedShell(k, c, steer=shell.injected_steer, drive=shell.injected_drive)
    if shell.geometry == "3d":
        return InjectedShell3D(k, c, normal=tuple(float(x) for x in normal))
    raise ValueError(f"unknown injected-shell geometry '{shell.geometry}' (choose from {', '.join(GEOMETRIES)})")


def shell_tags(robot: RobotFacts, spec: SimSpec) -> ShellTags:
    """Contact properties of the bedliner for this spec (eq. 10-11 for hydroelastic), starting
    from the robot facts' own (ShellTags.of, what an exported URDF carries)."""
    facts = ShellTags.of(robot)
    hint = spec.resolution_hint or facts.resolution_hint
    modulus, dissipation = facts.hydro_modulus, facts.hunt_crossley
    if spec.contact == "hydroelastic":
        sp = spec.shell
        if sp.hydro_modulus is not None:
            modulus = sp.hydro_modulus
        elif spec.pressure_kpa is not None:
            modulus = shell_laws.hydro_modulus(spec.pressure_kpa * 1e3, robot.weight_n, robot.radius)
        if sp.hydro_dissipation is not None:
            dissipation = sp.hydro_dissipation
        else:
            _require_shell_rocking(spec)
            dissipation = shell_laws.hydro_dissipation(sp.zeta, sp.omega_n, robot.M_eq)
        modulus *= sp.modulus_scale
        dissipation *= sp.dissipation_scale
    return replace(facts, hydro_modulus=modulus, hunt_crossley=dissipation, resolution_hint=hint)
