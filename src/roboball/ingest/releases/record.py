"""The record of one release found in a recording (roboball.ingest.releases)."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

__all__ = ["Release"]


@dataclass
class Release:
    """One release and the free response after it.

    Times in seconds in the recording's time base; indices into the arrays given to
    :func:`find_releases` (i_release: last sample at or before the release instant;
    i_end: last sample at or before t_end_s).  y_* in the signal's unit.
    """

    t_release_s: float
    t_end_s: float
    i_release: int
    i_end: int
    y_release: float
    y_rest: float
    held_from_s: float
    half_period_s: float = float("nan")
    noise: float = float("nan")
    kind: str = ""

    def __post_init__(self):
        # JSON has no NaN: unknown numbers travel as null and come back as NaN.
        for name in ("y_release", "y_rest", "half_period_s", "noise"):
            if getattr(self, name) is None:
                setattr(self, name, float("nan"))

    def as_dict(self) -> dict:
        """Plain dict for JSON: unknown numbers (NaN) become None; Release(**d) restores them."""
        d = asdict(self)
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in d.items()}
