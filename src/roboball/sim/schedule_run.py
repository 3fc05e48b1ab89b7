"""A run whose shell follows a pressure schedule (roboball.sim.schedule).

Injected shell: the pressure is an input of the shell's force system (roboball.sim.pressure),
continuous in time; the run is an ordinary scenario run.

Hydroelastic contact: what Drake allows
---------------------------------------
The bedliner's hydroelastic modulus (eq. 10) and Hunt-Crossley dissipation (eq. 11) are
*proximity properties* of its geometry, not inputs: no port can drive them, and nothing inside
a running step may change them.  What Drake does allow is replacing them in the simulation's
context between two `AdvanceTo` calls: `SceneGraph.AssignRole(context, source, geometry,
properties, RoleAssign.kReplace)` rebuilds the compliant mesh's pressure field, and the plant
reads the new dissipation at its next contact query.  The state simply carries on (it is the
same context).  Measured on this machine: a run whose properties are replaced at t = 0 equals
a run built with them bit for bit, and replacing them at t = 1.5 s equals rebuilding the whole
diagram there and copying the plant state across, also bit for bit; one replacement costs about
20 ms (the compliant sphere's mesh field is regenerated).

So `simulate_schedule` runs a hydroelastic schedule as a zero-order hold: before each segment of
`hydro_update_s` it sets modulus and dissipation for the pressure at the segment's midpoint.
That is the honest limit: piecewise constant in time, with a step that is a user choice, not a
continuously varying contact law.  It converges: on the Fig. S1 descent (20.7 -> 6.9 kPa over
3 s, dissipation x0.5) the drive rate at 3 s is 6.611, 6.639, 6.621, 6.617, 6.617 rad/s for
steps of 0.2, 0.1, 0.05, 0.025, 0.0125 s; the default 0.05 s is within 0.1% of the finest.
"""
from __future__ import annotations

from dataclasses import replace

from pydrake.geometry import ProximityProperties, RoleAssign

from roboball.config import RobotFacts
from roboball.errors import RoboballError
from roboball.physics import shell as shell_laws
from roboball.sim.plant import Built
from roboball.sim.scenarios import simulate
from roboball.sim.schedule import PressureSchedule, ShellLaws
from roboball.sim.spec import ShellParams, SimSpec


def _bedliner(built: Built):
    sg = built.scene_graph
    insp = sg.model_inspector()
    for gid in insp.GetAllGeometryIds():
        if insp.GetName(gid).endswith("bedliner_collision"):
            return gid
    raise RoboballError("the plant has no bedliner collision geometry")


def hydro_properties(robot: RobotFacts, shell: ShellParams, laws: ShellLaws, p_kpa: float) -> tuple[float, float]:
    """(modulus Pa, Hunt-Crossley s/m) at pressure p: eq. 10 and eq. 11 (= C_inject(p)) with the
    shell's sensitivity scales, or its fixed overrides."""
    modulus = shell.hydro_modulus if shell.hydro_modulus is not None else \
        shell_laws.hydro_modulus(p_kpa * 1e3, robot.weight_n, robot.radius)
    dissipation = shell.hydro_dissipation if shell.hydro_dissipation is not None else \
        shell_laws.hydro_dissipation(laws.zeta(p_kpa), laws.omega_n(p_kpa), robot.M_eq)
    return modulus * shell.modulus_scale, dissipation * shell.dissipation_scale


def hydro_updater(schedule: PressureSchedule, laws: ShellLaws):
    """A `before_chunk` hook for roboball.sim.scenarios.simulate: before each segment
    [t0, t1] it replaces the bedliner's hydroelastic modulus and dissipation in the running
    context with their values at p((t0 + t1) / 2) (zero-order hold; see the module docstring)."""
    state = {}

    def update(built, context, t0, t1):
        p = float(schedule.at(0.5 * (t0 + t1)))
        modulus, dissipation = hydro_properties(built.robot, built.spec.shell, laws, p)
        if state.get("last") == (modulus, dissipation):
            return
        sg = built.scene_graph
        gid = state.setdefault("gid", _bedliner(built))
        props = ProximityProperties(sg.model_inspector().GetProximityProperties(gid))
        props.UpdateProperty("hydroelastic", "hydroelastic_modulus", float(modulus))
        props.UpdateProperty("material", "hunt_crossley_dissipation", float(dissipation))
        sg.AssignRole(sg.GetMyMutableContextFromRoot(context), built.plant.get_source_id(), gid, props,
                      RoleAssign.kReplace)
        state["last"] = (modulus, dissipation)
        state.setdefault("log", []).append((t0, p, modulus, dissipation))

    return update


def simulate_schedule(spec: SimSpec, schedule: PressureSchedule, laws: ShellLaws, release: float, duration: float,
                      sample_rate_hz: float = 100.0, steer0: float = 0.0, hydro_update_s: float = 0.05,
                      return_states: bool = False, max_wall_s: float | None = None):
    """Run `spec` with the shell following `schedule`; return the recording DataFrame (with a
    pressure_kpa column: the schedule at each sample).

    injected: the pressure is an input of the shell system (continuous, see the module
    docstring); hydroelastic: zero-order hold of the contact properties per `hydro_update_s`
    segment; point: the rigid baseline, which has no pressure (the schedule changes nothing).
    """
    if hydro_update_s <= 0:
        raise RoboballError(f"hydro_update_s {hydro_update_s:g}: must be positive")
    p0 = float(schedule.at(0.0))
    zeta0, omega0 = float(laws.zeta(p0)), float(laws.omega_n(p0))
    shell = replace(spec.shell, zeta=zeta0, omega_n=omega0)
    run_spec = replace(spec, pressure_kpa=p0, shell=shell,
                       pressure_schedule=schedule if spec.contact == "injected" else None, shell_laws=laws)
    kw = dict(sample_rate_hz=sample_rate_hz, steer0=steer0, return_states=return_states, max_wall_s=max_wall_s)
    if spec.contact == "hydroelastic":
        out = simulate(run_spec, release, duration, chunk_s=hydro_update_s,
                       before_chunk=hydro_updater(schedule, laws), **kw)
    else:
        out = simulate(run_spec, release, duration, **kw)
    df = out[0] if return_states else out
    df["pressure_kpa"] = schedule.at(df.time_s.to_numpy())
    return out
