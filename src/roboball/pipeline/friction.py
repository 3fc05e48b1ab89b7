"""Friction stages: one fit per (recording, joint, law), and the model comparison."""
from __future__ import annotations

import json

from roboball.atomic import write_csv_atomic

STAGES = ("friction_fit", "friction_comparison")
# The module whose import closure computes a chain's log-probability: its source fingerprint is
# stored with the chain, so a chain sampled by other code is not resumed.
FIT_MODULE = "roboball.identify.friction.fit"


def friction_fit(recording: list, releases: list, joint: str, law: str, prior_json: str, chain: str,
                 out_json: str, out_samples: str, walkers: int = 32, autocorr_multiple: float = 50.0,
                 max_steps: int = 20000, seed: int = 0) -> None:
    """Least squares then emcee posterior of `law` on `joint`, over every stand run given (one
    releases file each, fitted together).  The HDF5 chain is the rule's
    resumable cache: an interrupted run continues it; a chain of another fit (data, prior,
    robot facts, settings or the code changed, which is why Snakemake reruns the rule) is
    sampled afresh."""
    from roboball.identify.friction.fit import fit
    from roboball.identify.friction.results import write_fit
    from roboball.pipeline.codedeps import source_fingerprint

    res, samples = fit(recording[0] if len(recording) == 1 else recording,
                       releases[0] if len(releases) == 1 else releases, joint, law, json.loads(prior_json), chain, walkers=walkers,
                       autocorr_multiple=autocorr_multiple, max_steps=max_steps, seed=seed, stale="restart",
                       code=source_fingerprint(FIT_MODULE))
    write_fit(out_json, out_samples, res, samples)


def friction_comparison(fits: list, out_csv: str) -> None:
    """Residual, log-likelihood and BIC of each law fitted to the same recording."""
    from roboball.identify.friction.comparison import comparison

    write_csv_atomic(comparison(fits), out_csv)
