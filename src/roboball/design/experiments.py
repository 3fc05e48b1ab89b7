"""The experiments the rig can run for a kind, and every candidate's predicted recording of each.

An experiment is a recording like the user's (same sample rate, same noise, releases held the
way the diagnosis finds them) with other settings: the release angle (one release, or two in one
recording), how long each release is left to settle (the user's window or twice it) and, for a
shell, whether the steer joint is clamped.  Every candidate is simulated by the diagnosis's own
engine (roboball.diagnose.fit.Engine on the reduced model of its kind, the sensor's fitted lag
included), from its fitted values and from `N_DRAWS` draws of its uncertain parameters, so the
predictions carry the parameters' uncertainty.

A ramp run's experiments are the ramp's angle instead (roboball.design.ramp).  Not varied, and
why: pressure: the reduced models hold no law of how an effect's parameters change with pressure
(the diagnosis fits them at the recording's), so no candidate predicts another pressure.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roboball.config import load_robot
from roboball.diagnose.data import Prepared, Window
from roboball.diagnose.fit import Engine
from roboball.diagnose.sensor import LAG_KEY

N_DRAWS = 12            # parameter draws per candidate (besides its fitted values)
SEED = 47               # the draws' stream: the same design every run
# release angles from rest (rad): a stand's pendulum is held up to the joint's limits; a hand
# rolls the shell (locked steering) up to about 0.6 rad, past which the pipe's ends near the floor
AMPLITUDES = {"stand": tuple(round(0.1 * i, 2) for i in range(1, 16)),
              "shell_rock": tuple(round(0.05 * i, 2) for i in range(1, 13))}
SETTLE_FACTORS = (1.0, 2.0)     # each release's duration, in units of the user's window
AT_REST = 0.02          # rad/s: slower than this, a body is at rest (its dry friction holds it or it creeps)
# rad from rest: a shell rolled further has its pendulum above the horizontal and rolls over; a
# candidate whose fit predicts that (one fitted to small swings, released far beyond them) runs
# away, and how far its reduced model then says it goes (1e12 rad, seen) means nothing
RUNAWAY_RAD = math.pi / 2


@dataclass
class Grid:
    """Every candidate's predictions for one steer setting: releases (absolute, rad) x samples."""

    steer_joint: str                # shell_rock: locked / free / "as recorded"; "" elsewhere
    # (W,) rad, absolute (the recording's signal at the release); on a ramp, its angles (deg)
    releases: np.ndarray
    t: np.ndarray                   # (N,) s since the release
    central: dict                   # candidate label -> (W, N) predicted signal at its fitted values
    var: dict                       # candidate label -> (W, N) variance over the parameter draws
    feasible: np.ndarray            # (W,) the swing stays inside the joint's limits for every candidate
    moving: np.ndarray              # (W, N) samples before every candidate has come to rest
    runaway: dict                   # candidate label -> (W,) its prediction left RUNAWAY_RAD from rest


def user_timing(prep: Prepared) -> tuple[float, float]:
    """(sample interval, window duration) of the user's recording: medians over its releases."""
    dts = np.concatenate([np.diff(w.t) for w in prep.windows])
    dt = float(np.median(dts[dts > 0]))
    return dt, float(np.median([w.duration for w in prep.windows]))


def releases_for(kind: str, rest: float) -> np.ndarray:
    amps = AMPLITUDES["shell_rock" if kind == "shell_rock" else "stand"]
    return np.array([rest + s * a for a in amps for s in (1.0, -1.0)])


def synthetic(prep: Prepared, releases: np.ndarray, t: np.ndarray) -> Prepared:
    """A recording like `prep` with releases at `releases` (rad) sampled at `t` (s): windows
    that start at their release (the diagnosis's windows' form; the values y are unused)."""
    rel = prep.windows[0].release
    wins = [Window(index=i, t0=0.0, t=t.copy(), y=np.zeros_like(t), q0=float(q), release=rel, start="release")
            for i, q in enumerate(releases)]
    return Prepared(recording=prep.recording, kind=prep.kind, signal=prep.signal, unit=prep.unit, windows=wins,
                    noise=prep.noise, quantum=prep.quantum)


def draws(values: dict, sigma: dict, engine: Engine, rng: np.random.Generator, n: int) -> list:
    """`values` and `n` draws of its uncertain parameters (independent normal, kept inside the
    parameters' bounds; details.json gives intervals, not their correlations)."""
    out = [dict(values)]
    for _ in range(n):
        v = dict(values)
        for key, s in sigma.items():
            x = values[key] + s * rng.standard_normal()
            if key in engine.info:
                _, lo, hi = engine.info[key]
                x = min(max(x, lo), hi)
            v[key] = x
        out.append(v)
    return out


