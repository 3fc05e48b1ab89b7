"""The campaign plan the workflow expands: which recordings there are, what can be made of them
and what is skipped (each with its reason), how the ramp runs group by pressure, which
hydroelastic sweep cases and replays run.  The Snakefile's rules only name files; every choice of
what to run is made here, where it is tested (tests/pipeline/test_plan.py).

A campaign is a folder of recordings and the manifest that lists them; a run analyses one or
more campaigns (config `campaigns`; `make figures RAW=DIR` analyses DIR alone).  Each campaign's
recordings are a dataset of their own (its `id`: stand fits, Fig. 7/8, the coupled test); the
shell regression pools every shell release of known pressure in the run.

    from roboball.pipeline.plan import Campaign
    camp = Campaign.from_config(config, base=".")   # the workflow's config.yaml, already validated
    camp.stems("ramp")                               # ['ramp_10.3kpa_r1', ...]
    camp.other_runs("ramp_10.3kpa_r1")               # the runs whose pooled diagnosis scores it
    print("\\n".join(camp.plan_lines()))             # what it makes, what it skips and why
"""
from __future__ import annotations

import os
import re
from dataclasses import dataclass, field

from roboball.errors import ConfigError
from roboball.kinds import STANDS

# One interactive Drake replay per experiment kind: the contact model it shows and the release
# (rad: steer/drive stand angle, shell roll angle; the ramp starts from rest).
REPLAYS = {"steer_stand": ("point", 0.8), "drive_stand": ("point", 0.6), "shell_rock": ("injected", -0.3),
           "ramp": ("hydroelastic", 0.0)}
STAND_FIGURE = {"steer": 7, "drive": 8}          # the paper's figure of each joint's stand fits


def campaign_id(name: str) -> str:
    """A campaign's name as it appears in file names and wildcards: roboball_real."""
    slug = re.sub(r"[^a-z0-9]+", "_", name.lower()).strip("_")
    return slug or "campaign"


def campaigns_of(config: dict) -> list[dict]:
    """The run's campaigns: config `campaigns`, or the one folder of `campaign_dir` (make figures
    RAW=DIR; named by `campaign_name`, else by its manifest, else by the folder), listed by
    `campaign_manifest` when given (MANIFEST=FILE), else by its own MANIFEST.csv."""
    if config.get("campaign_dir"):
        raw = os.path.normpath(str(config["campaign_dir"]))
        manifest = {"manifest": str(config["campaign_manifest"])} if config.get("campaign_manifest") else {}
        return [{"id": "", "name": str(config.get("campaign_name") or ""), "raw": raw,
                 "diagnose_recordings": True, "fallback_name": os.path.basename(raw), **manifest}]
    return [dict(c) for c in config["campaigns"]]


