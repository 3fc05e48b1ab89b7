"""One plant-building path for every scenario.

`build(spec)` generates the URDF variant for the scenario from the robot facts, adds it to a
discrete MultibodyPlant, welds or grounds it as the experiment requires, and wires the
generalised-force system (joint friction, injected shell, extra effects) into the plant's
applied-generalised-force port.  Diagram, read top to bottom:

    robot.yaml --make_urdf--> MultibodyPlant <--tau-- SymbolicVectorSystem(friction + shell)
                                   |  state  ----------------^
                                   +--> VectorLogSink (sampled recording)

Output ports are not sampled (`use_sampled_output_ports=False`, `SimSpec.sampled_output_ports`):
the plant evaluates them from the current state when asked, and only the state port is read.
The virtual test bed keeps Drake's sampled ports (its campaign is the experiment).

Discrete contact approximations, chosen on purpose (`approximation_for`):

* point and injected contact: `lagged` (Drake's default).  The paper's eq. 11 specifies a
  Hunt-Crossley dissipation (s/m); `lagged` and `similar` honour it for point and hydroelastic
  contact, `sap` ignores it and uses a relaxation time instead (drake-notes.md: a hydroelastic
  ball on 16 deg rolls at 3.98 rad/s under sap vs 9.03 under lagged/similar; rigid analytic 10.9).
* hydroelastic contact: `tamsi`, which honours the same Hunt-Crossley dissipation and, for this
  robot, gives the same hydroelastic model as `lagged`: converged ramp descents (0.25 ms) agree to
  0.01% PME (13.8 kPa), the pipeline's shell tests and sweep to 0.07% in zeta and 0.003% in
  omega_n, and its recorded ramp descents at 1 ms to 0.4% PME at 6.9 kPa (the softest shell),
  0.04% at 10.3 kPa and < 0.01% above.  TAMSI solves the small
  problem of this robot (8 dofs, ~20 contact polygons) about 3x faster: a hydroelastic ramp
  descent at 1 ms runs at ~18x real time instead of ~6x (benchmarks/hydro_speed_options.py).
  Drake has deprecated TAMSI (removal announced for after 2026-09-01; drake 1.51.1, the last
  release for Python 3.11, still has it): where it is gone, hydroelastic runs fall back to
  `lagged` with a warning, and the results move by at most 0.4%.
  `tests/test_contact_approximation.py` checks the choices, the Hunt-Crossley dependence under
  both, the equivalence and the fallback.  The virtual test bed keeps `lagged` everywhere.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from pydrake.geometry import (AddRigidHydroelasticProperties, HalfSpace, ProximityProperties,
                              SceneGraph)
from pydrake.math import RigidTransform, RotationMatrix, RollPitchYaw
from pydrake.multibody.plant import (AddMultibodyPlant, CoulombFriction, MultibodyPlantConfig)
from pydrake.multibody.parsing import Parser
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import Adder, LogVectorOutput

from roboball.config import RobotFacts, load_robot
from roboball.kinds import NOT_YET, SIMULATED, not_yet_message
from roboball.physics import friction as friction_laws
from roboball.physics import shell as shell_laws
from roboball.sim.urdf import ShellTags, make_urdf
from roboball.sim.forces import InjectedShell, JointFriction, StateLayout, build_force_system

KINDS = SIMULATED
CONTACTS = ("point", "injected", "hydroelastic")
APPROXIMATION = "lagged"            # point and injected contact
HYDRO_APPROXIMATION = "tamsi"       # hydroelastic contact (falls back to APPROXIMATION where Drake lacks it)
_AVAILABLE: dict = {}


def approximation_available(name: str) -> bool:
    """Whether this Drake build offers the discrete contact approximation `name`."""
    if name not in _AVAILABLE:
        import warnings

        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                AddMultibodyPlant(MultibodyPlantConfig(time_step=1e-3, discrete_contact_approximation=name),
                                  DiagramBuilder())
            _AVAILABLE[name] = True
        except (RuntimeError, ValueError):
            _AVAILABLE[name] = False
    return _AVAILABLE[name]


def approximation_for(contact: str) -> str:
    """The discrete contact approximation of a contact model (see the module docstring)."""
    if contact == "hydroelastic":
        if approximation_available(HYDRO_APPROXIMATION):
            return HYDRO_APPROXIMATION
        import warnings
        warnings.warn(f"this Drake has no '{HYDRO_APPROXIMATION}' contact approximation: hydroelastic runs use "
                      f"'{APPROXIMATION}' (same model, results within 0.4%, about 3x slower)", stacklevel=2)
    return APPROXIMATION

# Per scenario: joints emitted as fixed, tree root, whether the root is welded (stand).
_LAYOUT = {
    "steer_stand": dict(fixed=("drive",), root="pitch_center", welded=True),
    "drive_stand": dict(fixed=("steer",), root="pipe_assembly", welded=True),
    "shell_rock": dict(fixed=("steer", "drive"), root="pitch_center", welded=False),
    "ramp": dict(fixed=(), root="pitch_center", welded=False),
    "free": dict(fixed=(), root="pitch_center", welded=False),
}


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
    kind: str
    contact: str = "point"
    friction: dict = field(default_factory=lambda: {"steer": "none", "drive": "none"})
    friction_params: dict = field(default_factory=dict)   # joint -> params (default Table I)
    pressure_kpa: float | None = None
    shell: ShellParams = field(default_factory=ShellParams)
    dt: float = 1e-3
    ramp_angle_deg: float | None = None
    extra_terms: list = field(default_factory=list)       # additional ForceTerms (diagnosis)
    lock_joints: tuple = ()                               # extra joints emitted as fixed
    approximation: str | None = None                      # discrete contact approximation (None: approximation_for)
    extra_systems: list = field(default_factory=list)     # fn(layout, dt) -> System: state in, tau out
    resolution_hint: float | None = None                  # override the hydroelastic mesh hint (m)
    ramp_length_m: float | None = None                    # finite ramp ending on a flat floor
    robot: RobotFacts | None = None
    heading_deg: float = 0.0                              # yaw of the whole scene about world z (ground + release)
    # Time-varying pressure (roboball.sim.pressure): with contact "injected" the shell follows
    # pressure_schedule (a PressureSchedule) through shell_laws (ShellLaws: zeta(p), omega_n(p))
    # as an input, instead of fixed K, C; hydroelastic schedules are run by pressure.simulate_schedule.
    pressure_schedule: object = None
    shell_laws: object = None
    # Drake's sampled output ports (its default) or outputs computed on demand (ours, see build()).
    # With only stateless force systems in the loop (every model here) the two give bit-identical
    # runs; with a discrete-state system beside the plant (the test bed's LuGre friction) they
    # differ by the step at which that system sees the plant's state, so the virtual test bed
    # keeps Drake's default and its campaign regenerates bit-for-bit.
    sampled_output_ports: bool = False

    def resolved_robot(self) -> RobotFacts:
        return self.robot if self.robot is not None else load_robot()


@dataclass
class Built:
    diagram: object
    plant: object
    scene_graph: object
    layout: StateLayout
    spec: SimSpec
    robot: RobotFacts
    injected: InjectedShell | None
    shell_tags: ShellTags
    logger: object = None
    force_system: object = None


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


GEOMETRIES = ("planar", "3d")


def injected_term(k, c, shell: ShellParams, normal=(0.0, 0.0, 1.0)):
    """The injected-shell force term for `shell.geometry`: the paper's planar eq. 9 or the 3-D
    version (roboball.sim.shell3d).  k, c may be numbers or symbolic expressions."""
    if shell.geometry == "planar":
        return InjectedShell(k, c, steer=shell.injected_steer, drive=shell.injected_drive)
    if shell.geometry == "3d":
        from roboball.sim.shell3d import InjectedShell3D
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


def ground_normal(alpha: float, heading_deg: float = 0.0) -> np.ndarray:
    """Unit normal of the ground in the world: (sin a, 0, cos a) for a ramp of slope a that
    descends towards +x, turned by the scene's heading about world z."""
    n = np.array([math.sin(alpha), 0.0, math.cos(alpha)])
    if heading_deg:
        n = RotationMatrix.MakeZRotation(math.radians(heading_deg)).multiply(n)
    return n


