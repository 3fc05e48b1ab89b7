"""Configuration loading, schema validation and the robot's derived constants.

`configs/robot.yaml` is the single source of truth for the robot.  Every constant that
the paper derives from it (eq. 4-5: M_eq, K_eq, omega_n; the stand pendulum's inertia and
restoring stiffness; rest angles) is computed here, never typed in twice.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass
from functools import cached_property, lru_cache
from pathlib import Path

import yaml

from roboball.errors import ConfigError

PACKAGE_DIR = Path(__file__).resolve().parent
REPO_DIR = PACKAGE_DIR.parent.parent
CONFIG_DIR = Path(os.environ.get("ROBOBALL_CONFIG_DIR", REPO_DIR / "configs"))
ROBOT_YAML = CONFIG_DIR / "robot.yaml"
SCHEMA_DIR = CONFIG_DIR / "schema"

# libyaml's loader reads the same YAML as the pure-Python SafeLoader about ten times faster; a
# pipeline job reads robot.yaml and its schema once per Drake run (a ramp job: 17 times).
_YAML_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def _path_of_error(err) -> str:
    parts = [str(p) for p in err.absolute_path]
    return ".".join(parts) if parts else "(top level)"


def first_nonfinite(node, where: tuple = ()):
    """(dotted field, value) of the first NaN or infinite number in a YAML tree, else None.
    JSON Schema's bounds cannot refuse NaN (every comparison with it is false), and YAML
    writes both as plain words (.nan, .inf)."""
    if isinstance(node, float):
        return None if math.isfinite(node) else (".".join(where) or "(top level)", node)
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, value in items:
        hit = first_nonfinite(value, where + (str(key),))
        if hit:
            return hit
    return None


def load_yaml(path: str | os.PathLike, schema: str | None = None) -> dict:
    """Read a YAML file and, if `schema` names a file in configs/schema, validate it.

    Raises ConfigError with a one-line message naming the file and the offending field.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise ConfigError(f"{path}: file not found")
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read ({exc.strerror})")
    try:
        data = yaml.load(text, Loader=_YAML_LOADER)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}" if mark is not None else "?"
        raise ConfigError(f"{path}: {where}: not valid YAML ({getattr(exc, 'problem', exc)})")
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a mapping at the top level")
    bad = first_nonfinite(data)
    if bad:
        hint = " (leave an optional bound out rather than write .inf)" if math.isinf(bad[1]) else ""
        raise ConfigError(f"{path}: field '{bad[0]}': {bad[1]} is not a finite number{hint}")
    if schema is not None:
        validate(data, schema, source=str(path))
    return data


@lru_cache(maxsize=None)
def _schema(name: str) -> dict:
    with open(SCHEMA_DIR / name, encoding="utf-8") as fh:
        return yaml.load(fh, Loader=_YAML_LOADER)


def validate(data: dict, schema: str, source: str = "config") -> None:
    """Validate `data` against configs/schema/<schema>; one-line ConfigError on failure."""
    import jsonschema

    validator = jsonschema.Draft202012Validator(_schema(schema))
    errors = sorted(validator.iter_errors(data), key=lambda e: list(e.absolute_path))
    if errors:
        err = errors[0]
        raise ConfigError(f"{source}: field '{_path_of_error(err)}': {err.message}")


@dataclass(frozen=True)
class Link:
    name: str
    mass_kg: float
    com_m: tuple
    inertia_kg_m2: tuple


