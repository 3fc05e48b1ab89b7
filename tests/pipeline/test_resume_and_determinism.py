"""A pipeline killed part-way resumes to the same bytes, and two clean
runs give identical tables and JSON.

Each run works in its own temporary copy of the workflow (Snakefile, workflow/, configs/) with a
reduced campaign: two shell-rocking recordings of raw_data/ (symlinked, never copied) and the
authors' real logs switched off.  The target is the shell regression plus one Drake shell
simulation: ingest (validation, normalisation, release finding, QC plot), decay fits, the
pressure regressions and a simulation, i.e. CSV, JSON and PNG outputs of every kind of stage.

* Kill and resume: Snakemake is started in its own process group and SIGKILLed as soon as the
  first jobs have finished, with others running.  Every file present after the kill must
  already be complete (byte-identical to the uninterrupted run): atomic writes never leave a
  half-written output that a rerun would take as finished.  Runs go through the repository's
  `make figures` (on the reduced targets), so the Makefile itself must recover from the kill:
  Snakemake refuses to start over a stale directory lock or past incomplete outputs unless
  told what to do (roboball.pipeline.runlock and --rerun-incomplete).
* Determinism: two clean runs give byte-identical CSV and JSON outputs (and, with matplotlib's
  metadata stripped by roboball.figures.paper.save, identical PNGs).
"""
from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import REPO
SNAKEMAKE = str(Path(sys.executable).with_name("snakemake"))
STEMS = ("shell_rock_6.9kpa_r1", "shell_rock_17.2kpa_r1")
TARGETS = ("results/identify/shell_regression.csv", "results/shell_sim/point/shell_rock_17.2kpa_r1.csv")
# Written by Snakemake itself, with timings and dates in them: not pipeline results.
VOLATILE = ("results/logs/", "results/benchmarks/")
pytestmark = pytest.mark.slow


def make_workdir(root: Path) -> Path:
    """A runnable copy of the workflow with a two-recording campaign."""
    root.mkdir(parents=True)
    shutil.copy2(REPO / "Snakefile", root / "Snakefile")
    shutil.copytree(REPO / "workflow", root / "workflow")
    shutil.copytree(REPO / "configs", root / "configs")
    # the real logs' campaign is optional: its folder (../shared/... from here) is missing, so it is skipped
    raw = root / "raw_data"
    (raw / "shell_rock").mkdir(parents=True)
    lines = (REPO / "raw_data" / "MANIFEST.csv").read_text().splitlines()
    keep = [lines[0]] + [l for l in lines[1:] if Path(l.split(",")[0]).stem in STEMS]
    assert len(keep) == len(STEMS) + 1
    (raw / "MANIFEST.csv").write_text("\n".join(keep) + "\n")
    for stem in STEMS:
        for ext in (".csv", ".json"):
            os.symlink(REPO / "raw_data" / "shell_rock" / f"{stem}{ext}", raw / "shell_rock" / f"{stem}{ext}")
    return root


def make_figures(workdir: Path) -> list[str]:
    """`make figures` of the repository's Makefile, run in `workdir` on the reduced targets, with
    this interpreter's environment (its stamp file is not rebuilt)."""
    venv = Path(sys.executable).parent.parent
    return ["make", "-s", "-C", str(workdir), "-f", str(REPO / "Makefile"), "figures", f"VENV={venv}", "STAMP=",
            "CORES=2", "SNAKEMAKE_TARGETS=" + " ".join(TARGETS)]


def run(workdir: Path, check: bool = True) -> subprocess.CompletedProcess:
    r = subprocess.run(make_figures(workdir), capture_output=True, text=True, timeout=600)
    if check and r.returncode != 0:
        raise AssertionError(f"make figures failed in {workdir}:\n{r.stdout[-3000:]}\n{r.stderr[-4000:]}")
    return r