def _ground(plant, robot: RobotFacts, kind: str, ramp_angle_deg: float, ramp_length_m=None,
            heading_deg: float = 0.0):
    """Rigid ground: a half-space (tilted for the ramp so that downhill is +x, then turned by
    `heading_deg` about world z).  A finite ramp of length L (along the slope, from the robot's
    start) ends on a flat floor L sin(alpha) below the start: a second half-space meeting the
    ramp in a concave corner."""
    mu = float(robot.data["shell"]["ground_friction"])
    props = ProximityProperties()
    props.AddProperty("material", "coulomb_friction", CoulombFriction(mu, mu))
    AddRigidHydroelasticProperties(props)
    alpha = math.radians(ramp_angle_deg) if kind == "ramp" else 0.0
    # HalfSpace's outward normal is +z of its frame; pitch it by +alpha about y so that the
    # surface descends towards +x.
    R_WG = RotationMatrix.MakeYRotation(alpha)
    if heading_deg:
        R_WG = RotationMatrix.MakeZRotation(math.radians(heading_deg)).multiply(R_WG)
    X_WG = RigidTransform(R_WG, [0.0, 0.0, 0.0])
    plant.RegisterCollisionGeometry(plant.world_body(), X_WG, HalfSpace(), "ground", props)
    if kind == "ramp" and ramp_length_m is not None:
        X_WF = RigidTransform([0.0, 0.0, -ramp_length_m * math.sin(alpha)])
        plant.RegisterCollisionGeometry(plant.world_body(), X_WF, HalfSpace(), "floor", props)
    return alpha


