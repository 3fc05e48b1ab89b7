"""A researcher's own campaign through the whole DAG (issue 45): any file names, any subset of the
recording kinds, `make figures RAW=DIR OUT=DIR2`.

Fast: the virtual campaign with each kind removed in turn, and with its shell releases at one
pressure, is planned by Snakemake (a dry run) with only what depends on the missing kind left
out, saying why.  Slow (CI): the same partial campaigns, reduced to two pressures and a short
configuration, run to the end; and the five public real logs, in their own folder with a
manifest written elsewhere by `roboball manifest --out`, go through `make figures RAW=...
MANIFEST=... OUT=...` and leave that folder as it was.
"""
from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import REAL_DATA, REPO

SNAKEMAKE = str(Path(sys.executable).with_name("snakemake"))
ROBOBALL = str(Path(sys.executable).with_name("roboball"))


def partial(dest: Path, drop=(), pressures=None, ramps_per_pressure=None) -> Path:
    """The virtual campaign (raw_data/, symlinked) without the kinds in `drop`, its shell, ramp and
    coupled recordings limited to `pressures` (kPa) and to `ramps_per_pressure` ramp runs each."""
    dest.mkdir(parents=True)
    lines = (REPO / "raw_data" / "MANIFEST.csv").read_text().splitlines()
    keep = [lines[0]]
    for line in lines[1:]:
        file, kind, p = line.split(",")[:3]
        if kind in drop or (pressures and kind in ("shell_rock", "ramp", "steer_coupled") and float(p) not in pressures):
            continue
        if ramps_per_pressure and kind == "ramp" and int(line.split(",")[3]) > ramps_per_pressure:
            continue
        keep.append(line)
        for ext in (".csv", ".json"):
            src = REPO / "raw_data" / Path(file).with_suffix(ext)
            (dest / src.parent.name).mkdir(exist_ok=True)
            os.symlink(src, dest / src.parent.name / src.name)
    (dest / "MANIFEST.csv").write_text("\n".join(keep) + "\n")
    return dest


def dry_run(raw: Path, work: Path) -> tuple[dict, str]:
    """(rule -> jobs planned, Snakemake's output) of the DAG on campaign `raw`, run in `work`."""
    work.mkdir(parents=True, exist_ok=True)
    r = subprocess.run([SNAKEMAKE, "-s", str(REPO / "Snakefile"), "-n", "--quiet", "rules", "--cores", "2",
                        "--config", f"campaign_dir={raw}", "figures_dir=figures"],
                       cwd=work, capture_output=True, text=True, timeout=300)
    out = r.stdout + r.stderr
    assert r.returncode == 0, out[-3000:]
    jobs = {}
    for line in out.splitlines():
        m = re.match(r"^\s*([A-Za-z_0-9]+)\s+(\d+)\s*$", line)
        if m and m.group(1) != "total":
            jobs[m.group(1)] = int(m.group(2))
    return jobs, out


SHELL_RULES = ("shell_regression", "shell_sim", "sweep_sim", "fig10", "fig11", "hydro_grid", "hydro_fit",
               "figS3_hydro_calibration", "figS1_deflating_ramp", "replay")
