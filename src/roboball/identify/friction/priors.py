"""Priors of a friction fit, and the coordinates it samples them on.

``configs/priors.yaml`` (validated by ``configs/schema/priors.schema.yaml`` and
:func:`roboball.checks.check_priors`) gives per joint, law and parameter: ``uniform`` (low,
high), ``loguniform`` (low, high) or ``lognormal`` (median, sigma_log, optional low/high), each
with a ``start`` for the least squares.  The noise level has a log-uniform prior on
[1e-5, 0.2] rad (:data:`NOISE_PRIOR`).  Positive parameters are sampled as logarithms
(:class:`Prior`).
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

import numpy as np

from roboball.config import CONFIG_DIR, load_yaml, validate
from roboball.errors import ConfigError, RoboballError
from roboball.identify.friction.segments import KIND_OF_JOINT
from roboball.physics import friction

NOISE_PRIOR = {"type": "loguniform", "low": 1e-5, "high": 0.2, "start": 1e-3}


@dataclass
class Prior:
    """A prior on a positive parameter theta, evaluated on the sampling coordinate
    u = log(theta - shift).

    ``shift`` is 0 except for a parameter whose prior starts at ``low >= 1`` with a natural
    origin there (Majd's ``n``: the law loses its sigma terms at n = 1 and only sigma (n - 1)
    is identified near it, so log(n - 1) turns that curved ridge into a straight one, which
    the ensemble moves sample far better).
    """

    name: str
    type: str
    low: float = 0.0
    high: float = math.inf
    median: float | None = None
    sigma_log: float | None = None
    start: float | None = None
    shift: float = 0.0

    @classmethod
    def from_spec(cls, name: str, spec: Mapping, shift: float = 0.0) -> "Prior":
        typ = spec["type"]
        low = float(spec.get("low", 0.0))
        high = float(spec.get("high", math.inf))
        p = cls(name, typ, low, high, spec.get("median"), spec.get("sigma_log"), spec.get("start"), float(shift))
        if typ not in ("uniform", "loguniform", "lognormal"):
            raise ConfigError(f"prior of {name}: unknown type {typ!r} (uniform, loguniform, lognormal)")
        if typ in ("uniform", "loguniform") and not (math.isfinite(high) and high > low):
            raise ConfigError(f"prior of {name}: {typ} needs low < high")
        if typ == "lognormal" and not (p.median and p.sigma_log and p.median > 0 and p.sigma_log > 0):
            raise ConfigError(f"prior of {name}: lognormal needs a positive median and sigma_log")
        if p.shift and p.low < p.shift:
            raise ConfigError(f"prior of {name}: low {p.low:g} is below the sampling origin {p.shift:g}")
        return p

    def theta(self, u):
        return self.shift + np.exp(u)

    def u_of(self, theta):
        return np.log(np.asarray(theta, dtype=float) - self.shift)

    @property
    def u_low(self) -> float:
        return math.log(self.low - self.shift) if self.low > self.shift else -math.inf

    @property
    def u_high(self) -> float:
        return math.log(self.high - self.shift) if math.isfinite(self.high) else math.inf

    def logpdf_u(self, u: np.ndarray) -> np.ndarray:
        """log density of u, up to a constant (-inf outside the bounds): log p(theta) + log dtheta/du."""
        u = np.asarray(u, dtype=float)
        inside = (u > self.u_low) & (u < self.u_high)
        with np.errstate(all="ignore"):
            th = self.theta(u)
            lt = np.log(th)
            if self.type == "loguniform":
                lp = -lt
            elif self.type == "uniform":
                lp = np.zeros_like(u)
            else:
                lp = -lt - 0.5 * ((lt - math.log(self.median)) / self.sigma_log) ** 2
            lp = lp + u
        return np.where(inside, lp, -np.inf)

    def sample_u(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """n draws of u from the prior (bounded lognormals by rejection)."""
        if n <= 0:
            return np.empty(0)
        if self.type == "loguniform":
            th = np.exp(rng.uniform(math.log(self.low), math.log(self.high), n))
        elif self.type == "uniform":
            th = rng.uniform(self.low, self.high, n)
        else:
            th = np.empty(0)
            while th.size < n:
                d = np.exp(rng.normal(math.log(self.median), self.sigma_log, 4 * n))
                th = np.concatenate([th, d[(d > self.low) & (d < self.high)]])
            th = th[:n]
        return self.u_of(np.maximum(th, self.shift + 1e-12))

    def interval95_u(self) -> tuple[float, float]:
        """The prior's central 95% interval of u (for the identifiability ratio), by quantiles
        of a fixed-seed sample (exact enough for a ratio)."""
        u = self.sample_u(np.random.default_rng(0), 20000)
        a, b = np.percentile(u, [2.5, 97.5])
        return float(a), float(b)

    def describe(self) -> dict:
        d = {"type": self.type, "low": self.low, "high": self.high if math.isfinite(self.high) else None}
        if self.type == "lognormal":
            d.update(median=self.median, sigma_log=self.sigma_log)
        if self.shift:
            d["sampled_as"] = f"log({self.name} - {self.shift:g})"
        return d


def load_priors(path: str | os.PathLike | None = None) -> dict:
    """Read configs/priors.yaml (or `path`), schema-validated and cross-checked."""
    from roboball.checks import check_priors

    path = Path(path) if path is not None else CONFIG_DIR / "priors.yaml"
    data = load_yaml(path, schema="priors.schema.yaml")
    return check_priors(data, str(path))


def law_priors(joint: str, law: str, priors: Mapping | str | os.PathLike | None = None,
               source: str = "priors") -> dict[str, Prior]:
    """Priors of the free parameters of `law` on `joint`.

    `priors` is a whole priors mapping (as in configs/priors.yaml), the block of this one law
    (``{param: spec}``, e.g. from ``--prior-json``), a path, or None for configs/priors.yaml.
    A law block is validated with the same schema and checks as the file.
    """
    from roboball.checks import check_priors

    if law not in friction.PARAMS or law == "none":
        raise RoboballError(f"{source}: unknown friction law '{law}' (viscous, coulomb_viscous, majd)")
    if joint not in KIND_OF_JOINT:
        raise RoboballError(f"{source}: unknown joint '{joint}' (steer or drive)")
    if priors is None or isinstance(priors, (str, os.PathLike)):
        data = load_priors(priors)
        source = str(priors or CONFIG_DIR / "priors.yaml")
    else:
        data = dict(priors)
        if not set(data) <= {"steer", "drive"}:     # a single law block
            data = {joint: {law: data}}
        validate(data, "priors.schema.yaml", source=source)
        check_priors(data, source)
    try:
        block = data[joint][law]
    except KeyError:
        raise ConfigError(f"{source}: no priors for law '{law}' on the {joint} joint; add '{joint}.{law}'")
    out = {}
    for name in friction.PARAMS[law]:
        if name in block:
            shift = 1.0 if (law == "majd" and name == "n" and float(block[name].get("low", 0.0)) >= 1.0) else 0.0
            out[name] = Prior.from_spec(name, block[name], shift=shift)
    return out