@dataclass
class Campaign:
    """stem -> {"src", "kind", "pressure_kpa", "dataset", "steer_joint", ...} for every recording
    the workflow processes, with the datasets (campaigns) they belong to."""

    recordings: dict
    datasets: dict = field(default_factory=dict)     # id -> {"name", "diagnose_recordings"}
    notes: list = field(default_factory=list)

    @classmethod
    def from_config(cls, config: dict, base: str = ".") -> "Campaign":
        """Every campaign of the config read through its manifest (roboball.ingest.manifest);
        relative folders are taken from `base` (the workflow's folder).  A campaign marked
        `optional` whose folder is missing is skipped with a note; two recordings of one name in
        the run are refused in one line."""
        from roboball.ingest.manifest import manifest_name, read_manifest

        recordings: dict = {}
        datasets: dict = {}
        notes: list = []
        for c in campaigns_of(config):
            raw = _from(base, c["raw"])
            if not os.path.isdir(raw):
                if c.get("optional"):
                    notes.append(f"skip  campaign '{c['name']}': folder {c['raw']} not found "
                                 "(optional; see README, 'Your own recordings')")
                    continue
                raise ConfigError(f"campaign '{c['name'] or c['raw']}': folder {c['raw']} not found")
            found = read_manifest(raw, _from(base, c["manifest"]) if c.get("manifest") else None)
            name = c["name"] or manifest_name(found) or c.get("fallback_name") or "campaign"
            cid = c["id"] or campaign_id(name)
            if cid in datasets:
                raise ConfigError(f"campaign '{name}': id {cid} is used by another campaign of the run")
            for stem, r in found.items():
                if stem in recordings:
                    raise ConfigError(f"{r['where']}: {stem}: same name as {recordings[stem]['where']}; results are "
                                      "named after the recording, so rename one of them (or give column name)")
                recordings[stem] = {**r, "dataset": cid}
            datasets[cid] = {"name": name, "diagnose_recordings": bool(c.get("diagnose_recordings", True))}
        if not recordings:
            raise ConfigError("no campaign to analyse: every campaign's folder is missing")
        return cls(recordings, datasets, notes)

    # ---- the recordings -------------------------------------------------------------------
    def stems(self, kind: str, dataset: str | None = None) -> list:
        """The run's (or one dataset's) recordings of one kind, sorted."""
        return sorted(s for s, r in self.recordings.items()
                      if r["kind"] == kind and (dataset is None or r["dataset"] == dataset))

    def pressure(self, stem: str) -> float | None:
        """The recording's pressure (kPa), None where it is unknown or does not matter."""
        p = self.recordings[stem]["pressure_kpa"]
        try:
            return float(p)
        except ValueError:
            return None

    def known_pressure(self, kind: str) -> list:
        return [s for s in self.stems(kind) if self.pressure(s) is not None]

    def shell_pressures(self) -> list:
        return sorted({round(self.pressure(s), 6) for s in self.known_pressure("shell_rock")})

    def has_regression(self) -> bool:
        """zeta(p) and omega_n(p) need shell releases at two pressures at least."""
        return len(self.shell_pressures()) >= 2

    def dataset_of(self, kind: str) -> str | None:
        """The first dataset (in the config's order) with recordings of `kind`."""
        return next((d for d in self.datasets if self.stems(kind, d)), None)

    def name(self, dataset: str | None) -> str:
        return self.datasets[dataset]["name"] if dataset in self.datasets else ""

    # ---- stand fits ------------------------------------------------------------------------
    def stand_stems(self, dataset: str, joint: str) -> list:
        """The stand runs of one joint of one dataset, fitted together."""
        return self.stems(f"{joint}_stand", dataset)

    def fits(self, friction: dict) -> list:
        """(dataset, joint, law) of every friction fit: the config's laws of each joint that has
        a stand recording in the dataset."""
        return [(d, joint, law) for d in self.datasets for joint, law in friction_models(friction)
                if self.stand_stems(d, joint)]

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

    def ramp_friction(self, friction: dict) -> dict:
        """joint -> the Majd fit the ramp runs' model takes, for the joints of the ramp runs'
        dataset that have a stand (the others run with Table I's values, configs/robot.yaml)."""
        d = self.dataset_of("ramp")
        return {j: f"results/friction/{d}/{j}_majd.json" for j in ("steer", "drive")
                if (d, j, "majd") in self.fits(friction)}

    # ---- the coupled steer test (Fig. S2) ----------------------------------------------------
    def coupled_groups(self) -> dict:
        """Each dataset's coupled recordings as sets of repeats of one experiment: one set per
        logged pressure, and one of those whose pressure is not logged (the real robot's).  Set
        name -> (dataset, stems, pressure in kPa or None); the name, which suffixes Fig. S2's
        files, joins the dataset's id and the logged pressure (`real`, `testbed_6.9kpa`)."""
        out = {}
        for d in self.datasets:
            by_p: dict = {}
            for s in self.stems("steer_coupled", d):
                p = self.pressure(s)
                by_p.setdefault(None if p is None else round(p, 6), []).append(s)
            for p in sorted(by_p, key=lambda v: (v is not None, v or 0.0)):
                name = d if p is None else f"{d}_{p:g}kpa"
                out[name] = (d, by_p[p], p)
        return out

    def coupled_plan(self, friction: dict) -> tuple[dict, list]:
        """({set name: (dataset, stems, pressure)} of the sets of repeats that make a Fig. S2,
        [(set name, why not)] of the others): a set needs two repeats (leave-one-out), its
        dataset's steer Majd fit, and shell laws (the regression, else its dataset's shell
        releases)."""
        ok, skipped = {}, []
        fits = self.fits(friction)
        for name, (d, stems, p) in self.coupled_groups().items():
            if len(stems) < 2:
                why = "one steer_coupled recording; leave-one-out needs two repeats"
            elif (d, "steer", "majd") not in fits:
                why = f"no steer_stand Majd fit in '{self.name(d)}' for its steer friction"
            elif not self.has_regression() and not self.stems("shell_rock", d):
                why = f"no shell regression and no shell_rock recording in '{self.name(d)}' to take the shell laws from"
            else:
                ok[name] = (d, stems, p)
                continue
            skipped.append((name, why))
        return ok, skipped

    def diagnosed_stems(self) -> list:
        """The stand and shell recordings diagnosed one by one: those of the datasets whose
        config asks for it (the virtual campaign's are its calibration data)."""
        return [s for k in (*STANDS, "shell_rock") for s in self.stems(k)
                if self.datasets[self.recordings[s]["dataset"]]["diagnose_recordings"]]

    # ---- what the run makes and what it skips -------------------------------------------------
    def plan_lines(self, friction: dict) -> list:
        """One line per part of the paper's pipeline: `make  ...` or `skip  ...: reason`."""
        return self.notes + plan_lines(self, friction)


def _from(base: str, path: str) -> str:
    return path if os.path.isabs(path) or base in ("", ".") else os.path.join(base, path)