RAMP_RULES = ("ramp_sim", "diagnose_ramp", "ramp_diagnosed", "fig13_14")
CASES = {  # case -> (manifest filter, rules that must not run, rules that must, a line of the plan)
    "no steer stand": ({"drop": ("steer_stand",)}, ("friction_comparison", "figS2_steer_coupled"),
                       ("ramp_sim", "fig10", "table1"),
                       "skip  Fig. 7 and Table I rows: steer friction of 'c': no steer_stand recording in 'c'"),
    "no drive stand": ({"drop": ("drive_stand",)}, (), ("friction_comparison", "ramp_sim", "fig13_14", "figS2_steer_coupled"),
                       "note  ramp runs: no drive_stand Majd fit in 'c': its drive friction is Table I's"),
    "no shell releases": ({"drop": ("shell_rock",)}, SHELL_RULES + ("decay", "figS2_steer_coupled"),
                          ("fig13_14", "ramp_diagnosed"),
                          "skip  zeta(p), omega_n(p) regression and what needs it: Figs. 10, 11, the hydroelastic "
                          "calibration (Fig. S3), Fig. S1, the replays: no shell_rock recording with a known pressure"),
    "no ramp runs": ({"drop": ("ramp",)}, RAMP_RULES, SHELL_RULES, "skip  Figs. 13, 14 (ramp descents, PME): no ramp "
                     "recording"),
    "one shell pressure": ({"pressures": (13.8,)}, SHELL_RULES, ("decay", "fig13_14", "diagnose"),
                           "shell releases at one pressure only (13.8 kPa): decay table and diagnosis made, no regression"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_partial_campaign_plans_everything_that_does_not_need_what_is_missing(tmp_path, case):
    filt, absent, present, line = CASES[case]
    jobs, out = dry_run(partial(tmp_path / "c", **filt), tmp_path / "run")
    assert line in out, out[-3000:]
    assert not [r for r in absent if jobs.get(r)], jobs
    assert all(jobs.get(r) for r in present), jobs
    assert jobs["uncertainty_report"] == 1 and jobs["table2"] == 1
    if case == "no shell releases":          # the point contact only: the others need zeta(p), omega_n(p)
        # one ramp job per contact model, each running every run: the point contact's only
        assert jobs["ramp_sim"] == jobs["ramp_diagnosed"] == 1
        assert "ramp descents and their pooled diagnoses (15 runs at 5 pressures)" in out
    if case == "no steer stand":
        assert jobs["friction_fit"] == 1 and jobs["fig_stand"] == 1      # the drive stand's Majd fit, Fig. 8
    assert "virtual test bed" not in out


def make(*args, timeout: float = 300) -> subprocess.CompletedProcess:
    """`make figures ARGS` of the repository with this environment (no .venv of its own)."""
    venv = Path(sys.executable).parent.parent
    return subprocess.run(["make", "-s", "-C", str(REPO), "figures", f"VENV={venv}", "STAMP=", *args],
                          capture_output=True, text=True, timeout=timeout)


# ---- slow: to the end ----------------------------------------------------------------------------
def make_figures(raw: Path, out: Path, *extra) -> subprocess.CompletedProcess:
    r = make(f"RAW={raw}", f"OUT={out}", *extra, timeout=3000)
    assert r.returncode == 0, f"{r.stdout[-3000:]}\n{r.stderr[-5000:]}"
    return r


def short_config(out: Path) -> str:
    return f"SNAKEMAKE_TARGETS=--configfile {REPO / 'configs' / 'config.yaml'} {REPO / 'tests/data/config_partial.yaml'}"


@pytest.mark.slow
@pytest.mark.parametrize("case", sorted(CASES))
def test_a_partial_campaign_runs_to_the_end(tmp_path, case):
    filt = {"pressures": (6.9, 20.7), "ramps_per_pressure": 1, **CASES[case][0]}
    raw = partial(tmp_path / "c", **filt)
    out = tmp_path / "out"
    make_figures(raw, out, short_config(out))
    figs = {p.name for p in (out / "figures").glob("*.png")}
    assert "uncertainty_report.html" in {p.name for p in (out / "figures").iterdir()}
    assert ("fig13_ramp_pme.png" in figs) == ("ramp" not in filt.get("drop", ()))
    assert ("fig10_shell_dynamics.png" in figs) == (case not in ("no shell releases", "one shell pressure"))
    assert ("fig8_c_drive_fits.png" in figs) == (case != "no drive stand")
    assert not (REPO / "runs").exists() or not any((REPO / "runs").glob("c*"))


@pytest.mark.slow
@pytest.mark.skipif(not REAL_DATA.is_dir(), reason="real logs not available (../shared/data/roboball_real)")
def test_the_public_real_logs_are_a_campaign_like_any_other(tmp_path):
    """In their own folder, left as it is: the manifest is written elsewhere (MANIFEST=)."""
    raw = REAL_DATA
    before = {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in raw.iterdir()}
    manifest = tmp_path / "roboball_real.csv"
    subprocess.run([ROBOBALL, "manifest", str(raw), "--pressure-kpa", "unknown", "--steer-joint", "unknown",
                    "--out", str(manifest)], check=True, capture_output=True, text=True)
    out = tmp_path / "out"
    r = make_figures(raw, out, f"MANIFEST={manifest}")
    assert {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in raw.iterdir()} == before
    plan = r.stdout + r.stderr
    for line in ("skip  Fig. 8 and Table I rows: drive friction of 'roboball_real': no drive_stand recording",
                 "skip  Figs. 13, 14 (ramp descents, PME): no ramp recording",
                 "skip  zeta(p), omega_n(p) regression and what needs it"):
        assert line in plan, plan[-3000:]
    figs = out / "figures"
    for name in ("table1_friction.md", "fig7_roboball_real_steer_fits.png",
                 "figS2_steer_coupled_roboball_real.png", "table_coupled_rms_roboball_real.md",
                 "uncertainty_report.html", "fig5_friction_laws.png"):
        assert (figs / name).stat().st_size > 1000, name
    assert "steering_static_stand_response" in (figs / "table1_friction.md").read_text()
    decay = (out / "results" / "decay" / "dynamic_data.csv").read_text().splitlines()
    assert len(decay) == 2                                    # the shell log's one release
    diag = json.loads((out / "results" / "diagnose" / "dynamic_data" / "diagnosis.json").read_text())
    assert diag["verdict"]
    table = (figs / "table_coupled_rms_roboball_real.md").read_text()
    assert "Pressure (not logged): not fitted" in table and "| injected |" in table and "| diagnosed |" in table
    assert "virtual test bed" not in (figs / "uncertainty_report.html").read_text()


def test_a_bad_campaign_is_refused_in_one_line_before_any_job_and_leaves_nothing(tmp_path):
    raw = partial(tmp_path / "c", drop=("ramp", "shell_rock", "drive_stand", "steer_coupled"))
    (raw / "MANIFEST.csv").write_text((raw / "MANIFEST.csv").read_text() + "steer_stand/gone.csv,steer_stand,\n")
    out = tmp_path / "out"
    r = make(f"RAW={raw}", f"OUT={out}")
    assert r.returncode != 0
    assert f"{raw / 'MANIFEST.csv'}: line 3: steer_stand/gone.csv: file not found in {raw}" in r.stdout + r.stderr
    assert not out.exists()


def test_a_manifest_kept_outside_the_folder_of_logs_is_what_make_figures_reads(tmp_path):
    """make figures RAW=DIR MANIFEST=FILE plans from FILE (a dry run through the Makefile) and
    writes nothing into DIR; without it, DIR's own MANIFEST.csv is looked for."""
    raw = partial(tmp_path / "c", drop=("ramp", "shell_rock", "drive_stand", "steer_coupled"))
    manifest = tmp_path / "kept_elsewhere.csv"
    shutil.move(raw / "MANIFEST.csv", manifest)
    before = sorted(str(p.relative_to(raw)) for p in raw.rglob("*"))
    out = tmp_path / "out"
    r = make(f"RAW={raw}", f"OUT={out}", f"MANIFEST={manifest}", "SNAKEMAKE_TARGETS=-n")
    assert r.returncode == 0, (r.stdout + r.stderr)[-3000:]
    assert "make  Fig. 7 and Table I rows: steer friction of 'c'" in r.stdout + r.stderr
    assert sorted(str(p.relative_to(raw)) for p in raw.rglob("*")) == before
    r = make(f"RAW={raw}", f"OUT={tmp_path / 'out2'}", "SNAKEMAKE_TARGETS=-n")
    assert r.returncode != 0 and f"{raw / 'MANIFEST.csv'}: not found" in r.stdout + r.stderr


@pytest.mark.parametrize("arg", ["MANIFEST=lab.csv", "OUT=out", "NAME=lab"])
def test_a_campaigns_settings_without_its_folder_are_refused_not_ignored(arg):
    """Without RAW=, make figures would regenerate paper_figures/ from raw_data/ and silently drop
    OUT=, NAME= or MANIFEST=; it says so in one line instead, before anything runs."""
    r = make(arg, timeout=60)
    assert r.returncode != 0
    assert f"error: {arg.split('=')[0]}= given without RAW=DIR" in r.stdout + r.stderr


def test_an_environment_variable_named_like_a_campaign_setting_does_not_stop_make_figures():
    """Make reads the environment as variables: a shell's NAME or OUT must not refuse a plain run
    (the check `make figures` runs first)."""
    r = subprocess.run(["make", "-s", "-C", str(REPO), "campaign-args"], capture_output=True, text=True, timeout=60,
                       env={**os.environ, "NAME": "x", "OUT": "y", "MANIFEST": "z"})
    assert r.returncode == 0, r.stdout + r.stderr
