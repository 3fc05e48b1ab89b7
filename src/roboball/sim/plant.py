"""One plant-building path for every scenario.

`build(spec)` (a `roboball.sim.spec.SimSpec`) generates the URDF variant for the scenario from
the robot facts, adds it to a discrete MultibodyPlant, welds or grounds it as the experiment
requires, and wires the generalised-force system (joint friction, injected shell, extra effects)
into the plant's applied-generalised-force port.  Diagram, read top to bottom:

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
  `tests/sim/test_contact_approximation.py` checks the choices, the Hunt-Crossley dependence under
  both, the equivalence and the fallback.  The virtual test bed keeps `lagged` everywhere.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
from pydrake.geometry import (AddRigidHydroelasticProperties, HalfSpace, ProximityProperties,
                              SceneGraph)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import (AddMultibodyPlant, CoulombFriction, MultibodyPlant,
                                     MultibodyPlantConfig)
from pydrake.multibody.parsing import Parser
from pydrake.systems.framework import Diagram, DiagramBuilder, System
from pydrake.systems.primitives import Adder, LogVectorOutput, SymbolicVectorSystem, VectorLogSink

from roboball.config import RobotFacts
from roboball.kinds import NOT_YET, SIMULATED, not_yet_message
from roboball.physics import friction as friction_laws
from roboball.sim.forces import ForceTerm, JointFriction, StateLayout, build_force_system
from roboball.sim.pressure import scheduled_shell_system
from roboball.sim.shell import injected_term, shell_coefficients, shell_tags
from roboball.sim.spec import CONTACTS, SimSpec
from roboball.sim.urdf import ShellTags, make_urdf

APPROXIMATION = "lagged"            # point and injected contact
HYDRO_APPROXIMATION = "tamsi"       # hydroelastic contact (falls back to APPROXIMATION where Drake lacks it)
_AVAILABLE: dict = {}


def approximation_available(name: str) -> bool:
    """Whether this Drake build offers the discrete contact approximation `name`."""
    if name not in _AVAILABLE:
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
    # the coupled steer test: on the floor, pendulum free on its steer joint; the drive motor
    # holds the pipe to the pitch centre (the shell rocks sideways, it does not roll forward)
    "steer_coupled": dict(fixed=("drive",), root="pitch_center", welded=False),
}


@dataclass
class Built:
    """A built scenario: the diagram and the parts a run reads (see `build`)."""

    diagram: Diagram
    plant: MultibodyPlant
    scene_graph: SceneGraph
    layout: StateLayout
    spec: SimSpec
    robot: RobotFacts
    injected: ForceTerm | None                    # the injected-shell term (constant pressure)
    shell_tags: ShellTags
    logger: VectorLogSink | None = None
    force_system: SymbolicVectorSystem | None = None
    ramp_alpha: float = 0.0                       # slope of the ground (rad), 0 on the flat
    ground_normal: np.ndarray | None = None       # unit normal of the ground in the world
    pressure_system: Diagram | None = None        # the scheduled injected shell (pressure input)


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
    """Build the diagram for `spec`, step by step in Drake's order: the plant with the robot
    and its ground, the generalised-force systems, logging (and a visualiser).

    Args:
        spec: the scenario.
        sample_period: adds a state logger at that period (s).
        meshcat: a Meshcat instance to visualise the run in, or None.
    Returns:
        The :class:`Built` diagram and its parts.
    """
    _check_spec(spec)
    robot = spec.resolved_robot()
    tags = shell_tags(robot, spec)
    urdf = _scenario_urdf(spec, robot, tags)

    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(_plant_config(spec), builder)
    alpha = _add_robot(plant, spec, robot, urdf)
    layout = _layout(plant)

    terms = _joint_friction(spec, robot)
    normal = ground_normal(alpha, spec.heading_deg)
    injected, pressure_system = _shell_force(spec, robot, layout, normal)
    if injected is not None:
        terms.append(injected)
    terms.extend(spec.extra_terms)
    force_system = build_force_system(layout, terms)
    sources = [force_system] if force_system is not None else []
    if pressure_system is not None:
        sources.append(pressure_system)
    sources += [make(layout, spec.dt) for make in spec.extra_systems]
    _apply_forces(builder, plant, layout, sources)

    logger = None
    if sample_period is not None:
        logger = LogVectorOutput(plant.get_state_output_port(), builder, sample_period)
    if meshcat is not None:
        from pydrake.geometry import MeshcatVisualizer
        MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat)
    diagram = builder.Build()
    return Built(diagram, plant, scene_graph, layout, spec, robot, injected, tags, logger, force_system,
                 ramp_alpha=alpha, ground_normal=normal, pressure_system=pressure_system)


def _check_spec(spec: SimSpec) -> None:
    if spec.kind in NOT_YET["simulation scenarios"]:
        raise ValueError(not_yet_message(spec.kind, "simulation scenarios"))
    if spec.kind not in SIMULATED:
        raise ValueError(f"unknown kind '{spec.kind}' (choose from {', '.join(SIMULATED)})")
    if spec.contact not in CONTACTS:
        raise ValueError(f"unknown contact model '{spec.contact}' (choose from {', '.join(CONTACTS)})")
    if spec.pressure_schedule is not None and spec.contact == "hydroelastic":
        raise ValueError("hydroelastic contact properties cannot follow a pressure schedule inside one step: "
                         "run the schedule with roboball.sim.schedule_run.simulate_schedule (properties replaced "
                         "between segments)")


def _scenario_urdf(spec: SimSpec, robot: RobotFacts, tags: ShellTags) -> str:
    """The robot's URDF with the scenario's fixed joints and root (and any locked by the spec)."""
    lay = _LAYOUT[spec.kind]
    fixed = tuple(sorted(set(lay["fixed"]) | set(spec.lock_joints)))
    return make_urdf(robot, fixed_joints=fixed, root=lay["root"], shell=tags)


def _plant_config(spec: SimSpec) -> MultibodyPlantConfig:
    return MultibodyPlantConfig(
        time_step=spec.dt,
        # Outputs computed from the current state on demand, not sampled at every step: with
        # sampled ports (Drake's default) the plant computes and stores its contact results,
        # reaction forces and every other output port each step although only the state port is
        # read here.  With the models' stateless force systems trajectories are bit-identical
        # (tests/sim/test_drake_physics.py); a ramp step costs about 2.4x less (benchmarks/sim_speed.py).
        use_sampled_output_ports=spec.sampled_output_ports,
        discrete_contact_approximation=spec.approximation or approximation_for(spec.contact),
        contact_model="hydroelastic_with_fallback" if spec.contact == "hydroelastic" else "point",
    )


def _add_robot(plant: MultibodyPlant, spec: SimSpec, robot: RobotFacts, urdf: str) -> float:
    """Parse the robot, weld it (stands) or give it its ground, set gravity and finalise the
    plant; returns the ground's slope (rad)."""
    lay = _LAYOUT[spec.kind]
    Parser(plant).AddModelsFromString(urdf, "urdf")
    _add_rotors(plant, spec, robot)
    if lay["welded"]:
        plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(lay["root"]))
        alpha = 0.0
    else:
        ramp = spec.ramp_angle_deg if spec.ramp_angle_deg is not None else robot.ramp_angle_deg
        alpha = _ground(plant, robot, spec.kind, ramp, spec.ramp_length_m, spec.heading_deg)
    plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, -robot.g])
    plant.Finalize()
    return alpha


