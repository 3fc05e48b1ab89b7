"""What a Drake run is: the scenario, its contact model, joint friction and shell terms.

`SimSpec` names everything `roboball.sim.plant.build` needs to build the diagram and
`roboball.sim.scenarios.simulate` needs to run it; `ShellParams` holds the shell's terms at one
pressure.  Plain data, no Drake: specs are written by the pipeline stages, the CLI and the test
bed, and printed in failure messages (`roboball.sim.scenarios.describe`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable

from roboball.config import RobotFacts, load_robot
from roboball.sim.schedule import PressureSchedule, ShellLaws

if TYPE_CHECKING:
    from pydrake.systems.framework import System

    from roboball.sim.forces import ForceTerm, StateLayout

CONTACTS = ("point", "injected", "hydroelastic")      # SimSpec.contact
GEOMETRIES = ("planar", "3d")                         # ShellParams.geometry


@dataclass
class ShellParams:
    """Shell terms at one pressure.  zeta/omega_n drive the injected model (eq. 7-8) and the
    hydroelastic dissipation (eq. 11); hydro_modulus defaults to eq. 10."""

    zeta: float | None = None
    omega_n: float | None = None
    hydro_modulus: float | None = None          # Pa; None -> eq. 10 at the pressure
    hydro_dissipation: float | None = None      # s/m; None -> eq. 11 (C_inject)
    modulus_scale: float = 1.0                  # sensitivity sweep factors (section III-D)
    dissipation_scale: float = 1.0
    injected_steer: bool = True                 # injected K, C about the steer (roll) direction
    injected_drive: bool = True                 # injected C about the driveshaft (section IV)
    # "planar": eq. 9 in the steer plane + drive damping (paper); "3d": roboball.sim.shell3d,
    # K on the base's tilt and C on the pipe's rolling rate about both horizontal axes (the
    # steer/drive flags above are the planar model's; the 3-D model always has both terms).
    geometry: str = "planar"


@dataclass
class SimSpec:
    """One Drake scenario run (see the module docstring)."""

    kind: str
    contact: str = "point"
    friction: dict = field(default_factory=lambda: {"steer": "none", "drive": "none"})
    friction_params: dict = field(default_factory=dict)   # joint -> params (default Table I)
    # joint -> reflected rotor inertia J N^2 (kg m^2) the URDF leaves out (a calibrated stand's
    # delta_i): a joint actuator with the joint's gear ratio N and rotor inertia delta_i / N^2
    added_inertia: dict = field(default_factory=dict)
    pressure_kpa: float | None = None
    shell: ShellParams = field(default_factory=ShellParams)
    dt: float = 1e-3
    ramp_angle_deg: float | None = None
    extra_terms: list[ForceTerm] = field(default_factory=list)    # additional force terms (diagnosis)
    lock_joints: tuple = ()                               # extra joints emitted as fixed
    approximation: str | None = None                      # discrete contact approximation (None: approximation_for)
    # fn(layout, dt) -> System: state in, tau out
    extra_systems: list[Callable[[StateLayout, float], System]] = field(default_factory=list)
    resolution_hint: float | None = None                  # override the hydroelastic mesh hint (m)
    ramp_length_m: float | None = None                    # finite ramp ending on a flat floor
    robot: RobotFacts | None = None
    heading_deg: float = 0.0                              # yaw of the whole scene about world z (ground + release)
    # Time-varying pressure (roboball.sim.schedule): with contact "injected" the shell follows
    # pressure_schedule through shell_laws (zeta(p), omega_n(p)) as an input, instead of fixed
    # K, C; hydroelastic schedules are run by roboball.sim.schedule_run.simulate_schedule.
    pressure_schedule: PressureSchedule | None = None
    shell_laws: ShellLaws | None = None
    # Drake's sampled output ports (its default) or outputs computed on demand (ours, see build()).
    # With only stateless force systems in the loop (every model here) the two give bit-identical
    # runs; with a discrete-state system beside the plant (the test bed's LuGre friction) they
    # differ by the step at which that system sees the plant's state, so the virtual test bed
    # keeps Drake's default and its campaign regenerates bit-for-bit.
    sampled_output_ports: bool = False

    def resolved_robot(self) -> RobotFacts:
        return self.robot if self.robot is not None else load_robot()
