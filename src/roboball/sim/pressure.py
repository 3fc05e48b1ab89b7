"""Force systems of the injected shell with the shell's pressure as an input.

`pressure_shell_system` is a system with two inputs, the plant state and the pressure (kPa), and
one output, the generalised force.  It evaluates the Fig. 10 regressions zeta(p) = a exp(b p),
omega_n(p) = c + d p and eq. 7-8 (K_inject(p), C_inject(p)) on the pressure *input* inside one
Drake `SymbolicVectorSystem`, with the same law functions as the constant-pressure model
(roboball.physics.shell), so Drake evaluates them in C++ at every step: continuous in time, no
Python in the loop.  The schedule (roboball.sim.schedule) feeds it through a `TrajectorySource`
of a first-order-hold `PiecewisePolynomial`:

    TrajectorySource p(t) --pressure_kpa--> [ SymbolicVectorSystem(x, p) -> tau ] --> plant
    plant state -----------plant_state----------^

`scheduled_shell_system` packages the two as one diagram with the plant-state input and the
generalised-force output, the shape `roboball.sim.plant.build` wires into the plant (it is used
when `SimSpec.pressure_schedule` is set and the contact is "injected").  Hydroelastic contact
cannot take the pressure as an input: see roboball.sim.schedule_run.
"""
from __future__ import annotations

import numpy as np
import pydrake.symbolic as sym
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import Multiplexer, SymbolicVectorSystem, TrajectorySource

from roboball.config import RobotFacts
from roboball.sim.forces import SYM, Kin, StateLayout
from roboball.sim.schedule import PressureSchedule, ShellLaws
from roboball.sim.shell import injected_term
from roboball.sim.spec import ShellParams


def pressure_shell_system(layout: StateLayout, laws: ShellLaws, robot: RobotFacts, shell: ShellParams | None = None,
                          normal=(0.0, 0.0, 1.0)) -> Diagram:
    """Injected shell with pressure as an input: a Diagram with input ports `plant_state`
    ([q; v]) and `pressure_kpa` (1) and output port `generalized_force` (nv).  `shell` (a
    ShellParams) picks the geometry (planar / 3d) and the planar model's directions."""
    shell = shell if shell is not None else ShellParams()
    q = np.array([sym.Variable(f"q{i}") for i in range(layout.nq)], dtype=object)
    v = np.array([sym.Variable(f"v{i}") for i in range(layout.nv)], dtype=object)
    p = sym.Variable("pressure_kpa")
    k, c = laws.coefficients(p, robot, m=SYM)
    term = injected_term(k, c, shell, normal)
    tau = [sym.Expression(0.0) for _ in range(layout.nv)]
    for idx, expr in term.expressions(Kin(layout, q, v, SYM)):
        tau[idx] = tau[idx] + expr
    law = SymbolicVectorSystem(state=[], input=np.concatenate([q, v, [p]]), output=np.array(tau, dtype=object))
    law.set_name(f"{term.name}(p)")

    builder = DiagramBuilder()
    builder.AddSystem(law)
    mux = builder.AddSystem(Multiplexer([layout.nq + layout.nv, 1]))
    builder.Connect(mux.get_output_port(0), law.get_input_port(0))
    builder.ExportInput(mux.get_input_port(0), "plant_state")
    builder.ExportInput(mux.get_input_port(1), "pressure_kpa")
    builder.ExportOutput(law.get_output_port(0), "generalized_force")
    diagram = builder.Build()
    diagram.set_name("pressure_injected_shell")
    return diagram


def scheduled_shell_system(layout: StateLayout, laws: ShellLaws, robot: RobotFacts, schedule: PressureSchedule,
                           shell: ShellParams | None = None, normal=(0.0, 0.0, 1.0)) -> Diagram:
    """`pressure_shell_system` fed by the schedule: input `plant_state`, outputs
    `generalized_force` and `pressure_kpa` (the schedule, for logging)."""
    builder = DiagramBuilder()
    shell_sys = builder.AddSystem(pressure_shell_system(layout, laws, robot, shell, normal))
    source = builder.AddSystem(TrajectorySource(schedule.trajectory()))
    source.set_name("pressure_schedule")
    builder.Connect(source.get_output_port(0), shell_sys.GetInputPort("pressure_kpa"))
    builder.ExportInput(shell_sys.GetInputPort("plant_state"), "plant_state")
    builder.ExportOutput(shell_sys.GetOutputPort("generalized_force"), "generalized_force")
    builder.ExportOutput(source.get_output_port(0), "pressure_kpa")
    diagram = builder.Build()
    diagram.set_name("scheduled_injected_shell")
    return diagram
