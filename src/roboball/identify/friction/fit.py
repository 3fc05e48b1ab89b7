"""Joint-friction identification on stand recordings: least squares, then emcee posteriors.

Model: ONE friction law (roboball.physics.friction) on ONE joint, in the calibrated stand
model of :mod:`roboball.reduced.planar` (steer stand: viscous, coulomb_viscous or majd; drive
stand: any law, the paper fits majd): the stand's added inertia delta_i (the gearbox's
reflected rotor inertia, which the URDF leaves out) and its rest offset are fitted with the law.
Data: every release of a stand recording at once, a list of segments (t, y, release) with y the
measured joint angle from the release instant to the end of the free response
(:mod:`~roboball.identify.friction.segments`).  Each release starts from rest at an initial
angle and instant that are nuisance parameters (:mod:`~roboball.identify.friction.problem`).

1. Least squares on the stacked residuals of all releases (:mod:`~roboball.identify.friction.lsq`),
   priors from ``configs/priors.yaml`` (:mod:`~roboball.identify.friction.priors`).
2. Step size: the RK4 step is chosen at the least-squares optimum
   (:mod:`~roboball.identify.friction.timestep`).
3. emcee: posterior of every law parameter, the noise level and the release angles, run until
   it has converged (:mod:`~roboball.identify.friction.sampler`), stored in a resumable HDF5
   chain (:mod:`~roboball.identify.friction.chain`).
4. The result: posterior summaries, identifiability, fit statistics (BIC, WAIC) and chain
   diagnostics (:mod:`~roboball.identify.friction.summary`), written and read by
   :mod:`~roboball.identify.friction.results`; model comparison in
   :mod:`~roboball.identify.friction.comparison`.

Every random draw comes from the ``seed`` argument.
"""
from __future__ import annotations

import json
import math
import os
import time
from pathlib import Path
from typing import Mapping, Sequence

import pandas as pd

from roboball.config import RobotFacts
from roboball.errors import RoboballError
from roboball.identify.friction.lsq import least_squares_fit
from roboball.identify.friction.priors import law_fixed, law_priors, stand_priors
from roboball.identify.friction.problem import RELEASE_SHIFT_HALF_WIDTH_S, FrictionProblem
from roboball.identify.friction.sampler import sample_posterior
from roboball.identify.friction.segments import JOINT_OF_KIND, KIND_OF_JOINT, Segment, segments_from_arrays
from roboball.identify.friction.summary import summarize
from roboball.identify.friction.timestep import DT_CANDIDATES, DT_TOLERANCE, adaptation_dt, choose_dt


def fit_segments(kind: str, law: str, segments: Sequence, chain_path: str | os.PathLike,
                 priors: Mapping | str | os.PathLike | None = None, *, seed: int = 0, walkers: int = 32,
                 autocorr_multiple: float = 50.0, max_steps: int = 20000, dt: float | None = None,
                 chunk: int = 50, robot: RobotFacts | None = None, fixed: Mapping | None = None,
                 source: str = "data", moves=None, min_steps: int = 100,
                 sample_angles: bool = True, stale: str = "refuse", code: str | None = None,
                 release_shift_s: float = RELEASE_SHIFT_HALF_WIDTH_S) -> tuple[dict, pd.DataFrame]:
    """Full fit of `law` on stand `kind` from segments (:func:`segments_from_arrays` input or
    :class:`Segment` list): least squares, step choice, emcee to convergence, summary.

    `priors` gives the law's and the stand's priors (:func:`law_priors`, :func:`stand_priors`);
    `fixed` holds any of their parameters at a value (``{"delta_i": 0, "rest_offset": 0}``: the
    stand as its URDF says), besides those the priors fix (``type: fixed``).  `release_shift_s`: the half-width of the release instants' prior
    (0: the instants are the release finder's).
    `dt` None chooses the RK4 step at the least-squares optimum (:func:`choose_dt`).
    `sample_angles` True (default) marginalises the release states in the posterior.  False
    conditions on their least-squares values: cheaper, but the friction levels are correlated
    with the release amplitudes, so the conditional intervals come out too narrow (by ~40% for
    f_w, f_c of a Majd fit in the tests); use it only for quick looks.
    `walkers` is raised to 2 x (number of sampled parameters) + 2 if it is smaller.  `stale`: what
    to do with a stored chain of another fit, and `code` the identity of the code stored with the
    chain (:func:`~roboball.identify.friction.sampler.sample_posterior`)."""
    t_start = time.perf_counter()
    joint = JOINT_OF_KIND.get(kind)
    if joint is None:
        raise RoboballError(f"{source}: friction fits need a stand recording (steer_stand or drive_stand), "
                            f"not '{kind}'")
    segs = segments if all(isinstance(s, Segment) for s in segments) else segments_from_arrays(segments, source)
    where = str(priors) if isinstance(priors, (str, os.PathLike)) else "priors"
    fixed = {**law_fixed(joint, law, priors, source=where), **(fixed or {})}     # the file's point priors, then the caller's
    problem = FrictionProblem(kind, law, segs, law_priors(joint, law, priors, source=where), fixed=fixed,
                              robot=robot, dt=dt or DT_CANDIDATES[0], stand=stand_priors(joint, priors, source=where),
                              shift_half_width=release_shift_s)
    lsq, dt_info = _least_squares_and_step(problem, dt, seed)
    t_lsq = time.perf_counter() - t_start
    if not sample_angles:
        problem.fix_releases(lsq["x"][problem.n_phys:])
    walkers = max(int(walkers), 2 * problem.ndim + 2)
    adapt_dt = adaptation_dt(problem.dt) if moves is None else problem.dt
    post = sample_posterior(problem, lsq, chain_path, seed=seed, n_walkers=walkers,
                            autocorr_multiple=autocorr_multiple, max_steps=max_steps, chunk=chunk,
                            moves=moves, min_steps=min_steps, stale=stale, code=code,
                            adapt_dt=adapt_dt)
    res, samples = summarize(problem, lsq, post, seed=seed, step_error=dt_info["max_error_rad"])
    res["integration"]["parameter_shift_sd"] = dt_info["max_shift_sd"]
    if adapt_dt != problem.dt:
        res["integration"]["adaptation_dt_s"] = adapt_dt     # the proposal's samples only
    if dt_info["max_shift_sd"] > DT_TOLERANCE:
        res["notes"].append(f"integration error {dt_info['max_error_rad']:.2g} rad shifts a parameter by "
                            f"{dt_info['max_shift_sd']:.2g} posterior sd at dt = {problem.dt:g} s (tolerance "
                            f"{DT_TOLERANCE}); the intervals may be biased")
    res["recording"] = Path(source).stem if source not in ("data", "") else source
    res["timing"] = {"wall_s": time.perf_counter() - t_start, "least_squares_s": t_lsq,
                     "simulation_calls": problem.n_sim_calls, "simulated_rows": problem.n_sim_rows}
    return res, samples


