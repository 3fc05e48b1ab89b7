"""What a friction fit takes: the releases of one stand recording, and the joint each stand swings.

Each release starts from rest at the release instant; a segment is its free response, from
the release to the end of the swing (:func:`segments_from_arrays` cuts it from a recording).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from roboball.errors import RoboballError

KIND_OF_JOINT = {"steer": "steer_stand", "drive": "drive_stand"}
JOINT_OF_KIND = {v: k for k, v in KIND_OF_JOINT.items()}


@dataclass
class Segment:
    """One release: sample times ``t`` (s, recording time base, all >= t_release), measured
    angles ``y`` (rad), the release instant and the angle there (initial guess)."""

    t: np.ndarray
    y: np.ndarray
    t_release: float
    y_release: float


def _get(release, *names, default=None):
    for n in names:
        if isinstance(release, Mapping) and n in release and release[n] is not None:
            return release[n]
        if not isinstance(release, Mapping) and getattr(release, n, None) is not None:
            return getattr(release, n)
    return default


def segments_from_arrays(data: Sequence, source: str = "data") -> list[Segment]:
    """Segments from a list of ``(t, y, release)`` triples.

    `release` is the release time (float), or a mapping / object with ``t_release_s`` (and
    optionally ``t_end_s``, ``y_release``; :class:`roboball.ingest.releases.record.Release` works).  Samples
    before the release and after ``t_end_s`` are dropped; the release angle defaults to the
    measured angle interpolated at the release time.  Several triples may share one (t, y).
    """
    segs = []
    for i, item in enumerate(data):
        try:
            t, y, rel = item
        except (TypeError, ValueError):
            raise RoboballError(f"{source}: segment {i + 1}: expected (t, y, release)")
        t = np.asarray(t, dtype=float).ravel()
        y = np.asarray(y, dtype=float).ravel()
        if t.shape != y.shape:
            raise RoboballError(f"{source}: segment {i + 1}: {t.size} times but {y.size} angles")
        if isinstance(rel, (int, float, np.floating)):
            t_rel, t_end, y_rel = float(rel), None, None
        else:
            t_rel = _get(rel, "t_release_s", "t_release")
            t_end = _get(rel, "t_end_s", "t_end")
            y_rel = _get(rel, "y_release")
            if t_rel is None:
                raise RoboballError(f"{source}: release {i + 1}: no release time (t_release_s)")
            t_rel = float(t_rel)
        keep = np.isfinite(t) & np.isfinite(y) & (t >= t_rel)
        if t_end is not None:
            keep &= t <= float(t_end)
        if keep.sum() < 10:
            raise RoboballError(f"{source}: release {i + 1} at {t_rel:.3f} s: only {int(keep.sum())} samples "
                                "after the release; need at least 10")
        if y_rel is None or not math.isfinite(float(y_rel)):
            y_rel = float(np.interp(t_rel, t[np.isfinite(y)], y[np.isfinite(y)]))
        segs.append(Segment(t[keep], y[keep], t_rel, float(y_rel)))
    if not segs:
        raise RoboballError(f"{source}: no releases to fit")
    return segs
