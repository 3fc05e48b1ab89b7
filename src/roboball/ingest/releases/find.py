"""Finding the releases: the entry points (the method: roboball.ingest.releases)."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from roboball.errors import RoboballError
from roboball.ingest.releases.oscillation import oscillation_releases
from roboball.ingest.releases.ramp import ramp_release
from roboball.ingest.releases.record import Release
from roboball.ingest.releases.signal import prepare_signal
from roboball.kinds import RECORDED

if TYPE_CHECKING:  # pragma: no cover
    from roboball.ingest.recording import Recording

__all__ = ["find_releases", "recording_releases", "require_releases"]


def find_releases(
    t,
    y,
    kind: str,
    *,
    ramp_exit_s: float | None = None,
    min_hold_s: float = 0.25,
    min_offset_sigma: float = 20.0,
    hold_speed: float = 0.1,
    min_relative_offset: float = 0.05,
) -> list[Release]:
    """Find the releases in one signal (the method: the docstring of roboball.ingest.releases).

    `kind` is a recording kind: steer_stand, drive_stand, shell_rock, steer_coupled (hand
    releases and free oscillations; a log trimmed at the let-go is released at its first
    sample) or ramp (one start of motion, ending at `ramp_exit_s` if given).
    `min_hold_s`: shortest hand hold accepted; `min_offset_sigma`: smallest hold offset
    from rest, in noise levels; `hold_speed`: fastest speed that still counts as held, as a
    fraction of the free swing's peak speed (offset x omega); `min_relative_offset`:
    releases smaller than this fraction of the file's largest release are taken for hand
    tremor and dropped.  Works on irregular sampling with gaps and duplicate stamps.
    Returns the releases in time order (possibly none).
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if kind not in RECORDED:
        raise ValueError(f"find_releases: unknown kind {kind!r}")
    try:
        sig = prepare_signal(t, y)
    except ValueError:
        return []
    if kind == "ramp":
        releases = ramp_release(sig, ramp_exit_s)
    else:
        releases = oscillation_releases(sig, kind, min_hold_s, min_offset_sigma, hold_speed,
                                         min_relative_offset)
    # Indices into the caller's arrays.
    for r in releases:
        pos = int(np.searchsorted(sig.tk, r.t_release_s, side="right")) - 1
        r.i_release = int(sig.index[max(pos, 0)])
        pos = int(np.searchsorted(sig.tk, r.t_end_s, side="right")) - 1
        r.i_end = int(sig.index[max(pos, 0)])
    return releases


def recording_releases(rec: "Recording", signal: str | None = None, **kwargs) -> list[Release]:
    """:func:`find_releases` on a recording's main signal (or `signal`)."""
    name = signal or rec.main_signal()
    kwargs.setdefault("ramp_exit_s", rec.ramp_exit_s)
    return find_releases(rec.time, rec.signal(name), rec.kind, **kwargs)


def require_releases(rec: "Recording", signal: str | None = None, **kwargs) -> list[Release]:
    """Like :func:`recording_releases`, but a recording without any release is a user
    error: raises a one-line :class:`RoboballError` naming the file."""
    name = signal or rec.main_signal()
    releases = recording_releases(rec, name, **kwargs)
    if not releases:
        if rec.kind == "ramp":
            what = "no start of motion found (the drive rate never leaves its initial rest)"
        else:
            what = ("no release found (no hold away from rest followed by a free, decaying "
                    "oscillation)")
        raise RoboballError(
            f"{rec.label}: {name}: {what}; check the kind and the signal, "
            "or record a hand release (move, hold still, let go)"
        )
    return releases
