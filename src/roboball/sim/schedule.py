"""Shell pressure that changes during a run (beyond the paper, section V): the schedule p(t) and
the shell's regression laws of pressure.

The paper sets the shell's contact parameters before a simulation, so a run has one pressure.
Here a run can follow a schedule p(t): a table of (time_s, pressure_kpa) points, linear between
them and held constant before the first and after the last.  :class:`ShellLaws` turns a
pressure into the shell's terms (Fig. 10's zeta(p), omega_n(p), then eq. 7-8).  How a schedule
enters a run: `roboball.sim.pressure` (injected shell: the pressure is an input of its force
system) and `roboball.sim.schedule_run` (the run, and the hydroelastic contact's zero-order hold).
Nothing here imports Drake until a schedule is turned into a Drake trajectory.
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from roboball.errors import RoboballError
from roboball.physics import shell as shell_laws

P_MAX_KPA = 500.0


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
        rows = ("zeta_a", "zeta_b", "omega_n_c", "omega_n_d")     # the constructor's order
        missing = [k for k in rows if k not in values]
        if missing:
            raise RoboballError(f"{path}: missing rows {', '.join(missing)}")
        for k in rows:
            if not math.isfinite(values[k]):
                raise RoboballError(f"{path}: row {k}: value {values[k]!r} is not a finite number")
        if not values["zeta_a"] > 0:      # zeta(p) = a exp(b p) is a damping ratio, > 0 at every p
            raise RoboballError(f"{path}: row zeta_a: value {values['zeta_a']!r} must be > 0")
        return cls(*(values[k] for k in rows))

    @property
    def pressure_free(self) -> bool:
        """Laws that do not depend on pressure (a campaign's shell releases at one pressure or
        at none logged: roboball.pipeline.ident.shell_constant_laws)."""
        return self.zeta_b == 0.0 and self.omega_n_d == 0.0

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