def predict(cand, kind: str, synth: Prepared, steer_joint: str | None, rng, model=None):
    """(fitted-value prediction, variance over the draws, fitted-value rate), each (W, N), of
    candidate `cand` in the synthetic recording `synth` with the shell's steer joint `steer_joint`
    (or on `model`: a ramp's at another angle)."""
    model = model or cand.model(kind, steer_joint)
    engine = Engine(model, synth)
    if LAG_KEY in cand.values:          # seen through the sensor's fitted lag, as the log was
        engine.sensor = {LAG_KEY: cand.values[LAG_KEY]}
    sets = draws(cand.values, cand.sigma, engine, rng, N_DRAWS)
    items = []
    for v in sets:
        for w in synth.windows:
            vw = dict(v, **{f"q0@{w.index}": w.q0, f"ts@{w.index}": 0.0})
            for h in model.hidden_release:          # a free pendulum released at rest on its joint
                vw[f"{h.name}@{w.index}"] = model.steer_rest if h.name == "steer_angle" else 0.0
            items.append((vw, w.index))
    out = engine.predict(items)
    ys = np.array([y for y, _ in out]).reshape(len(sets), len(synth.windows), -1)
    rate = np.array([yd for _, yd in out[:len(synth.windows)]])
    return ys[0], ys[1:].var(axis=0), rate


def limits(kind: str) -> tuple[float, float]:
    """The coordinate's range (rad): the steer joint's limits on the steer stand (robot facts)."""
    if kind == "steer_stand":
        j = load_robot().joints["steer"]
        return float(j["lower_rad"]), float(j["upper_rad"])
    return -math.inf, math.inf


def grid(src, choice, steer_joint: str | None) -> Grid:
    """Every candidate of `choice` predicted over the kind's releases, each left to settle for
    the longest duration considered (shorter ones are its first part)."""
    dt, dur = user_timing(src.prep)
    t = np.arange(0.0, max(SETTLE_FACTORS) * dur + 0.5 * dt, dt)
    rest = choice.candidates[0].model(src.kind, steer_joint).rest
    releases = releases_for(src.kind, rest)
    synth = synthetic(src.prep, releases, t)
    central, var, runaway, speed = {}, {}, {}, np.zeros((len(releases), len(t)))
    for cand in choice.candidates:
        y, v, rate = predict(cand, src.kind, synth, steer_joint, np.random.default_rng(SEED))
        if src.kind == "shell_rock":
            y, v, runaway[cand.label] = rolled_over(y, v, cand.model(src.kind, steer_joint).rest)
        else:
            runaway[cand.label] = np.zeros(len(releases), bool)
        central[cand.label], var[cand.label] = y, v
        speed = np.maximum(speed, np.where(np.isfinite(rate), np.abs(rate), 0.0))
    lo, hi = limits(src.kind)
    feasible = np.ones(len(releases), bool)
    for y in central.values():
        feasible &= np.all((y >= lo) & (y <= hi), axis=1) & np.all(np.isfinite(y), axis=1)
    return Grid(steer_joint or "", releases, t, central, var, feasible, moving(speed, t), runaway)


def rolled_over(y: np.ndarray, var: np.ndarray, rest: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A shell candidate's predictions (W, N) and their variance held at `RUNAWAY_RAD` from `rest`
    from the sample they first pass it on (the shell has rolled over; the model's angle beyond
    says nothing), and which releases (W,) did.  A candidate that rolls over where the other
    swings back is told from it all the same, by at most the bound: the separation stays a
    number of noise levels a recording can show."""
    with np.errstate(invalid="ignore"):
        past = np.abs(y - rest) > RUNAWAY_RAD
    after = np.cumsum(past, axis=1) > 0
    first = np.argmax(past, axis=1)
    side = np.sign(y[np.arange(len(y)), first] - rest)
    side = np.where(np.isfinite(side) & (side != 0), side, 1.0)
    y = np.where(after, rest + RUNAWAY_RAD * side[:, None], y)
    var = np.where(after, np.minimum(np.nan_to_num(var, nan=np.inf), RUNAWAY_RAD ** 2), var)
    return y, var, after.any(axis=1)


def moving(speed: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(W, N): the samples up to the last at which some candidate still moves faster than
    `AT_REST`.  Where the body has stopped, the angle it rests at is set by where dry friction
    caught its last reversal: a slight change of the friction moves it anywhere within the
    band the friction holds, and the memoryless law creeps there (docs/diagnosis.md), so the
    candidates' resting angles are no evidence of the physics that tells them apart; counted,
    they would rank every release by how far apart the two stop."""
    fast = speed > AT_REST
    last = np.where(fast.any(axis=1), fast.shape[1] - 1 - np.argmax(fast[:, ::-1], axis=1), 0)
    return np.arange(len(t))[None, :] <= last[:, None]