def plan_lines(camp: Campaign, friction: dict) -> list:
    """What the run makes and skips (see Campaign.plan_lines); the targets in common.smk follow
    the same tests."""
    out = []

    def say(ok: bool, what: str, why: str):
        out.append(f"make  {what}" if ok else f"skip  {what}: {why}")

    for d, info in camp.datasets.items():
        n = {k: len(camp.stems(k, d)) for k in ("steer_stand", "drive_stand", "shell_rock", "ramp", "steer_coupled")}
        out.append(f"campaign '{info['name']}' ({d}): " + ", ".join(f"{v} {k}" for k, v in n.items()))
        for joint in ("steer", "drive"):
            stands = camp.stand_stems(d, joint)
            runs = f" ({len(stands)} runs fitted together)" if len(stands) > 1 else ""
            say(bool(stands), f"Fig. {STAND_FIGURE[joint]} and Table I rows: {joint} friction of '{info['name']}'{runs}",
                f"no {joint}_stand recording in '{info['name']}'")
    shells = camp.stems("shell_rock")
    say(bool(shells), f"shell decay tables ({len(shells)} recording{'s' if len(shells) != 1 else ''})",
        "no shell_rock recording")
    ps = camp.shell_pressures()
    why = ("no shell_rock recording with a known pressure" if not ps else
           f"shell releases at one pressure only ({ps[0]:g} kPa): decay table and diagnosis made, no regression")
    reg = camp.has_regression()
    say(reg, "zeta(p), omega_n(p) regression" + (f" over {len(ps)} pressures" if reg else "") + " and what needs it: "
        "Figs. 10, 11, the hydroelastic calibration (Fig. S3), Fig. S1, the replays", why)
    ramps = camp.stems("ramp")
    if ramps:
        d = camp.dataset_of("ramp")
        missing = [j for j in ("steer", "drive") if (d, j, "majd") not in camp.fits(friction)]
        say(True, f"ramp descents and their pooled diagnoses ({len(ramps)} runs at {len(camp.ramp_groups())} "
            "pressures): Figs. 13, 14" + ("" if reg else ", point contact and the diagnosed model only (no shell "
                                           "regression for the others)"), "")
        for j in missing:
            out.append(f"note  ramp runs: no {j}_stand Majd fit in '{camp.name(d)}': its {j} friction is Table I's "
                       "(configs/robot.yaml), without posterior draws")
        single = [camp.recordings[runs[0]]["pressure_kpa"] for runs in map(camp.runs_at, camp.ramp_groups())
                  if len(runs) == 1]
        if single:
            out.append(f"note  ramp runs: one run at {', '.join(f'{float(p):g}' for p in single)} kPa: the diagnosed "
                       "model is scored there on the run its diagnosis was fitted on (in sample, marked in Figs. 13, 14)")
    else:
        say(False, "Figs. 13, 14 (ramp descents, PME)", "no ramp recording")
    groups = camp.coupled_groups()
    sets, skipped = camp.coupled_plan(friction)
    for name, (d, stems, p) in sets.items():
        at = "pressure not logged" if p is None else f"at {p:g} kPa"
        say(True, f"Fig. S2 (coupled steer test, {len(stems)} repeats of '{camp.name(d)}', {at})"
            + ("" if reg else ": shell laws held at its shell releases' zeta and omega_n (no regression)"
               + ("" if p is not None else "; the models that need the pressure are left out")), "")
    for name, why in skipped:
        d, stems, p = groups[name]
        say(False, f"Fig. S2 (coupled steer test of '{camp.name(d)}', "
            + ("pressure not logged)" if p is None else f"at {p:g} kPa)"), why)
    if not camp.stems("steer_coupled"):
        say(False, "Fig. S2 (coupled steer test)", "no steer_coupled recording")
    diag = camp.diagnosed_stems()
    say(bool(diag), f"diagnoses of {len(diag)} stand and shell recordings", "no campaign asks for them "
        "(diagnose_recordings) or none has stand or shell recordings")
    out.append("make  the uncertainty report")
    return out


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
        try:
            p = float(p)
        except ValueError:
            continue                       # pressure unknown (a real log): nothing to calibrate at
        if p != p:
            continue
        out.setdefault(f"shell_{p:g}kpa", []).append(s)
    return {g: sorted(v) for g, v in sorted(out.items(), key=lambda kv: float(kv[0][6:-3]))}


DEFAULT_SCHEDULE = {"time_s": [0.0, 3.0], "pressure_kpa": [20.7, 6.9]}


def schedule_args(schedule: dict | None) -> str:
    """Command-line arguments of `deflating-ramp` for a pressure schedule: a CSV file, or knots."""
    schedule = schedule or DEFAULT_SCHEDULE
    if "csv" in schedule:
        return f"--schedule-csv {schedule['csv']}"
    return ("--schedule-time-s " + " ".join(str(x) for x in schedule["time_s"]) +
            " --schedule-pressure-kpa " + " ".join(str(x) for x in schedule["pressure_kpa"]))
