"""Diagnosis stages: `roboball diagnose` on recordings of the campaign and the real logs, and the
diagnosed model of the ramp scored like the paper's three (the fourth bar of Fig. 13/14).

The diagnosed ramp model is the paper's point model as the pipeline calibrates it (point
contact, the Majd friction fitted on the stand logs on both joints: the contract's ramp baseline
of ../shared/specs/diagnosis.md with the fitted friction in place of Table I) plus the effects the
diagnosis found, evaluated as a Drake force element (roboball.diagnose.drake.effect_term).  It is
scored out of sample: the effects and their parameters for one run come from the pooled
diagnosis of the OTHER runs at the same pressure (workflow/rules/diagnose.smk), whose held-out test
leaves one whole run out.  Its PME (eq. 12) is computed on the same samples, from the same start, as
the paper's models (roboball.pipeline.simulation.ramp_window).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from roboball.atomic import write_bytes_atomic, write_csv_atomic
from roboball.errors import RoboballError
from roboball.metrics import speed_errors
from roboball.pipeline.simulation import ramp_window

STAGES = ("diagnose_recording", "ramp_diagnosed")


def diagnose_recording(recording: list, out_dir: str, friction_steer: str = "", friction_drive: str = "",
                       steer_joint: str = "", same_as: str = "") -> None:
    """`roboball diagnose` on one recording (CSV with its sidecar), or on several recordings of
    one experiment together: diagnosis.json, report.md, predictions.csv and the figures in
    `out_dir`.  With fitted friction (the pipeline's Majd fits) the ramp baseline is the paper's
    point model as the pipeline calibrates it, instead of the contract's Table I friction.
    `steer_joint` ("locked", "free", "unknown"; empty: the sidecar's, else locked): a shell release's
    steer setting (roboball.diagnose.steer).  `same_as`: an out dir already holding the diagnosis
    of the same recordings with the same settings (a pressure's only ramp run, diagnosed pooled
    and held out): its files are copied rather than computed again."""
    from roboball.diagnose import diagnose
    from roboball.identify.friction.fitted import read_diagnosis_friction

    if same_as and diagnosed_runs([str(Path(same_as) / "diagnosis.json")]) == sorted({Path(r).stem for r in recording}):
        for src in sorted(Path(same_as).iterdir()):
            if src.is_file():
                write_bytes_atomic(Path(out_dir) / src.name, src.read_bytes())
        return
    diagnose(recording, out_dir=out_dir, friction=read_diagnosis_friction(friction_steer, friction_drive) or None,
             steer_joint=steer_joint or None)


def consensus_effects(diagnoses: list) -> dict:
    """{effect: {param: value}} from the diagnoses (JSON paths): the effect set named most often
    (ties: the set whose best diagnosis has the lowest held-out RMS after), each parameter the
    median over the diagnoses that name that set.  Parameters of different sets are never mixed
    (a damping fitted alone and one fitted beside a rolling resistance are different numbers)."""
    by_set: dict = {}
    for path in diagnoses:
        try:
            with open(path, encoding="utf-8") as fh:
                d = json.load(fh)
            found = {m["effect"]: m["parameters"] for m in d["missing_physics"]}
        except (OSError, json.JSONDecodeError, KeyError, TypeError) as exc:
            raise RoboballError(f"{path}: not a diagnosis.json ({exc})")
        rmse = d.get("fit", {}).get("rmse_heldout_after")
        by_set.setdefault(tuple(sorted(found)), []).append((float(rmse) if rmse is not None else np.inf, found))
    if not by_set:
        return {}
    key = max(by_set, key=lambda k: (len(by_set[k]), -min(r for r, _ in by_set[k])))
    entries = [f for _, f in by_set[key]]
    return {e: {p: float(np.median([f[e][p] for f in entries])) for p in entries[0][e]} for e in key}


def baseline_friction(diagnoses: list) -> dict:
    """The joint friction of the diagnoses' ramp baseline ({} = Table I).  The diagnosed model
    must run on the baseline its effects were fitted against, so the diagnoses must agree."""
    found = []
    for path in diagnoses:
        with open(path, encoding="utf-8") as fh:
            found.append(json.load(fh).get("baseline", {}).get("friction") or {})
    if any(f != found[0] for f in found[1:]):
        raise RoboballError(f"{diagnoses[0]}: the diagnoses were made against different baseline friction; "
                            "their effects cannot be combined")
    return found[0] if found else {}


def describe(effects: dict) -> str:
    return "; ".join(f"{e}(" + ", ".join(f"{k}={v:.4g}" for k, v in p.items()) + ")" for e, p in effects.items()) \
        or "none"


def diagnosed_descent(rec, releases: str, effects: dict, friction: dict, dt: float = 0.001):
    """The diagnosed model's Drake descent of one recorded run (`rec`, read), from the release
    instant the paper's models start from: (times, measured drive rate, simulated drive rate) on
    eq. 12's samples, and the pipe angle it starts at."""
    from roboball.diagnose.drake import effect_term, ramp_spec
    from roboball.reduced.models import model_for
    from roboball.sim.scenarios import simulate

    tt, w_e, pipe0 = ramp_window(rec, releases)
    angle = rec.ramp_angle_deg
    term = effect_term(model_for("ramp", ramp_angle_deg=angle), effects)
    spec = ramp_spec(rec.pressure_kpa, angle, [term] if term is not None else [], dt, friction_params=friction)
    df = simulate(spec, pipe0, float(tt[-1]) + 0.05, sample_rate_hz=200.0)
    return tt, w_e, np.interp(tt, df.time_s.to_numpy(), df.drive_rate_rad_s.to_numpy()), pipe0


def diagnosed_runs(diagnoses: list) -> list:
    """The recordings (file stems) the diagnoses were made on, from the details.json beside each
    diagnosis.json ([] where a diagnosis has none)."""
    runs = []
    for path in diagnoses:
        details = Path(path).with_name("details.json")
        if details.is_file():
            with open(details, encoding="utf-8") as fh:
                runs += [Path(r.strip()).stem for r in str(json.load(fh).get("recording", "")).split(" + ") if r.strip()]
    return sorted(set(runs))


def ramp_diagnosed(recording: str, releases: str, diagnoses: list, out_csv: str, out_trace: str = "",
                   dt: float = 0.001) -> None:
    """Ramp descent of one recorded run with the diagnosed model (effects from `diagnoses`, the
    other runs' diagnosis.json files), scored by PME like the paper's contact models.  The row
    names the runs the effects were fitted on (`effects_from`) and whether the scored run is
    among them (`scored_in_sample`: a pressure with a single run has no other to fit on)."""
    from roboball.ingest.recording import read_recording

    if not diagnoses:
        raise RoboballError(f"{recording}: no diagnoses of other runs to take the diagnosed effects from")
    rec = read_recording(recording)
    effects = consensus_effects(diagnoses)
    tt, w_e, w_s, pipe0 = diagnosed_descent(rec, releases, effects, baseline_friction(diagnoses), dt)
    stem = rec.path.stem if rec.path else Path(recording).stem
    runs = diagnosed_runs(diagnoses)
    row = {"recording": stem, "pressure_kpa": rec.pressure_kpa,
           "contact": "diagnosed", **speed_errors(w_e, w_s), "initial_pipe_angle_rad": pipe0,
           "n_samples": int(tt.size), "ramp_time_s": float(tt[-1]), "diagnosed_effects": describe(effects),
           "effects_from": " ".join(runs) if runs else " ".join(Path(p).parent.name for p in diagnoses),
           "scored_in_sample": stem in runs}
    write_csv_atomic(pd.DataFrame([row]), out_csv)
    if out_trace:
        write_csv_atomic(pd.DataFrame({"time_s": tt, "drive_rate_measured_rad_s": w_e,
                                       "drive_rate_sim_rad_s": w_s}), out_trace)
