"""Configuration checks that run before any work starts.

The YAML files in ``configs/`` are validated against their JSON schemas in ``configs/schema/``
(``<name>.yaml`` against ``<name>.schema.yaml``: unknown keys, wrong types, values out of
range such as a negative mass, a negative friction coefficient or a time step above 10 ms).
A schema cannot see physics that involves several values at once, so the robot facts get
a second look here:

* every link's principal moments of inertia satisfy the triangle inequality (no rigid body
  has ``I_xx > I_yy + I_zz``; Drake would refuse the model with a long message much later);
* the locked-steer shell has a stable rest: ``M_eq > 0`` and ``K_eq > 0`` in eq. 4-5, i.e. the
  hanging links' centre of mass is below the shell centre (otherwise ``omega_n`` is imaginary);
* both stand pendulums hang below their joint axes (their restoring ``m g d > 0``).

The friction priors (``configs/priors.yaml``) get the cross-field checks a schema cannot express:
every law lists exactly its parameters, ``low < high``, and the starting value inside the bounds.

The pipeline (Snakefile) and ``roboball simulate`` call these checks before running anything;
``roboball check-config`` runs them on demand.  Every failure is a one-line
:class:`~roboball.errors.ConfigError` naming the file, the field and what to do.
"""
from __future__ import annotations

from pathlib import Path

from roboball.config import SCHEMA_DIR, RobotFacts, load_yaml
from roboball.errors import ConfigError

__all__ = ["check_robot", "check_priors", "check_config_dir", "load_checked_robot"]


def check_robot(robot: RobotFacts) -> RobotFacts:
    """Physical checks on validated robot facts (see module docstring); returns `robot`."""
    src = robot.source
    for name, link in robot.links.items():
        ixx, iyy, izz = link.inertia_kg_m2
        for label, a, b, c in (("xx", ixx, iyy, izz), ("yy", iyy, izz, ixx), ("zz", izz, ixx, iyy)):
            if a > b + c:
                raise ConfigError(
                    f"{src}: field 'links.{name}.inertia_kg_m2': I_{label} = {a:g} exceeds the sum of the "
                    f"other two ({b:g} + {c:g}), impossible for a rigid body; check the inertia values and units (kg m^2)")
    hanging = [robot.links["pitch_center"], robot.links["pendulum"]]
    m_r = sum(l.mass_kg * (-l.com_m[2]) for l in hanging)
    if not m_r > 0:
        raise ConfigError(
            f"{src}: field 'links.*.com_m': the pitch centre and pendulum centre of mass is not below the "
            f"shell centre (sum m z = {-m_r:g} kg m >= 0), so K_eq <= 0 and the shell has no rest (eq. 4-5); "
            "com_m is in the link frame with z up")
    terms = robot.shell_terms
    if not terms["M_eq"] > 0:
        raise ConfigError(
            f"{src}: fields 'links' and 'shell.radius_m': M_eq = {terms['M_eq']:g} kg m^2 <= 0 (eq. 4); "
            "check the masses, centres of mass and the shell radius")
    pend = robot.links["pendulum"]
    if not pend.com_m[2] < 0:
        raise ConfigError(
            f"{src}: field 'links.pendulum.com_m': z = {pend.com_m[2]:g} m is not below the steer axis; "
            "the steer-stand pendulum must hang below it (z up)")
    return robot


def check_priors(data: dict, source: str) -> dict:
    """Cross-field checks of the friction priors (the schema checks each value): every law lists
    exactly the parameters it fits, ``low < high``, and ``start`` (and a lognormal's median)
    lies inside the bounds.  Returns `data`."""
    from roboball.physics.friction import FIT_PARAMS

    for joint, laws in data.items():
        for law, params in laws.items():
            # the stand's calibration (its names are the schema's); a law lists what fits sample
            wanted = set(params) if law == "stand" else set(FIT_PARAMS[law])
            where = f"{source}: field '{joint}.{law}'"
            missing, extra = sorted(wanted - set(params)), sorted(set(params) - wanted)
            if missing:
                raise ConfigError(f"{where}: no prior for {', '.join(missing)}; give each parameter of the "
                                  f"{law} law a prior ({', '.join(sorted(wanted))})")
            if extra:
                raise ConfigError(f"{where}: {', '.join(extra)} is not a parameter of the {law} law "
                                  f"({', '.join(sorted(wanted))}); remove it")
            for name, pr in params.items():
                lo, hi = pr.get("low", 0.0), pr.get("high", float("inf"))
                field = f"{source}: field '{joint}.{law}.{name}'"
                if not lo < hi:
                    raise ConfigError(f"{field}: low {lo:g} is not below high {hi:g}; swap or fix the bounds")
                for key in ("start", "median", "value"):
                    if key in pr and not lo < pr[key] < hi:
                        raise ConfigError(f"{field}: {key} {pr[key]:g} is outside the bounds ({lo:g}, {hi:g}); "
                                          "move it inside")
    return data


def load_checked_robot(path: str | Path, schema: str | Path | None = None) -> RobotFacts:
    """Load robot facts from `path`, validate them against `schema` (default: the
    ``schema/robot.schema.yaml`` next to the file, else the package's) and check their physics."""
    path = Path(path)
    if schema is None:
        local = path.parent / "schema" / "robot.schema.yaml"
        schema = local if local.exists() else SCHEMA_DIR / "robot.schema.yaml"
    # load_yaml resolves the schema inside SCHEMA_DIR; an absolute path overrides that.
    data = load_yaml(path, schema=str(Path(schema).resolve()))
    return check_robot(RobotFacts(data, source=str(path)))


def check_config_dir(config_dir: str | Path, exclude: tuple[str, ...] = ()) -> list[Path]:
    """Validate every ``<name>.yaml`` in `config_dir` that has ``schema/<name>.schema.yaml``
    (robot.yaml also through :func:`check_robot`), except the file names in `exclude`.

    A YAML file without a schema is only parsed.  Returns the files checked; raises
    :class:`ConfigError` (one line) at the first problem."""
    config_dir = Path(config_dir)
    if not config_dir.is_dir():
        raise ConfigError(f"{config_dir}: configuration folder not found")
    checked = []
    for path in sorted(config_dir.glob("*.yaml")):
        if path.name in exclude:
            continue
        schema = config_dir / "schema" / f"{path.stem}.schema.yaml"
        if path.name == "robot.yaml":
            load_checked_robot(path, schema if schema.exists() else None)
        elif schema.exists():
            data = load_yaml(path, schema=str(schema.resolve()))
            if path.name == "priors.yaml":
                check_priors(data, str(path))
        else:
            load_yaml(path)
        checked.append(path)
    if not any(p.name == "robot.yaml" for p in checked) and "robot.yaml" not in exclude:
        raise ConfigError(f"{config_dir / 'robot.yaml'}: file not found (the robot facts every model is built from)")
    return checked