def _least_squares_and_step(problem: FrictionProblem, dt: float | None, seed: int) -> tuple[dict, dict]:
    """Least squares at the first candidate step, then the step chosen at its optimum (`dt`
    None; the least squares refined at the new step) or `dt`'s integration error measured.
    Returns (least squares, :func:`choose_dt` info)."""
    lsq = least_squares_fit(problem, seed=seed)
    if dt is None:
        chosen, dt_info = choose_dt(problem, lsq)
        if chosen != problem.dt:
            problem.dt = chosen
            lsq = _refine(problem, lsq, seed)
    else:
        _, dt_info = choose_dt(problem, lsq, candidates=(float(dt),), tolerance=math.inf)
    return lsq, dt_info


def _refine(problem: FrictionProblem, lsq: dict, seed: int) -> dict:
    """Re-run the least squares from the previous optimum after the step size changed."""
    saved = problem.start_point

    problem.start_point = lambda: lsq["x"]            # noqa: E731 - start from the previous optimum
    try:
        return least_squares_fit(problem, seed=seed, n_candidates=0, n_starts=1, max_nfev=30)
    finally:
        problem.start_point = saved


def fit(recording, releases, joint: str, law: str,
        prior: Mapping | str | os.PathLike | None, chain: str | os.PathLike, *, walkers: int = 32,
        autocorr_multiple: float = 50.0, max_steps: int = 20000, seed: int = 0,
        dt: float | None = None, sample_angles: bool = True, stale: str = "refuse",
        code: str | None = None) -> tuple[dict, pd.DataFrame]:
    """Pipeline entry: fit `law` on `joint` to a stand recording (CSV + sidecar) and its
    releases JSON (``{"releases": [{"t_release_s", "t_end_s", "y_release", ...}]}``), or to
    several runs of one stand together (lists of both, in the same order: their releases are
    the fit's segments, one after another); the other arguments as in :func:`fit_segments`."""
    from roboball.ingest.recording import read_recording

    if joint not in KIND_OF_JOINT:
        raise RoboballError(f"--joint: unknown joint '{joint}' (steer or drive)")
    recordings = [recording] if isinstance(recording, (str, os.PathLike)) else list(recording)
    release_files = [releases] if isinstance(releases, (str, os.PathLike)) else list(releases)
    if len(recordings) != len(release_files) or not recordings:
        raise RoboballError(f"--recording / --releases: {len(recordings)} recordings and {len(release_files)} "
                            "releases files; give one releases file per recording")
    kind = KIND_OF_JOINT[joint]
    parts, labels = [], []
    for rec_path, rel_path in zip(recordings, release_files):
        rec = read_recording(rec_path)
        if rec.kind != kind:
            raise RoboballError(f"{rec.label}: kind is '{rec.kind}', but a {joint}-joint friction fit needs a "
                                f"{kind} recording")
        parts += [(rec.time, rec.main_values(), r) for r in _release_list(rel_path)]
        labels.append(rec.label)
    source = " + ".join(str(r) for r in release_files)
    segs = segments_from_arrays(parts, source=source)
    res, samples = fit_segments(kind, law, segs, chain, prior, seed=seed, walkers=walkers,
                                autocorr_multiple=autocorr_multiple, max_steps=max_steps, dt=dt,
                                source=labels[0] if len(labels) == 1 else " + ".join(labels),
                                sample_angles=sample_angles, stale=stale, code=code)
    if len(labels) > 1:
        res["recording"] = " + ".join(Path(p).stem for p in recordings)
    releases = source
    res["releases_file"] = str(releases)
    return res, samples


def _release_list(path) -> list:
    """The releases of a releases JSON; a one-line error for a missing or malformed file."""
    try:
        with open(path, encoding="utf-8") as fh:
            return json.load(fh)["releases"]
    except FileNotFoundError:
        raise RoboballError(f"{path}: file not found")
    except (json.JSONDecodeError, KeyError, TypeError) as exc:
        raise RoboballError(f"{path}: not a releases JSON with a 'releases' list ({exc})")