def _layout(plant) -> StateLayout:
    lay = StateLayout(nq=plant.num_positions(), nv=plant.num_velocities())
    for name in ("steer", "drive"):
        if plant.HasJointNamed(name):
            j = plant.GetJointByName(name)
            if j.num_velocities() == 1:
                lay.joint_q[name] = j.position_start()
                lay.joint_v[name] = j.velocity_start()
    body = plant.GetBodyByName("pitch_center")
    if body.is_floating_base_body():
        lay.base_q = body.floating_positions_start()
        lay.base_v = body.floating_velocities_start_in_v()
    return lay


def build(spec: SimSpec, sample_period: float | None = None, meshcat=None) -> Built:
    """Build the diagram for `spec`.  `sample_period` adds a state logger at that period."""
    if spec.kind in NOT_YET["simulation scenarios"]:
        raise ValueError(not_yet_message(spec.kind, "simulation scenarios"))
    if spec.kind not in KINDS:
        raise ValueError(f"unknown kind '{spec.kind}' (choose from {', '.join(KINDS)})")
    if spec.contact not in CONTACTS:
        raise ValueError(f"unknown contact model '{spec.contact}' (choose from {', '.join(CONTACTS)})")
    if spec.pressure_schedule is not None and spec.contact == "hydroelastic":
        raise ValueError("hydroelastic contact properties cannot follow a pressure schedule inside one step: "
                         "run the schedule with roboball.sim.pressure.simulate_schedule (properties replaced "
                         "between segments)")
    robot = spec.resolved_robot()
    lay = _LAYOUT[spec.kind]
    tags = shell_tags(robot, spec)
    fixed = tuple(sorted(set(lay["fixed"]) | set(spec.lock_joints)))
    urdf = make_urdf(robot, fixed_joints=fixed, root=lay["root"], shell=tags)

    builder = DiagramBuilder()
    cfg = MultibodyPlantConfig(
        time_step=spec.dt,
        # Outputs computed from the current state on demand, not sampled at every step: with
        # sampled ports (Drake's default) the plant computes and stores its contact results,
        # reaction forces and every other output port each step although only the state port is
        # read here.  With the models' stateless force systems trajectories are bit-identical
        # (tests/test_drake_physics.py); a ramp step costs about 2.4x less (benchmarks/sim_speed.py).
        use_sampled_output_ports=spec.sampled_output_ports,
        discrete_contact_approximation=spec.approximation or approximation_for(spec.contact),
        contact_model="hydroelastic_with_fallback" if spec.contact == "hydroelastic" else "point",
    )
    plant, scene_graph = AddMultibodyPlant(cfg, builder)
    Parser(plant).AddModelsFromString(urdf, "urdf")
    if lay["welded"]:
        plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(lay["root"]))
        alpha = 0.0
    else:
        ramp = spec.ramp_angle_deg if spec.ramp_angle_deg is not None else robot.ramp_angle_deg
        alpha = _ground(plant, robot, spec.kind, ramp, spec.ramp_length_m, spec.heading_deg)
    plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, -robot.g])
    plant.Finalize()
    layout = _layout(plant)

    terms = []
    for joint in ("steer", "drive"):
        law = spec.friction.get(joint, "none")
        if law not in friction_laws.LAWS:
            raise ValueError(f"unknown friction law '{law}' (choose from {', '.join(friction_laws.LAWS)})")
        params = spec.friction_params.get(joint) or friction_laws.table1_params(robot, law, joint)
        terms.append(JointFriction(joint, law, params))
    injected = None
    normal = ground_normal(alpha, spec.heading_deg)
    pressure_system = None
    if spec.contact == "injected" and layout.base_v is not None:
        if spec.pressure_schedule is not None:
            if spec.shell_laws is None:
                raise ValueError("a pressure schedule needs the shell's regression laws zeta(p), omega_n(p) "
                                 "(SimSpec.shell_laws, e.g. from results/identify/shell_regression.csv)")
            from roboball.sim.pressure import scheduled_shell_system
            pressure_system = scheduled_shell_system(layout, spec.shell_laws, robot, spec.pressure_schedule,
                                                     spec.shell, normal)
        else:
            k, c = shell_coefficients(robot, spec)
            injected = injected_term(k, c, spec.shell, normal)
            terms.append(injected)
    terms.extend(spec.extra_terms)
    force_system = build_force_system(layout, terms)
    sources = [force_system] if force_system is not None else []
    if pressure_system is not None:
        sources.append(pressure_system)
    sources += [make(layout, spec.dt) for make in spec.extra_systems]
    for system in sources:
        builder.AddSystem(system)
        builder.Connect(plant.get_state_output_port(), system.get_input_port(0))
    if len(sources) == 1:
        builder.Connect(sources[0].get_output_port(0), plant.get_applied_generalized_force_input_port())
    elif len(sources) > 1:
        adder = builder.AddSystem(Adder(len(sources), layout.nv))
        for k, system in enumerate(sources):
            builder.Connect(system.get_output_port(0), adder.get_input_port(k))
        builder.Connect(adder.get_output_port(0), plant.get_applied_generalized_force_input_port())

    logger = None
    if sample_period is not None:
        logger = LogVectorOutput(plant.get_state_output_port(), builder, sample_period)
    if meshcat is not None:
        from pydrake.geometry import MeshcatVisualizer
        MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat)
    diagram = builder.Build()
    built = Built(diagram, plant, scene_graph, layout, spec, robot, injected, tags, logger, force_system)
    built.ramp_alpha = alpha
    built.ground_normal = normal
    built.pressure_system = pressure_system
    return built
