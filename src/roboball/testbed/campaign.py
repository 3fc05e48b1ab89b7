"""The experimental campaign, written to raw_data/ in the recording format with a MANIFEST.

`generate(out_dir)` regenerates every file bit-for-bit from the seed in truth.yaml: each
file draws from its own random stream (SeedSequence keyed by the file's name), and Drake
runs are deterministic, so the manifest's sha256 sums are reproducible.
"""
from __future__ import annotations

import hashlib
import math
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd

from roboball.atomic import write_csv_atomic
from roboball.ingest.recording import write_recording
from roboball.testbed.physics import campaign_truth, true_robot
from roboball.testbed.run import ALL_EXTRAS, coupled_release, ramp_exit_time, run_free
from roboball.testbed.sensors import hand_phase, measure

SIGNAL = {"steer_stand": "steer_angle_rad", "drive_stand": "drive_angle_rad", "shell_rock": "pipe_angle_rad"}


def _rng(seed: int, name: str) -> np.random.Generator:
    key = int.from_bytes(hashlib.sha256(name.encode()).digest()[:8], "little")
    return np.random.default_rng(np.random.SeedSequence([seed, key]))


def jobs(truth: dict) -> list[dict]:
    """Every file of the campaign: name, kind, pressure, run."""
    c = truth["campaign"]
    out = []
    for kind in ("steer_stand", "drive_stand"):
        for r in range(1, c[kind]["files"] + 1):
            out.append(dict(file=f"{kind}/{kind}_r{r}.csv", kind=kind, pressure_kpa=None, run=r))
    for p in c["pressures_kpa"]:
        for r in range(1, c["shell_rock"]["runs"] + 1):
            out.append(dict(file=f"shell_rock/shell_rock_{p:.1f}kpa_r{r}.csv", kind="shell_rock", pressure_kpa=p, run=r))
    for p in c["pressures_kpa"]:
        for r in range(1, c["ramp"]["runs"] + 1):
            out.append(dict(file=f"ramp/ramp_{p:.1f}kpa_r{r}.csv", kind="ramp", pressure_kpa=p, run=r))
    for p in c["pressures_kpa"]:
        for r in range(1, c.get("steer_coupled", {}).get("runs", 0) + 1):
            out.append(dict(file=f"steer_coupled/steer_coupled_{p:.1f}kpa_r{r}.csv", kind="steer_coupled",
                            pressure_kpa=p, run=r))
    return out


def _rest_angle(kind: str, robot) -> float:
    if kind == "steer_stand":
        p = robot.links["pendulum"]
        return -math.atan2(p.com_m[1], -p.com_m[2])
    if kind == "shell_rock":
        return robot.shell_rest_angle
    return 0.0


def release_recording(kind: str, p_kpa, releases, free_s: float, truth: dict, rng, extras=ALL_EXTRAS,
                      extra_terms=(), extra_systems=(), base_friction=None, robot=None) -> pd.DataFrame:
    """Rest, then for each release: move, hold, let go, free response.  Dense (1 kHz) signals,
    with the let-go instants in `attrs["let_go_s"]` (s).  `base_friction` and `robot`: see
    roboball.testbed.run.truth_spec (blind diagnosis cases)."""
    rate = truth["simulation"]["sample_rate_hz"]
    sig = SIGNAL[kind]
    angle = _rest_angle(kind, robot if robot is not None else true_robot(truth, perturbed="mass" in extras))
    pieces = [np.full(int(1.0 * rate), angle)]
    let_go = []
    for target in releases:
        hand, held = hand_phase(angle, target, truth["hand"], rng, rate)
        pieces.append(hand)
        let_go.append((sum(len(p) for p in pieces) - 1) / rate)   # the last held sample
        df, _, _ = run_free(kind, held, free_s, p_kpa, truth, extras, extra_terms=extra_terms,
                            extra_systems=extra_systems, base_friction=base_friction, robot=robot)
        y = df[sig].to_numpy()[1:]
        pieces.append(y)
        angle = float(y[-1])
    y = np.concatenate(pieces)
    t = np.arange(len(y)) / rate
    dense = pd.DataFrame({"time_s": t, sig: y})
    if kind == "shell_rock":
        dense["pipe_rate_rad_s"] = np.gradient(y, t)
    dense.attrs["let_go_s"] = let_go      # ground truth the recording does not carry
    return dense


def _ramp_start(rng, truth: dict) -> tuple[float, int]:
    """A ramp run's random start, the first two draws of its generator: the initial pipe angle
    (rad) and the number of samples (at the internal rate) held still before the release."""
    c = truth["campaign"]["ramp"]
    phi0 = float(rng.normal(0.0, c["initial_pipe_angle_sd_rad"]))
    pre = rng.uniform(*c["pre_hold_s"])
    return phi0, int(pre * truth["simulation"]["sample_rate_hz"])


def ramp_release_s(file: str, truth: dict | None = None) -> float:
    """The instant (s, recording time) at which the test bed let go of the ramp run `file` (as
    named in the MANIFEST, e.g. "ramp/ramp_20.7kpa_r1.csv"): ground truth that the recording
    does not carry, for auditing release detection (benchmarks/ramp_release_audit.py)."""
    truth = truth or campaign_truth()
    _, n_pre = _ramp_start(_rng(truth["seed"], file), truth)
    return n_pre / truth["simulation"]["sample_rate_hz"]


