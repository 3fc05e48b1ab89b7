"""A diagnosis folder read back for design: its contract file (diagnosis.json), its details
(details.json: every fitted value and interval) and the recording(s) it was made from, and the
choices the diagnosis left undecided, each candidate a simulator (a reduced model of
roboball.reduced and the values the diagnosis fitted to it).

Undecided choices (docs/diagnosis.md, "Equivalent explanations"):
- an effect and its listed alternatives: the final model F against F - e + u, each as fitted;
- the steer setting of a shell release (`steer_joint` unknown): the locked and the free
  diagnoses, each as fitted;
- a poorly pinned parameter: the model at the two ends of the parameter's 95% interval.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

from roboball.diagnose.data import pool, prepare, read
from roboball.errors import RoboballError
from roboball.physics import effects as fx
from roboball.reduced.base import ReducedModel
from roboball.reduced.models import model_for

# a parameter whose 95% interval is wider than this share of its value is poorly pinned
POORLY_PINNED = 0.5
# kinds whose diagnosis runs on a reduced model (the coupled test is diagnosed in Drake)
DESIGNABLE = ("steer_stand", "drive_stand", "shell_rock", "ramp")


@dataclass
class Candidate:
    """One explanation: the model (its effects on the kind's reduced model, the steer joint for
    a shell), every parameter as fitted, and the standard deviation of the uncertain ones."""

    label: str
    effects: tuple
    values: dict
    sigma: dict
    steer_joint: str = ""        # shell_rock: "locked" or "free"; "" elsewhere
    setup: dict = field(default_factory=dict)   # ramp: the diagnosis's angle and baseline friction

    def model(self, kind: str, steer_joint: str | None = None, ramp_angle_deg: float | None = None) -> ReducedModel:
        """The reduced model of this candidate (a shell with its steer joint `steer_joint`,
        default its own setting; a ramp at `ramp_angle_deg`, default the user's)."""
        joint = steer_joint or self.steer_joint
        if kind == "shell_rock" and joint == "free":
            from roboball.reduced.shell_steer import ShellSteerModel
            return ShellSteerModel()
        if kind == "ramp":
            angle = self.setup["ramp_angle_deg"] if ramp_angle_deg is None else ramp_angle_deg
            return model_for(kind, ramp_angle_deg=angle, friction=self.setup.get("friction") or None)
        return model_for(kind)


@dataclass
class Choice:
    """An undecided choice: what it is about and its candidates (two or more)."""

    name: str
    about: str                  # "effect", "steer_joint" or "parameter"
    candidates: list
    mechanism: dict = field(default_factory=dict)   # candidate label -> what it stands for


@dataclass
class Source:
    folder: Path
    diagnosis: dict
    details: dict
    prep: object                # roboball.diagnose.data.Prepared of the diagnosed recording(s)
    kind: str
    noise: float                # rad: the log's own noise (the diagnosis's fit_noise)
    residual: float             # rad: the augmented model's RMS residual on the log
    choices: list
    setup: dict = field(default_factory=dict)   # details.json's model_setup (a ramp's angle, friction)


def _json(path: Path, what: str) -> dict:
    if not path.is_file():
        raise RoboballError(f"{path}: not found ({what})")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise RoboballError(f"{path}: not JSON ({exc})")
    if not isinstance(data, dict):
        raise RoboballError(f"{path}: not a JSON object")
    return data


def read_source(folder) -> Source:
    """The diagnosis in `folder` with its recording and undecided choices; a one-line
    RoboballError naming the file and what is wrong otherwise."""
    folder = Path(folder)
    if not folder.is_dir():
        raise RoboballError(f"{folder}: not a folder (give the output folder of `roboball diagnose`)")
    dg = _json(folder / "diagnosis.json", "not a diagnosis folder: run `roboball diagnose ... --out` first")
    for key in ("kind", "missing_physics", "fit"):
        if key not in dg:
            raise RoboballError(f"{folder / 'diagnosis.json'}: no '{key}' (not a diagnosis.json of the contract)")
    kind = dg["kind"]
    # before details.json: a coupled diagnosis writes none, and its missing file would say nothing of why
    if kind not in DESIGNABLE:
        raise RoboballError(f"{folder / 'diagnosis.json'}: kind {kind}: design covers {', '.join(DESIGNABLE)} "
                            f"(their candidates run on the reduced models; a {kind} diagnosis's are not simulated "
                            "by design)")
    det = _json(folder / "details.json", "the diagnosis's details, written beside diagnosis.json")
    for key in ("recording", "final_values", "ci95", "fit_noise"):
        if key not in det:
            raise RoboballError(f"{folder / 'details.json'}: no '{key}' (written by an older roboball? rerun the diagnosis)")
    paths = str(det["recording"]).split(" + ")
    recs = []
    for p in paths:
        if not Path(p).is_file():
            raise RoboballError(f"{p}: file not found (the recording {folder / 'details.json'} names)")
        recs.append(read(p, kind=kind))
    prep = pool([prepare(r) for r in recs])
    noise = float(det["fit_noise"])
    if not (math.isfinite(noise) and noise > 0):
        raise RoboballError(f"{folder / 'details.json'}: fit_noise {det['fit_noise']!r} is not a positive number")
    residual = float(dg["fit"].get("rmse_after") or dg["fit"].get("rmse_before") or noise)
    setup = det.get("model_setup") or {}
    if kind == "ramp" and not isinstance(setup.get("ramp_angle_deg"), (int, float)):
        raise RoboballError(f"{folder / 'details.json'}: no 'model_setup' with the ramp's angle (written by an older "
                            "roboball? rerun the diagnosis)")
    src = Source(folder, dg, det, prep, kind, noise, residual, [], setup)
    src.choices = choices(src)
    for choice in src.choices:
        for cand in choice.candidates:
            cand.setup = setup
    return src


def sigma_of(ci95: dict, values: dict) -> dict:
    """Standard deviations (95% half-width / 1.96) of the model parameters in `ci95` (release
    states left out: a new recording has its own), held parameters (zero width) left out."""
    out = {}
    for k, iv in ci95.items():
        if "@" in k or k not in values or iv is None or None in iv:
            continue
        s = (float(iv[1]) - float(iv[0])) / 3.92
        if math.isfinite(s) and s > 0:
            out[k] = s
    return out


def _effects_of(values: dict) -> tuple:
    """The vocabulary effects with a non-zero magnitude in `values`."""
    out = []
    for name, eff in fx.LIBRARY.items():
        v = values.get(f"{name}.{eff.params[0].name}")
        if v is not None and v != 0.0:
            out.append(name)
    return tuple(out)


def choices(src: Source) -> list:
    """Every undecided choice of the diagnosis (module docstring)."""
    out = _effect_choices(src)
    steer = src.details.get("steer_settings") or {}
    if all(steer.get(k, {}).get("values") for k in ("locked", "free")):
        cands = []
        for k in ("locked", "free"):
            v = {a: float(b) for a, b in steer[k]["values"].items() if b is not None}
            cands.append(Candidate(f"steer joint {k}", _effects_of(v), v, sigma_of(steer[k].get("ci95", {}), v), k))
        out.append(Choice("steer joint locked or free", "steer_joint", cands,
                          {"steer joint locked": "the pendulum clamped to the pipe during the release",
                           "steer joint free": "the pendulum swinging on its steer joint during the release"}))
    out += _parameter_choices(src)
    return out


def _final(src: Source) -> tuple[dict, dict, str]:
    values = {k: float(v) for k, v in src.details["final_values"].items() if v is not None}
    sigma = sigma_of(src.details["ci95"], values)
    joint = "free" if "steer_angle@0" in values else ("locked" if src.kind == "shell_rock" else "")
    return values, sigma, joint


def _effect_choices(src: Source) -> list:
    values, sigma, joint = _final(src)
    stored = src.details.get("alternatives") or {}
    out = []
    for m in src.diagnosis["missing_physics"]:
        alts = m.get("alternatives") or []
        if not alts:
            continue
        e = m["effect"]
        cands = [Candidate(e, _effects_of(values), values, sigma, joint)]
        mech = {e: m.get("mechanism", "")}
        for a in alts:
            u = a["effect"]
            full = next((s for s in stored.get(e, []) if s.get("effect") == u and s.get("values")), None)
            if full:
                v = {k: float(x) for k, x in full["values"].items() if x is not None}
                s = sigma_of(full.get("ci95", {}), v)
            else:       # an older details.json: F's values with e's parameters swapped for u's
                v = {k: x for k, x in values.items() if not k.startswith(e + ".")}
                v.update({f"{u}.{p}": float(x) for p, x in a["parameters"].items()})
                s = {k: x for k, x in sigma.items() if not k.startswith(e + ".")}
                s.update(sigma_of({f"{u}.{p}": iv for p, iv in a.get("ci95", {}).items()}, v))
            cands.append(Candidate(u, _effects_of(v), v, s, joint))
            mech[u] = a.get("mechanism", "")
        out.append(Choice(" or ".join(c.label for c in cands), "effect", cands, mech))
    return out


def _parameter_choices(src: Source) -> list:
    """A poorly pinned effect parameter: the model at either end of its 95% interval."""
    values, sigma, joint = _final(src)
    out = []
    for m in src.diagnosis["missing_physics"]:
        for p, iv in (m.get("ci95") or {}).items():
            key = f"{m['effect']}.{p}"
            v = values.get(key)
            if v is None or iv is None or None in iv or iv[0] == iv[1] or not v:
                continue
            if (iv[1] - iv[0]) / abs(v) <= POORLY_PINNED:
                continue
            cands = []
            for end, x in (("low", iv[0]), ("high", iv[1])):
                vv = dict(values, **{key: float(x)})
                ss = {k: s for k, s in sigma.items() if k != key}
                cands.append(Candidate(f"{key} = {x:.4g} ({end} end)", _effects_of(vv), vv, ss, joint))
            out.append(Choice(f"{key} within [{iv[0]:.4g}, {iv[1]:.4g}]", "parameter", cands))
    return out
