"""The fitted Majd friction a simulation runs with: the point estimate of a fit file.

One reader for every consumer of the fits (the ramp descents, the deflating ramp, the
diagnosis's calibrated ramp baseline), so that a malformed file fails the same way, in one line,
everywhere.  The file format is :mod:`roboball.identify.friction.results`'s."""
from __future__ import annotations

from pathlib import Path

from roboball.errors import RoboballError
from roboball.identify.friction.results import is_fit, point_estimate, read_json
from roboball.physics import friction as friction_laws


def read_friction(path) -> dict:
    """Majd parameters from a friction fit (roboball's fit JSON: posterior medians, and the values
    of any parameters the fit held fixed) or a plain JSON object {f_w, f_c, sigma, omega_c, n};
    a one-line error names the file and what is wrong."""
    path = Path(path)
    return _majd_parameters(path, _estimate(path)[0])


def _estimate(path: Path) -> tuple[dict, bool]:
    """The file's point estimate (a fit's posterior medians and fixed values, or the plain object)
    and whether it came from a fit."""
    d = read_json(path)
    fitted = is_fit(d) and isinstance(d["parameters"], dict)
    if fitted:
        if d.get("law") not in (None, "majd"):
            raise RoboballError(f"{path}: a fit of the {d.get('law')} law, not Majd's")
        d = point_estimate(d)
    if not isinstance(d, dict):
        raise RoboballError(f"{path}: expected a JSON object of Majd parameters")
    return d, fitted


def _majd_parameters(path: Path, d: dict) -> dict:
    out = {}
    for k in friction_laws.PARAMS["majd"]:
        v = d.get(k)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or v != v:
            raise RoboballError(f"{path}: Majd parameter '{k}' is {'missing' if v is None else repr(v)}, not a number")
        out[k] = float(v)
    # eq. 3 needs a positive break speed and exponent, and its viscous and Coulomb terms must
    # oppose the motion; sigma's sign is free (it shapes the hump)
    for k in ("omega_c", "n"):
        if not out[k] > 0:
            raise RoboballError(f"{path}: Majd parameter '{k}' is {out[k]!r}, must be > 0")
    for k in ("f_w", "f_c"):
        if not out[k] >= 0:
            raise RoboballError(f"{path}: Majd parameter '{k}' is {out[k]!r}, must be >= 0 (friction opposes motion)")
    return out


def read_joint_friction(steer=None, drive=None) -> dict:
    """{joint: Majd parameters} for the joints whose fit file is given (empty or None: left out)."""
    return {joint: read_friction(path) for joint, path in (("steer", steer), ("drive", drive)) if path}


def read_diagnosis_friction(steer=None, drive=None) -> dict:
    """What `roboball diagnose` takes as its baselines' friction: `read_joint_friction`, with the
    steer fit's reflected rotor inertia `delta_i` kept (`read_stand_friction`).  The ramp baseline
    reads the Majd parameters only; a shell release with the pendulum free puts delta_i on the
    steer joint (roboball.reduced.shell_steer), as the coupled scenario does."""
    out = read_joint_friction(None, drive)
    if steer:
        out["steer"] = read_stand_friction(steer)
    return out


def read_stand_friction(path) -> dict:
    """The steer stand's calibrated fit as a Drake scenario runs it: the Majd parameters
    (`read_friction`) and, when the fit has one, its reflected rotor inertia `delta_i` (kg m^2;
    the calibrated stand's added inertia, which belongs to the joint wherever the joint moves)."""
    path = Path(path)
    d, fitted = _estimate(path)
    out = _majd_parameters(path, d)
    delta = d.get("delta_i") if fitted else None    # a plain object's Majd parameters only
    if delta is not None:
        if isinstance(delta, bool) or not isinstance(delta, (int, float)) or delta != delta:
            raise RoboballError(f"{path}: parameter 'delta_i' is {delta!r}, not a number")
        out["delta_i"] = float(delta)
    return out
