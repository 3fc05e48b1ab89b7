"""Priors of a friction fit, and the coordinates it samples them on.

``configs/priors.yaml`` (validated by ``configs/schema/priors.schema.yaml`` and
:func:`roboball.checks.check_priors`) gives per joint, law and parameter: ``uniform`` (low,
high), ``loguniform`` (low, high) or ``lognormal`` (median, sigma_log, optional low/high), each
with a ``start`` for the least squares; Majd's law is given (and sampled) by its stiction peak,
``h_peak`` and ``v_peak``, instead of sigma and omega_c (:data:`roboball.physics.friction.FIT_PARAMS`).  Per joint, the
``stand`` block gives the priors of the stand's calibration (:data:`STAND_PARAMS`: the added
inertia ``delta_i`` and the ``rest_offset``, uniform, sampled on their own scale).  The noise
level has a log-uniform prior on [1e-5, 0.2] rad (:data:`NOISE_PRIOR`).  Positive law
parameters are sampled as logarithms (:class:`Prior`).
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
from roboball.identify.friction.results import STAND_PARAMS
from roboball.identify.friction.segments import KIND_OF_JOINT
from roboball.physics import friction

NOISE_PRIOR = {"type": "loguniform", "low": 1e-5, "high": 0.2, "start": 1e-3}
STAND_UNITS = {"delta_i": "kg m^2", "rest_offset": "rad"}


@dataclass
class Prior:
    """A prior on a parameter theta, evaluated on the sampling coordinate u = log(theta - shift)
    (a positive parameter) or u = theta (``linear``: a uniform prior on a quantity that may be
    zero or negative, the stand's calibration).

    ``shift`` moves the logarithm's origin (0 for every prior of the fits).  Majd's n was once
    sampled as log(n - 1), to straighten the (sigma, n) ridge near n = 1; with the law sampled
    by its stiction peak there is no such ridge, and log(n - 1) gave n's posterior a long
    exponential tail towards n = 1 (the prior's density (n - 1) p(n) on that axis) that stuck
    the real steer log's chain (slowest tau 208 steps against 14 with log n).
    """

    name: str
    type: str
    low: float = 0.0
    high: float = math.inf
    median: float | None = None
    sigma_log: float | None = None
    start: float | None = None
    shift: float = 0.0
    linear: bool = False

    @classmethod
    def from_spec(cls, name: str, spec: Mapping, shift: float = 0.0, linear: bool = False) -> "Prior":
        typ = spec["type"]
        low = float(spec.get("low", 0.0))
        high = float(spec.get("high", math.inf))
        p = cls(name, typ, low, high, spec.get("median"), spec.get("sigma_log"), spec.get("start"), float(shift),
                bool(linear))
        if typ not in ("uniform", "loguniform", "lognormal"):
            raise ConfigError(f"prior of {name}: unknown type {typ!r} (uniform, loguniform, lognormal)")
        if linear and typ != "uniform":
            raise ConfigError(f"prior of {name}: sampled on its own scale, it needs a uniform prior, not {typ}")
        if typ in ("uniform", "loguniform") and not (math.isfinite(high) and high > low):
            raise ConfigError(f"prior of {name}: {typ} needs low < high")
        if typ == "lognormal" and not (p.median and p.sigma_log and p.median > 0 and p.sigma_log > 0):
            raise ConfigError(f"prior of {name}: lognormal needs a positive median and sigma_log")
        if p.shift and p.low < p.shift:
            raise ConfigError(f"prior of {name}: low {p.low:g} is below the sampling origin {p.shift:g}")
        return p

    def theta(self, u):
        return np.asarray(u, dtype=float) + 0.0 if self.linear else self.shift + np.exp(u)

    def u_of(self, theta):
        if self.linear:
            return np.asarray(theta, dtype=float)
        return np.log(np.asarray(theta, dtype=float) - self.shift)

    @property
    def u_low(self) -> float:
        if self.linear:
            return self.low
        return math.log(self.low - self.shift) if self.low > self.shift else -math.inf

    @property
    def u_high(self) -> float:
        if self.linear:
            return self.high
        return math.log(self.high - self.shift) if math.isfinite(self.high) else math.inf

    def logpdf_u(self, u: np.ndarray) -> np.ndarray:
        """log density of u, up to a constant (-inf outside the bounds): log p(theta) + log dtheta/du."""
        u = np.asarray(u, dtype=float)
        inside = (u > self.u_low) & (u < self.u_high)
        if self.linear:
            return np.where(inside, 0.0, -np.inf)
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
        if self.linear:
            return rng.uniform(self.low, self.high, n)
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
        elif self.linear:
            d["sampled_as"] = self.name
        return d


def load_priors(path: str | os.PathLike | None = None) -> dict:
    """Read configs/priors.yaml (or `path`), schema-validated and cross-checked."""
    from roboball.checks import check_priors

    path = Path(path) if path is not None else CONFIG_DIR / "priors.yaml"
    data = load_yaml(path, schema="priors.schema.yaml")
    return check_priors(data, str(path))


def _resolved(joint: str, law: str | None, priors, source: str) -> tuple[dict, str]:
    """(the whole priors mapping, validated, and where it came from) from a mapping, one law's
    block (``{param: spec}``), a path, or None (configs/priors.yaml)."""
    from roboball.checks import check_priors

    if law is not None and law not in friction.FIT_PARAMS:
        raise RoboballError(f"{source}: unknown friction law '{law}' (viscous, coulomb_viscous, majd)")
    if joint not in KIND_OF_JOINT:
        raise RoboballError(f"{source}: unknown joint '{joint}' (steer or drive)")
    if priors is None or isinstance(priors, (str, os.PathLike)):
        return load_priors(priors), str(priors or CONFIG_DIR / "priors.yaml")
    data = dict(priors)
    if not set(data) <= {"steer", "drive"}:     # a single law block
        data = {joint: {law: data}}
    validate(data, "priors.schema.yaml", source=source)
    check_priors(data, source)
    return data, source


def law_priors(joint: str, law: str, priors: Mapping | str | os.PathLike | None = None,
               source: str = "priors") -> dict[str, Prior]:
    """Priors of the free parameters of `law` on `joint` (:data:`roboball.physics.friction.FIT_PARAMS`).

    `priors` is a whole priors mapping (as in configs/priors.yaml), the block of this one law
    (``{param: spec}``, e.g. from ``--prior-json``), a path, or None for configs/priors.yaml.
    A law block is validated with the same schema and checks as the file.
    """
    data, source = _resolved(joint, law, priors, source)
    try:
        block = data[joint][law]
    except KeyError:
        raise ConfigError(f"{source}: no priors for law '{law}' on the {joint} joint; add '{joint}.{law}'")
    return {name: Prior.from_spec(name, block[name]) for name in friction.FIT_PARAMS[law]
            if name in block and block[name]["type"] != "fixed"}


def law_fixed(joint: str, law: str, priors: Mapping | str | os.PathLike | None = None,
              source: str = "priors") -> dict[str, float]:
    """The parameters of `law` on `joint` that `priors` holds at a value (``type: fixed``, a
    point prior stated in the file: Majd's n, whose value the swings do not pin), as
    {name: value}; `priors` as for :func:`law_priors`."""
    data, source = _resolved(joint, law, priors, source)
    block = data.get(joint, {}).get(law, {})
    return {name: float(spec["value"]) for name, spec in block.items() if spec["type"] == "fixed"}


def stand_priors(joint: str, priors: Mapping | str | os.PathLike | None = None,
                 source: str = "priors") -> dict[str, Prior]:
    """Priors of the stand's calibration on `joint` (:data:`STAND_PARAMS`): the ``JOINT.stand``
    block of `priors` (as for :func:`law_priors`), or of configs/priors.yaml when `priors` has
    none (a single law's block, or a mapping without it)."""
    if isinstance(priors, Mapping) and not set(priors) <= {"steer", "drive"}:     # one law's block
        return stand_priors(joint, None)
    data, source = _resolved(joint, None, priors, source)
    if "stand" not in data.get(joint, {}):
        if priors is None:
            raise ConfigError(f"{source}: no priors for the {joint} stand's calibration; add '{joint}.stand'")
        return stand_priors(joint, None)
    block = data[joint]["stand"]
    return {name: Prior.from_spec(name, block[name], linear=True) for name in STAND_PARAMS}