def ramp_recording(p_kpa: float, truth: dict, rng, extras=ALL_EXTRAS, extra_terms=(), extra_systems=(),
                   base_friction=None, robot=None):
    """Held at rest on the ramp, released, rolls off the end onto the floor.
    `base_friction` and `robot`: see roboball.testbed.run.truth_spec (blind diagnosis cases)."""
    c = truth["campaign"]["ramp"]
    rate = truth["simulation"]["sample_rate_hz"]
    phi0, n_pre = _ramp_start(rng, truth)
    # Long enough to leave the ramp; trimmed to exit + after_exit below.
    df, x, spec = run_free("ramp", phi0, 4.0, p_kpa, truth, extras, ramp_length_m=c["length_m"],
                           extra_terms=extra_terms, extra_systems=extra_systems, base_friction=base_friction,
                           robot=robot)
    t_exit = ramp_exit_time(df, x, spec)
    if t_exit is not None:
        df = df[df.time_s <= t_exit + c["after_exit_s"]]
    head = pd.DataFrame({col: np.full(n_pre, df[col].iloc[0]) for col in df.columns})
    head["time_s"] = np.arange(n_pre) / rate
    body = df.copy()
    body["time_s"] = body["time_s"] + n_pre / rate
    dense = pd.concat([head, body], ignore_index=True)
    keep = ["time_s", "drive_rate_rad_s", "pipe_angle_rad", "steer_angle_rad"]
    exit_s = None if t_exit is None else round(t_exit + n_pre / rate, 4)
    return dense[keep], exit_s, n_pre / rate


def coupled_recording(p_kpa: float, truth: dict, rng) -> pd.DataFrame:
    """The coupled steer test as the real robot's repeats were made (data README): the shell
    tilted by hand, the pendulum hanging near plumb on its free steer joint, let go; shell and
    pendulum swing together until both settle.  Like the real logs it is trimmed at the let-go,
    starting a few samples after it, at their slower sampling (dense 1 kHz here)."""
    c = truth["campaign"]["steer_coupled"]
    rate = truth["simulation"]["sample_rate_hz"]
    pipe0 = float(rng.uniform(*c["release_pipe_rad"]))
    steer0 = -pipe0 + float(rng.uniform(*c["pendulum_from_plumb_rad"]))   # the pendulum's own angle to the vertical
    trim = float(rng.uniform(*c["trim_s"]))
    t = np.arange(int(round((trim + c["duration_s"]) * rate)) + 1) / rate
    y = coupled_release(p_kpa, t, pipe0, steer0, None, truth)
    keep = t >= trim - 1e-12
    return pd.DataFrame({"time_s": t[keep] - t[keep][0], "pipe_angle_rad": y["pipe_angle_rad"][keep],
                         "steer_angle_rad": y["steer_angle_rad"][keep]})


def make_file(job: dict, out_dir: str, truth: dict) -> dict:
    rng = _rng(truth["seed"], job["file"])
    kind, p = job["kind"], job["pressure_kpa"]
    meta = {"kind": kind, "pressure_kpa": p, "source": "roboball virtual test bed", "run": job["run"]}
    if kind == "ramp":
        dense, exit_s, release_s = ramp_recording(p, truth, rng)
        meta.update(ramp_angle_deg=true_robot(truth).ramp_angle_deg, ramp_exit_s=exit_s)
    elif kind == "steer_coupled":
        dense = coupled_recording(p, truth, rng)
    else:
        c = truth["campaign"][kind]
        dense = release_recording(kind, p, c["releases_rad"], c["free_s"], truth, rng)
        if kind == "shell_rock":
            meta["steer_joint"] = "locked"     # the paper's clamp (Fig. 9) holds the pendulum
    sensors = truth["sensors"]
    if kind == "steer_coupled":        # the real coupled repeats' logger: about 50 Hz
        sensors = dict(sensors, rate_hz=truth["campaign"]["steer_coupled"]["rate_hz"])
    rec = measure(dense, sensors, rng)
    path = Path(out_dir) / job["file"]
    path.parent.mkdir(parents=True, exist_ok=True)
    write_recording(path, rec, meta)
    return dict(job, sha256=hashlib.sha256(path.read_bytes()).hexdigest(),
                sidecar_sha256=hashlib.sha256(path.with_suffix(".json").read_bytes()).hexdigest())


def generate(out_dir: str | Path, only: str | None = None, workers: int = 2) -> pd.DataFrame:
    """Write the campaign (or the files whose name contains `only`) and the MANIFEST."""
    truth = campaign_truth()
    todo = [j for j in jobs(truth) if only is None or only in j["file"]]
    out_dir = str(out_dir)
    if workers > 1 and len(todo) > 1:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            rows = list(pool.map(make_file, todo, [out_dir] * len(todo), [truth] * len(todo)))
    else:
        rows = [make_file(j, out_dir, truth) for j in todo]
    manifest = pd.DataFrame(rows)[["file", "kind", "pressure_kpa", "run", "sha256", "sidecar_sha256"]]
    if only is None:
        write_csv_atomic(manifest, Path(out_dir) / "MANIFEST.csv")
    return manifest