def _add_rotors(plant: MultibodyPlant, spec: SimSpec, robot: RobotFacts) -> None:
    """A joint actuator on each joint given an added inertia, whose rotor (inertia delta_i / N^2
    behind the joint's gear ratio N, configs/robot.yaml) adds its reflected inertia N^2 J =
    delta_i to the joint's diagonal of the mass matrix.  A negative delta_i (a fit's correction
    of the URDF's inertia, configs/priors.yaml; never a rotor) is added the same way.  The
    actuation input is left unconnected (no motor torque: the generalised forces are applied
    through their own port)."""
    for joint, delta_i in spec.added_inertia.items():
        if not delta_i:
            continue
        if joint not in robot.joints:
            raise ValueError(f"added inertia on unknown joint '{joint}' (choose from {', '.join(robot.joints)})")
        j = plant.GetJointByName(joint)
        if j.num_velocities() != 1:
            continue                      # locked in this scenario: nothing turns the rotor
        n = float(robot.joints[joint]["gear_ratio"])
        motor = plant.AddJointActuator(f"{joint}_motor", j)
        motor.set_default_gear_ratio(n)
        motor.set_default_rotor_inertia(float(delta_i) / n ** 2)


def _joint_friction(spec: SimSpec, robot: RobotFacts) -> list[ForceTerm]:
    """The friction law of each joint (Table I parameters unless the spec gives its own)."""
    terms = []
    for joint in ("steer", "drive"):
        law = spec.friction.get(joint, "none")
        if law not in friction_laws.LAWS:
            raise ValueError(f"unknown friction law '{law}' (choose from {', '.join(friction_laws.LAWS)})")
        params = spec.friction_params.get(joint) or friction_laws.table1_params(robot, law, joint)
        terms.append(JointFriction(joint, law, params))
    return terms


def _shell_force(spec: SimSpec, robot: RobotFacts, layout: StateLayout, normal):
    """(injected-shell term at constant pressure, or None; scheduled-pressure shell system, or
    None): only injected contact of a robot on the ground has either."""
    if spec.contact != "injected" or layout.base_v is None:
        return None, None
    if spec.pressure_schedule is None:
        k, c = shell_coefficients(robot, spec)
        return injected_term(k, c, spec.shell, normal), None
    if spec.shell_laws is None:
        raise ValueError("a pressure schedule needs the shell's regression laws zeta(p), omega_n(p) "
                         "(SimSpec.shell_laws, e.g. from results/identify/shell_regression.csv)")
    return None, scheduled_shell_system(layout, spec.shell_laws, robot, spec.pressure_schedule, spec.shell, normal)


def _apply_forces(builder: DiagramBuilder, plant: MultibodyPlant, layout: StateLayout, sources: list[System]) -> None:
    """Feed the plant state to every force source and their sum to the applied-force port."""
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
