"""The campaign plan the workflow expands: which recordings there are, how the ramp runs group by
pressure, which hydroelastic sweep cases and replays run.  The Snakefile's rules only name files;
every choice of what to run is made here, where it is tested (tests/pipeline/test_plan.py).

    from roboball.pipeline.plan import Campaign
    camp = Campaign.from_config(config)          # the workflow's config.yaml, already validated
    camp.stems("ramp")                           # ['ramp_10.3kpa_r1', ...]
    camp.other_runs("ramp_10.3kpa_r1")           # the runs whose pooled diagnosis scores it
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field

from roboball.errors import ConfigError

# The real logs' stems in the results (the authors' recordings, config section real_data).
REAL_STEMS = {"steer_stand": "real_steer_stand", "shell_rock": "real_shell_rock"}

# One interactive Drake replay per experiment kind: the contact model it shows and the release
# (rad: steer/drive stand angle, shell roll angle; the ramp starts from rest).
REPLAYS = {"steer_stand": ("point", 0.8), "drive_stand": ("point", 0.6), "shell_rock": ("injected", -0.3),
           "ramp": ("hydroelastic", 0.0)}


@dataclass
class Campaign:
    """stem -> {"src", "kind", "pressure_kpa"} for every recording the workflow processes
    (raw_data/MANIFEST.csv, plus the real logs when `real_on`)."""

    recordings: dict
    real_on: bool = False
    notes: list = field(default_factory=list)

    @classmethod
    def from_config(cls, config: dict) -> "Campaign":
        """The campaign of the workflow's config: the manifest of `raw_data` (checked by
        roboball.ingest.manifest.read_manifest) and the real logs of `real_data`.  `enabled: auto` takes
        them when their folder exists; `enabled: true` requires it (a one-line ConfigError)."""
        from roboball.ingest.manifest import read_manifest

        recordings = read_manifest(config["raw_data"])
        real = config["real_data"]
        on = real["enabled"] is True or (real["enabled"] == "auto" and os.path.isdir(real["path"]))
        if real["enabled"] is True and not os.path.isdir(real["path"]):
            raise ConfigError(f"real_data.path {real['path']}: folder not found "
                              "(set real_data.enabled: auto or false)")
        notes = []
        if on:
            for kind, stem in REAL_STEMS.items():
                if stem in recordings:
                    raise ConfigError(f"{config['raw_data']}/MANIFEST.csv: recording {stem}: the name of a real log "
                                      f"({real['path']}); rename the file (their results would overwrite each other)")
                recordings[stem] = {"src": os.path.join(real["path"], real[kind]), "kind": kind, "pressure_kpa": ""}
            # the shell log's steer setting, which the log does not record (config's comment)
            recordings[REAL_STEMS["shell_rock"]]["steer_joint"] = real.get("shell_rock_steer_joint", "locked")
        else:
            notes.append(f"roboball: real logs not found at {real['path']}: the real-data part of the pipeline "
                         "is skipped (see README, 'Real recordings').")
        return cls(recordings, on, notes)

    def stems(self, kind: str, real: bool = False) -> list:
        """The campaign's (or, with `real`, the real logs') recordings of one kind, sorted."""
        return sorted(s for s, r in self.recordings.items()
                      if r["kind"] == kind and (s in REAL_STEMS.values()) == real)

    # ---- ramp runs by pressure (the pooled diagnoses, issue 6) ------------------------------
    def pressure_group(self, stem: str) -> str:
        """Name of the ramp runs at the pressure of `stem`: ramp_13.8kpa."""
        return f"ramp_{float(self.recordings[stem]['pressure_kpa']):g}kpa"

    def ramp_groups(self) -> list:
        return sorted({self.pressure_group(s) for s in self.stems("ramp")})

    def runs_at(self, group: str) -> list:
        return [s for s in self.stems("ramp") if self.pressure_group(s) == group]

    def other_runs(self, stem: str) -> list:
        """The other ramp runs at the pressure of `stem`, whose pooled diagnosis gives its
        out-of-sample effects; all runs at it (itself) when it is the only one."""
        same = self.runs_at(self.pressure_group(stem))
        return [s for s in same if s != stem] or same


def sweep_cases(factors) -> dict:
    """The hydroelastic sensitivity sweep (section III-D): case -> (modulus scale, dissipation
    scale), each factor applied to the modulus, the dissipation and both.  The control case
    (1, 1) is the hydroelastic shell simulation itself."""
    out = {}
    for f in factors:
        out[f"modulus_x{f:g}"] = (f, 1.0)
        out[f"dissipation_x{f:g}"] = (1.0, f)
        out[f"both_x{f:g}"] = (f, f)
    return out


def friction_models(friction: dict) -> list:
    """(joint, law) of every stand fit: config section `friction`'s steer_laws and drive_laws."""
    return [("steer", law) for law in friction["steer_laws"]] + [("drive", law) for law in friction["drive_laws"]]


# The hydroelastic calibration's settings when config shell.hydro_fit leaves them out.
DEFAULT_HYDRO_FIT = {"modulus_pa": [1.0e4, 3.0e6], "n_modulus": 8, "dissipation_s_m": [0.1, 10.0],
                     "n_dissipation": 5, "tol": 0.01, "max_drake_evals": 4, "draws": 400}


def hydro_fit_settings(shell: dict) -> dict:
    """Config section shell.hydro_fit over its defaults."""
    return {**DEFAULT_HYDRO_FIT, **(shell.get("hydro_fit") or {})}


def hydro_grid_moduli(settings: dict) -> dict:
    """The calibration grid's columns: job name -> modulus (Pa), log-spaced over the range."""
    import numpy as np

    lo, hi = settings["modulus_pa"]
    return {f"m{k}": float(f"{m:.6g}") for k, m in enumerate(np.geomspace(lo, hi, settings["n_modulus"]))}


def shell_pressure_groups(recordings: dict, stems: list) -> dict:
    """Shell recordings by pressure: 'shell_13.8kpa' -> its stems (the calibration fits each
    pressure to all releases recorded at it)."""
    out: dict = {}
    for s in stems:
        p = recordings[s]["pressure_kpa"]
        if p in ("", None) or float(p) != float(p):
            continue                       # pressure unknown (a real log): nothing to calibrate at
        out.setdefault(f"shell_{float(p):g}kpa", []).append(s)
    return {g: sorted(v) for g, v in sorted(out.items(), key=lambda kv: float(kv[0][6:-3]))}


DEFAULT_SCHEDULE = {"time_s": [0.0, 3.0], "pressure_kpa": [20.7, 6.9]}


def schedule_args(schedule: dict | None) -> str:
    """Command-line arguments of `deflating-ramp` for a pressure schedule: a CSV file, or knots."""
    schedule = schedule or DEFAULT_SCHEDULE
    if "csv" in schedule:
        return f"--schedule-csv {schedule['csv']}"
    return ("--schedule-time-s " + " ".join(str(x) for x in schedule["time_s"]) +
            " --schedule-pressure-kpa " + " ".join(str(x) for x in schedule["pressure_kpa"]))
