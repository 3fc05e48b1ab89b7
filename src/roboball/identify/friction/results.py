"""Fit files: the one writer and reader of what a friction fit stores.

A fit is two files: the JSON result (:func:`roboball.identify.friction.summary.summarize`, plus
``recording``, ``timing``, ``releases_file`` and ``samples_csv``) and the CSV of its posterior
samples that the JSON names.  Every consumer reads them here: the figures and Table I, the
reports, the model comparison and the fitted friction the simulations take
(:mod:`roboball.identify.friction.fitted`), so that a malformed file fails the same way, in one
line naming the file, everywhere.  Kept apart from the fitting modules (and from the friction
laws) so that reading a fit pulls neither the sampler nor the laws into the code fingerprint of
the stages that only read one.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Collection

from roboball.atomic import write_csv_atomic, write_json_atomic
from roboball.errors import RoboballError

SUMMARY_KEYS = ("median", "ci95_low", "ci95_high")     # what every reader of a parameter needs
# The stand's calibration fitted with every law (roboball.reduced.planar: calibrated stand).
STAND_PARAMS = ("delta_i", "rest_offset")


def write_fit(out_json: str, out_samples: str, result: dict, samples) -> None:
    """Write a fit: the posterior samples (a DataFrame) to `out_samples`, then the result to
    `out_json`, naming the samples file (``samples_csv``, added to `result`)."""
    write_csv_atomic(samples, out_samples)
    result["samples_csv"] = out_samples
    write_json_atomic(out_json, result)


def read_json(path) -> object:
    """The JSON in `path`; a one-line error naming the file when it cannot be read or parsed."""
    try:
        with open(path, encoding="utf-8") as fh:
            return json.load(fh)
    except FileNotFoundError:
        raise RoboballError(f"{path}: file not found")
    except OSError as exc:
        raise RoboballError(f"{path}: cannot read it ({exc.strerror or exc})")
    except json.JSONDecodeError as exc:
        raise RoboballError(f"{path}: not JSON (line {exc.lineno}: {exc.msg})")


@dataclass(frozen=True)
class FrictionFit:
    """One fit file as its readers use it.

    ``parameters`` maps the law's sampled parameters and ``noise_rad`` to their posterior
    summary (``median``, ``ci95_low``, ``ci95_high``, ``map``, ...); ``convergence`` holds the
    chain diagnostics ({} when none were recorded; keys ``converged``, ``steps``, ``burn_in``,
    ``max_tau``, ``chain_over_tau``, ``ess_min``, ``acceptance_fraction``, ...) and ``stats``
    the fit statistics (the file's ``fit``: ``rmse_rad``, ``loglik_max``, ``bic``, ...).  The
    stand's calibration (``delta_i``, ``rest_offset``) is among the parameters when it was
    fitted, among ``fixed`` when it was held (:meth:`stand`).
    """

    path: Path
    joint: str
    law: str
    recording: str                      # "" when not recorded
    parameters: dict
    fixed: dict                         # parameters the fit held fixed, {} when none
    convergence: dict
    stats: dict
    release_angles: list | None         # posterior summaries of the release angles, in release order
    samples_csv: str | None
    release_shifts: list | None = None  # posterior summaries of the release instants' shifts (s)
    timing: dict | None = None          # wall_s, least_squares_s, ... of the fit

    def stand(self) -> dict:
        """The stand's calibration, {"delta_i": summary, "rest_offset": summary} (a held value
        as a summary of zero width); {} for a fit without one (made before it existed)."""
        out = {}
        for name in STAND_PARAMS:
            if name in self.parameters:
                out[name] = self.parameters[name]
            elif name in self.fixed:
                v = float(self.fixed[name])
                out[name] = {"median": v, "ci95_low": v, "ci95_high": v}
        return out

    def stand_values(self) -> dict:
        """The calibrated stand a simulation of this fit runs with: posterior medians (or held
        values) of ``delta_i`` and ``rest_offset``, 0 where the fit has none."""
        st = self.stand()
        return {name: float(st[name]["median"]) if name in st else 0.0 for name in STAND_PARAMS}

    def release_shift_medians(self) -> list | None:
        """Fitted shifts of the release instants (s), in release order; None if not fitted."""
        return [a["median"] for a in self.release_shifts] if self.release_shifts else None

    def medians(self, names: Collection[str]) -> dict:
        """Posterior medians of the parameters among `names` (e.g. the law's) that were sampled."""
        return {k: v["median"] for k, v in self.parameters.items() if k in names}

    def release_angle_medians(self) -> list | None:
        """Fitted release angles in release order; files that kept them as parameters named like
        release_1_rad are read too.  None if the file has none."""
        if self.release_angles is not None:
            return [a["median"] for a in self.release_angles]
        keys = sorted((k for k in self.parameters if k.startswith("release")),
                      key=lambda k: int("".join(c for c in k if c.isdigit()) or 0))
        return [self.parameters[k]["median"] for k in keys] or None

    def samples(self, n: int | None = None, seed: int = 0):
        """The posterior samples (a DataFrame), at most `n` of them drawn with `seed`."""
        import pandas as pd

        s = pd.read_csv(self.samples_csv)
        if n is not None and len(s) > n:
            s = s.sample(n, random_state=seed)
        return s


def _checked(d: dict, path) -> FrictionFit:
    for key in ("joint", "law"):
        if key not in d:
            raise RoboballError(f"{path}: friction fit without field '{key}'")
    params = d["parameters"]
    if not isinstance(params, dict) or not params:
        raise RoboballError(f"{path}: field 'parameters' must map parameter names to their posterior summary")
    for name, p in params.items():
        for key in SUMMARY_KEYS:
            if not isinstance(p, dict) or key not in p:
                raise RoboballError(f"{path}: parameter '{name}' has no '{key}'")
    return FrictionFit(Path(path), d["joint"], d["law"], d.get("recording", ""), params, d.get("fixed", {}),
                       d.get("convergence") or {}, d.get("fit", {}), d.get("release_angles"), d.get("samples_csv"),
                       d.get("release_shifts_s"), d.get("timing") or {})


def is_fit(d) -> bool:
    """Whether parsed JSON is a fit result (an object with ``parameters``)."""
    return isinstance(d, dict) and "parameters" in d


def try_read_fit(path) -> FrictionFit | None:
    """The fit in `path`, or None for a JSON file that is not a fit (no ``parameters``); a
    malformed fit is a one-line error naming the file and the field."""
    d = read_json(path)
    return _checked(d, path) if is_fit(d) else None


def read_fit(path) -> FrictionFit:
    """The fit in `path`; a one-line error naming the file and what is wrong."""
    fit = try_read_fit(path)
    if fit is None:
        raise RoboballError(f"{path}: not a friction fit (no 'parameters')")
    return fit


def point_estimate(d: dict) -> dict:
    """The law as fitted, from a parsed fit result: the values of the parameters the fit held
    fixed, and the posterior medians of the others (entries that are plain numbers are read
    as the value)."""
    fixed = d.get("fixed") if isinstance(d.get("fixed"), dict) else {}
    return {**fixed, **{k: (v.get("median") if isinstance(v, dict) else v) for k, v in d["parameters"].items()}}