def outputs(workdir: Path) -> dict[str, bytes]:
    """Every pipeline result (relative path -> bytes), without Snakemake's logs and timings."""
    out = {}
    for p in sorted((workdir / "results").rglob("*")):
        rel = p.relative_to(workdir).as_posix()
        if p.is_file() and not rel.startswith(VOLATILE):
            out[rel] = p.read_bytes()
    return out


@pytest.fixture(scope="module")
def clean_run(tmp_path_factory):
    work = make_workdir(tmp_path_factory.mktemp("reliability") / "clean")
    t0 = time.monotonic()
    run(work)
    elapsed = time.monotonic() - t0
    print(f"clean reduced run: {elapsed:.1f} s")
    return work, outputs(work), elapsed


def test_clean_run_builds_the_targets(clean_run):
    _, files, _ = clean_run
    for target in TARGETS:
        assert target in files
    for stem in STEMS:
        for suffix in (".csv", ".json", ".releases.json"):
            assert f"results/ingest/{stem}{suffix}" in files
        assert files[f"results/qc/{stem}.png"].startswith(b"\x89PNG")
    # No temporary files of the atomic writers are left behind.
    assert not [f for f in files if Path(f).name.startswith(".")]


def test_kill_and_resume_gives_identical_results(clean_run, tmp_path):
    _, reference, clean_s = clean_run
    work = make_workdir(tmp_path / "killed")
    proc = subprocess.Popen(make_figures(work), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    try:
        # Kill once the first jobs are done, while others are running (2 cores, 6 jobs).
        deadline = time.monotonic() + 300
        while not list((work / "results" / "ingest").glob("*.releases.json")):
            assert proc.poll() is None, "snakemake ended before it could be killed"
            assert time.monotonic() < deadline, "no job finished within 300 s"
            time.sleep(0.05)
        time.sleep(0.5)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    partial = outputs(work)
    assert not all(t in partial for t in TARGETS), "the run finished before the kill; nothing was tested"
    # The kill hit running jobs and left Snakemake's lock behind: the rerun has something to recover from.
    assert list((work / ".snakemake" / "incomplete").iterdir()), "no job was running at the kill"
    assert list((work / ".snakemake" / "locks").glob("*.lock")), "no stale lock after the kill"
    # Whatever exists after a SIGKILL is complete: identical to the uninterrupted run's file.
    # (Hidden *.tmp files are the atomic writers' scratch files: never a result.)
    for rel, data in partial.items():
        if Path(rel).name.startswith("."):
            assert Path(rel).name.endswith(".tmp"), rel
            continue
        assert data == reference[rel], f"{rel} is half-written after the kill"

    t0 = time.monotonic()
    r = run(work, check=False)
    assert r.returncode == 0, "rerunning `make figures` did not recover:\n" + r.stderr[-3000:]
    print(f"kill after {clean_s:.0f} s clean run; resume took {time.monotonic() - t0:.1f} s")
    resumed = {k: v for k, v in outputs(work).items() if not Path(k).name.startswith(".")}
    assert set(resumed) == set(reference)
    differ = [k for k in reference if resumed[k] != reference[k]]
    assert not differ, f"resumed results differ from an uninterrupted run: {differ}"
    # A further run has nothing to do.
    again = subprocess.run([SNAKEMAKE, *TARGETS, "-n"], cwd=work, capture_output=True, text=True)
    assert "Nothing to be done" in again.stdout + again.stderr


def test_two_clean_runs_are_byte_identical(clean_run, tmp_path):
    _, reference, _ = clean_run
    work = make_workdir(tmp_path / "second")
    run(work)
    second = outputs(work)
    assert set(second) == set(reference)
    tables = [k for k in reference if k.endswith((".csv", ".json"))]
    assert len(tables) >= 3 * len(STEMS) + 4
    differ = [k for k in tables if second[k] != reference[k]]
    assert not differ, f"two clean runs differ in {differ}"
    # Figures are written without timestamps or software versions: identical too.
    pngs = [k for k in reference if k.endswith(".png")]
    assert pngs and all(second[k] == reference[k] for k in pngs)
