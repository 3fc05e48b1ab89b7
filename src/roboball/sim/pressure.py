"""Shell pressure that changes during a run (beyond the paper, section V).

The paper sets the shell's contact parameters before a simulation, so a run has one pressure.
Here a run can follow a schedule p(t): a table of (time_s, pressure_kpa) points, linear between
them and held constant before the first and after the last.

Injected shell: continuous, no Python in the loop
-------------------------------------------------
`pressure_shell_system` is a system with two inputs, the plant state and the pressure (kPa), and
one output, the generalised force.  It evaluates the Fig. 10 regressions zeta(p) = a exp(b p),
omega_n(p) = c + d p and eq. 7-8 (K_inject(p), C_inject(p)) on the pressure *input* inside one
Drake `SymbolicVectorSystem`, with the same law functions as the constant-pressure model
(roboball.physics.shell), so Drake evaluates them in C++ at every step.  The schedule feeds it
through a `TrajectorySource` of a first-order-hold `PiecewisePolynomial`:

    TrajectorySource p(t) --pressure_kpa--> [ SymbolicVectorSystem(x, p) -> tau ] --> plant
    plant state -----------plant_state----------^

`scheduled_shell_system` packages the two as one diagram with the plant-state input and the
generalised-force output, the shape `roboball.sim.plant.build` wires into the plant (it is used
when `SimSpec.pressure_schedule` is set and the contact is "injected").

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

import csv
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from roboball.errors import RoboballError
from roboball.physics import shell as shell_laws

P_MAX_KPA = 500.0


# ---- the schedule ------------------------------------------------------------------------
@dataclass(frozen=True)
class PressureSchedule:
    """p(t): pressures (kPa gauge) at increasing times (s); linear between points, held at the
    ends.  One point is a constant pressure."""

    times_s: tuple
    pressures_kpa: tuple
    source: str = "schedule"

    def __post_init__(self):
        t = np.asarray(self.times_s, float)
        p = np.asarray(self.pressures_kpa, float)
        where = self.source
        if t.ndim != 1 or t.shape != p.shape or len(t) == 0:
            raise RoboballError(f"{where}: a pressure schedule needs equally many times and pressures, at least one")
        for i, (ti, pi) in enumerate(zip(t, p), start=1):
            if not (math.isfinite(ti) and math.isfinite(pi)):
                raise RoboballError(f"{where}: row {i}: time and pressure must be finite numbers")
            if not 0.0 < pi <= P_MAX_KPA:
                raise RoboballError(f"{where}: row {i}: pressure_kpa {pi:g} outside (0, {P_MAX_KPA:g}] kPa gauge")
            if ti < 0.0:
                raise RoboballError(f"{where}: row {i}: time_s {ti:g} is negative")
        bad = np.nonzero(np.diff(t) <= 0)[0]
        if len(bad):
            i = int(bad[0]) + 2
            raise RoboballError(f"{where}: row {i}: time_s {t[i - 1]:g} does not increase (previous {t[i - 2]:g})")
        object.__setattr__(self, "times_s", tuple(float(x) for x in t))
        object.__setattr__(self, "pressures_kpa", tuple(float(x) for x in p))

    # -- construction
    @classmethod
    def constant(cls, p_kpa: float) -> "PressureSchedule":
        return cls((0.0,), (float(p_kpa),), source=f"constant {p_kpa:g} kPa")

    @classmethod
    def linear(cls, p_start_kpa: float, p_end_kpa: float, t_start_s: float, t_end_s: float) -> "PressureSchedule":
        """From p_start (held until t_start) linearly to p_end at t_end (held after)."""
        if not t_end_s > t_start_s:
            raise RoboballError(f"linear pressure schedule: t_end_s {t_end_s:g} must be after t_start_s {t_start_s:g}")
        return cls((float(t_start_s), float(t_end_s)), (float(p_start_kpa), float(p_end_kpa)),
                   source=f"linear {p_start_kpa:g} -> {p_end_kpa:g} kPa over {t_start_s:g}-{t_end_s:g} s")

    @classmethod
    def from_csv(cls, path) -> "PressureSchedule":
        """A CSV with columns time_s, pressure_kpa (one row per point)."""
        path = Path(path)
        if not path.is_file():
            raise RoboballError(f"{path}: pressure schedule not found")
        with open(path, newline="", encoding="utf-8") as fh:
            reader = csv.DictReader(fh)
            cols = [c.strip() for c in (reader.fieldnames or [])]
            for need in ("time_s", "pressure_kpa"):
                if need not in cols:
                    raise RoboballError(f"{path}: missing column '{need}' (columns: {', '.join(cols) or 'none'})")
            times, pressures = [], []
            for i, row in enumerate(reader, start=1):
                row = {k.strip(): v for k, v in row.items() if k is not None}
                try:
                    times.append(float(row["time_s"]))
                    pressures.append(float(row["pressure_kpa"]))
                except (TypeError, ValueError):
                    raise RoboballError(f"{path}: row {i}: time_s '{row.get('time_s')}' / pressure_kpa "
                                        f"'{row.get('pressure_kpa')}' is not a number")
        if not times:
            raise RoboballError(f"{path}: pressure schedule has no rows")
        return cls(tuple(times), tuple(pressures), source=str(path))

    @classmethod
    def from_config(cls, cfg, where: str = "pressure_schedule") -> "PressureSchedule":
        """From a config entry: a number (constant), {csv: path}, {time_s: [...], pressure_kpa: [...]}
        or {start_kpa, end_kpa, t_start_s, t_end_s} (linear)."""
        if isinstance(cfg, (int, float)) and not isinstance(cfg, bool):
            return cls((0.0,), (float(cfg),), source=where)
        if not isinstance(cfg, dict):
            raise RoboballError(f"{where}: expected a number or a mapping, got {type(cfg).__name__}")
        if "csv" in cfg:
            return cls.from_csv(cfg["csv"])
        if "time_s" in cfg or "pressure_kpa" in cfg:
            try:
                return cls(tuple(cfg["time_s"]), tuple(cfg["pressure_kpa"]), source=where)
            except KeyError as exc:
                raise RoboballError(f"{where}: missing '{exc.args[0]}'")
            except TypeError:
                raise RoboballError(f"{where}: time_s and pressure_kpa must be lists of numbers")
        keys = ("start_kpa", "end_kpa", "t_start_s", "t_end_s")
        if all(k in cfg for k in keys):
            return cls.linear(*(float(cfg[k]) for k in keys))
        raise RoboballError(f"{where}: give csv, time_s + pressure_kpa, or {', '.join(keys)}")

    # -- evaluation
    def at(self, t):
        """p(t) in kPa (NumPy; held constant outside the table)."""
        return np.interp(t, self.times_s, self.pressures_kpa)

    @property
    def is_constant(self) -> bool:
        return len(set(self.pressures_kpa)) == 1

    def trajectory(self):
        """The schedule as a Drake first-order-hold PiecewisePolynomial (1 x 1); Drake holds the
        end values outside the breaks, as `at` does."""
        from pydrake.trajectories import PiecewisePolynomial

        t, p = list(self.times_s), list(self.pressures_kpa)
        if len(t) == 1:
            t, p = [t[0], t[0] + 1.0], [p[0], p[0]]
        return PiecewisePolynomial.FirstOrderHold(t, np.array([p], dtype=float))

    def describe(self) -> str:
        pts = ", ".join(f"{t:g} s: {p:g} kPa" for t, p in zip(self.times_s, self.pressures_kpa))
        return f"pressure schedule [{pts}]"


# ---- the regression laws ------------------------------------------------------------------
@dataclass(frozen=True)
class ShellLaws:
    """The Fig. 10 regressions: zeta(p) = a exp(b p), omega_n(p) = c + d p (p in kPa)."""

    zeta_a: float
    zeta_b: float
    omega_n_c: float
    omega_n_d: float

    @classmethod
    def from_regression_csv(cls, path) -> "ShellLaws":
        """From the pipeline's shell regression table (rows zeta_a, zeta_b, omega_n_c, omega_n_d)."""
        path = Path(path)
        if not path.is_file():
            raise RoboballError(f"{path}: shell regression table not found (run the pipeline's shell_regression rule)")
        values = {}
        with open(path, newline="", encoding="utf-8") as fh:
            for row in csv.DictReader(fh):
                try:
                    values[row["name"]] = float(row["value"])
                except (KeyError, TypeError, ValueError):
                    raise RoboballError(f"{path}: row {row}: needs columns name, value with a number")
        missing = [k for k in ("zeta_a", "zeta_b", "omega_n_c", "omega_n_d") if k not in values]
        if missing:
            raise RoboballError(f"{path}: missing rows {', '.join(missing)}")
        return cls(values["zeta_a"], values["zeta_b"], values["omega_n_c"], values["omega_n_d"])

    def zeta(self, p_kpa, m=None):
        from roboball.physics.mathns import NP
        return shell_laws.zeta_of_p(p_kpa, self.zeta_a, self.zeta_b, m=m or NP)

    def omega_n(self, p_kpa):
        return shell_laws.omega_n_of_p(p_kpa, self.omega_n_c, self.omega_n_d)

    def coefficients(self, p_kpa, robot, m=None):
        """(K_inject, C_inject) at pressure p (eq. 7-8); p may be symbolic (then m=SYM)."""
        omega = self.omega_n(p_kpa)
        return (shell_laws.k_inject(omega, robot.M_eq, robot.K_eq),
                shell_laws.c_inject(self.zeta(p_kpa, m=m), omega, robot.M_eq))