class RobotFacts:
    """The robot's facts plus every constant derived from them."""

    def __init__(self, data: dict, source: str = "robot.yaml"):
        self.data = data
        self.source = source
        self.g = float(data["gravity_m_s2"])
        self.links = {
            name: Link(name, float(d["mass_kg"]), tuple(map(float, d["com_m"])),
                       tuple(map(float, d["inertia_kg_m2"])))
            for name, d in data["links"].items()
        }
        self.radius = float(data["shell"]["radius_m"])
        self.joints = data["joints"]
        self.friction_table1 = data["friction_table1"]
        self.ramp_angle_deg = float(data["experiments"]["ramp_angle_deg"])
        self.test_pressures_kpa = [float(p) for p in data["experiments"]["test_pressures_kpa"]]

    # ---- masses -------------------------------------------------------------------
    @property
    def total_mass(self) -> float:
        return sum(l.mass_kg for l in self.links.values())

    @property
    def weight_n(self) -> float:
        return self.total_mass * self.g

    # ---- eq. 4-5: locked-steer shell --------------------------------------------
    @cached_property
    def shell_terms(self) -> dict:
        """M_eq, K_eq, omega_n of eq. 4-5 (r_i = CoM depth below centre).  One departure from the
        paper's eq. 4: the pendulum's parallel-axis term uses its distance from the steer axis,
        sideways CoM offset included, not its depth alone; M_eq is 2.5e-4 kg m^2 (0.006%) larger
        than with the depth alone (4.19157 against 4.19132; robot-facts.md: 4.191), omega_n 2.28547
        against 2.28554 rad/s (3e-5 relative)."""
        pc, p, s = self.links["pitch_center"], self.links["pendulum"], self.links["pipe_assembly"]
        r_pc = -pc.com_m[2]
        r_p = -p.com_m[2]
        # Inertias about the steer (x) axis through each CoM; the pendulum's small y offset adds
        # to its parallel-axis term (distance from the x axis).
        d2_pc = pc.com_m[1] ** 2 + pc.com_m[2] ** 2
        d2_p = p.com_m[1] ** 2 + p.com_m[2] ** 2
        i_eq = (s.inertia_kg_m2[0] + (pc.inertia_kg_m2[0] + pc.mass_kg * d2_pc)
                + (p.inertia_kg_m2[0] + p.mass_kg * d2_p) + self.total_mass * self.radius ** 2)
        m_r = pc.mass_kg * r_pc + p.mass_kg * r_p
        m_eq = i_eq - 2.0 * m_r * self.radius
        k_eq = m_r * self.g
        return {"I_eq": i_eq, "M_eq": m_eq, "K_eq": k_eq, "omega_n": math.sqrt(k_eq / m_eq)}

    @property
    def M_eq(self) -> float:
        return self.shell_terms["M_eq"]

    @property
    def K_eq(self) -> float:
        return self.shell_terms["K_eq"]

    @property
    def omega_n_eq5(self) -> float:
        return self.shell_terms["omega_n"]

    @property
    def shell_rest_angle(self) -> float:
        """Locked-steer rest roll angle: the CoM of the hanging links directly below the centre."""
        pc, p = self.links["pitch_center"], self.links["pendulum"]
        lateral = pc.mass_kg * pc.com_m[1] + p.mass_kg * p.com_m[1]
        depth = -(pc.mass_kg * pc.com_m[2] + p.mass_kg * p.com_m[2])
        return -math.atan2(lateral, depth)

    # ---- stands -------------------------------------------------------------------
    @cached_property
    def steer_stand_terms(self) -> dict:
        """Pendulum swinging about the steer (x) axis: inertia, m g d, small-swing omega, rest."""
        p = self.links["pendulum"]
        d = math.hypot(p.com_m[1], p.com_m[2])
        inertia = p.inertia_kg_m2[0] + p.mass_kg * d ** 2
        mgd = p.mass_kg * self.g * d
        return {"inertia": inertia, "mgd": mgd, "omega_n": math.sqrt(mgd / inertia),
                "rest_angle": -math.atan2(p.com_m[1], -p.com_m[2])}

    @cached_property
    def drive_stand_terms(self) -> dict:
        """pitch_center + pendulum (steer locked) swinging about the drive (y) axis, pipe held."""
        pc, p = self.links["pitch_center"], self.links["pendulum"]
        inertia = 0.0
        m_r = 0.0
        for l in (pc, p):
            inertia += l.inertia_kg_m2[1] + l.mass_kg * (l.com_m[0] ** 2 + l.com_m[2] ** 2)
            m_r += l.mass_kg * (-l.com_m[2])
        mgd = m_r * self.g
        return {"inertia": inertia, "mgd": mgd, "omega_n": math.sqrt(mgd / inertia), "rest_angle": 0.0}

    def majd_params(self, joint: str) -> dict:
        return dict(self.friction_table1[f"majd_{joint}"])


def load_robot(path: str | os.PathLike | None = None) -> RobotFacts:
    """Load and validate the robot facts (default: configs/robot.yaml).

    The facts are read once per file version (path, size, modification time) and shared: a
    ramp job builds 17 plants from them.  Callers that change the facts copy `data` first
    (roboball.testbed.effects).
    """
    path = Path(path) if path is not None else ROBOT_YAML
    try:
        st = path.stat()
    except OSError:     # load_yaml says what is wrong with the path, in one line
        return RobotFacts(load_yaml(path, schema="robot.schema.yaml"), source=str(path))
    return _load_robot(str(path), st.st_mtime_ns, st.st_size)


@lru_cache(maxsize=8)
def _load_robot(path: str, mtime_ns: int, size: int) -> RobotFacts:
    return RobotFacts(load_yaml(path, schema="robot.schema.yaml"), source=path)