# ---- systems ---------------------------------------------------------------------------------
def pressure_shell_system(layout, laws: ShellLaws, robot, shell=None, normal=(0.0, 0.0, 1.0)):
    """Injected shell with pressure as an input: a Diagram with input ports `plant_state`
    ([q; v]) and `pressure_kpa` (1) and output port `generalized_force` (nv).  `shell` (a
    ShellParams) picks the geometry (planar / 3d) and the planar model's directions."""
    import pydrake.symbolic as sym
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import Multiplexer, SymbolicVectorSystem

    from roboball.sim.forces import SYM, Kin
    from roboball.sim.plant import ShellParams, injected_term

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


def scheduled_shell_system(layout, laws: ShellLaws, robot, schedule: PressureSchedule, shell=None,
                           normal=(0.0, 0.0, 1.0)):
    """`pressure_shell_system` fed by the schedule: input `plant_state`, outputs
    `generalized_force` and `pressure_kpa` (the schedule, for logging)."""
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import TrajectorySource

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


# ---- runs ------------------------------------------------------------------------------------
def _bedliner(built):
    sg = built.scene_graph
    insp = sg.model_inspector()
    for gid in insp.GetAllGeometryIds():
        if insp.GetName(gid).endswith("bedliner_collision"):
            return gid
    raise RoboballError("the plant has no bedliner collision geometry")


def hydro_properties(robot, shell, laws: ShellLaws, p_kpa: float) -> tuple[float, float]:
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
    from pydrake.geometry import ProximityProperties, RoleAssign

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


def simulate_schedule(spec, schedule: PressureSchedule, laws: ShellLaws, release: float, duration: float,
                      sample_rate_hz: float = 100.0, steer0: float = 0.0, hydro_update_s: float = 0.05,
                      return_states: bool = False, max_wall_s: float | None = None):
    """Run `spec` with the shell following `schedule`; return the recording DataFrame (with a
    pressure_kpa column: the schedule at each sample).

    injected: the pressure is an input of the shell system (continuous, see the module
    docstring); hydroelastic: zero-order hold of the contact properties per `hydro_update_s`
    segment; point: the rigid baseline, which has no pressure (the schedule changes nothing).
    """
    from roboball.sim.scenarios import simulate

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
