"""Through the real command line (subprocesses, as the pipeline runs it).

Every file of the bad-recording corpus (tests/bad_recordings/) given to `roboball stage ingest`
(the pipeline's ingest) gives its expected one-line error, exit code 2, advice on what to do, no
traceback and no output file.  The accepted quirks (CRLF, byte-order mark, blank lines, duplicate
stamps) pass validation, and a real campaign recording rewritten with CRLF line endings and a BOM
ingests to exactly the same outputs as the original.  Config and simulation faults are in
test_reliability_config.py and test_reliability_sim.py.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from conftest import CORPUS, INGEST_ERRORS, REPO, SIDECAR_NAMED, one_error_line
BIN = Path(sys.executable).parent
ROBOBALL = str(BIN / "roboball")

MAIN_SIGNAL = {"steer_stand": "steer_angle_rad", "shell_rock": "pipe_angle_rad", "ramp": "drive_rate_rad_s"}


def roboball(*args, env=None, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run([ROBOBALL, *map(str, args)], capture_output=True, text=True, env=env, cwd=cwd,
                          timeout=300)


def ingest(src: Path, out: Path) -> subprocess.CompletedProcess:
    out.mkdir(parents=True, exist_ok=True)
    stem = src.stem
    return roboball("stage", "ingest", "--src", src, "--out-csv", out / f"{stem}.csv",
                    "--out-releases", out / f"{stem}.releases.json", "--qc-png", out / f"{stem}.png")


# --------------------------------------------------------------------------------------------
# the corpus through the pipeline's ingest
# --------------------------------------------------------------------------------------------
def _crlf_bom(src: Path, dst: Path, bom: bool) -> Path:
    """Copy a recording and its sidecar with CRLF line endings (and a UTF-8 byte-order mark)."""
    dst.parent.mkdir(parents=True, exist_ok=True)
    for ext in (".csv", ".json"):
        text = src.with_suffix(ext).read_text(encoding="utf-8").replace("\n", "\r\n")
        dst.with_suffix(ext).write_bytes((b"\xef\xbb\xbf" if bom else b"") + text.encode("utf-8"))
    return dst


QUIRKY = {  # name -> (original in raw_data, byte-order mark?)
    "steer_crlf_bom": ("steer_stand/steer_stand_r1.csv", True),
}


@pytest.fixture(scope="module")
def ingested(tmp_path_factory):
    """Run `roboball stage ingest` on every corpus file and on a CRLF/BOM copy of a real campaign
    recording (and its original), two processes at a time."""
    root = tmp_path_factory.mktemp("ingest")
    jobs = {p.stem: (p, root / "out" / p.stem) for p in sorted(CORPUS.glob("*.csv"))}
    for name, (orig, bom) in QUIRKY.items():
        jobs[f"{name}:original"] = (REPO / "raw_data" / orig, root / "out" / f"{name}_original")
        jobs[f"{name}:quirky"] = (_crlf_bom(REPO / "raw_data" / orig, root / "quirky" / Path(orig).name, bom),
                                  root / "out" / f"{name}_quirky")
    with ThreadPoolExecutor(max_workers=max(2, os.cpu_count() or 2)) as pool:
        futures = {k: pool.submit(ingest, src, out) for k, (src, out) in jobs.items()}
        return {k: (jobs[k][0], jobs[k][1], f.result()) for k, f in futures.items()}


def test_corpus_cases_are_all_tested():
    stems = {p.stem for p in CORPUS.glob("*.csv")}
    assert {s for s in stems if not s.startswith("ok_")} == set(INGEST_ERRORS)
    # The list: each kind of bad input has at least one file.
    for stem in ["empty", "header_only", "missing_main_signal", "misspelled_column", "non_numeric_cell", "nan_value",
                 "inf_value", "time_backwards", "all_equal_timestamps", "nanosecond_stamps", "degrees_not_radians",
                 "truncated_last_line", "ok_crlf", "ok_bom", "missing_sidecar", "malformed_sidecar",
                 "negative_pressure", "absurd_pressure", "unknown_kind", "no_release"]:
        assert stem in stems, stem


@pytest.mark.parametrize("stem", sorted(INGEST_ERRORS))
def test_bad_recording_refused_by_ingest(ingested, stem):
    src, out, r = ingested[stem]
    assert r.returncode == 2, r.stderr
    msg = one_error_line(r)
    named = src.with_suffix(".json") if stem in SIDECAR_NAMED else src
    assert msg.startswith(f"{named}: "), msg
    assert INGEST_ERRORS[stem] in msg, msg
    assert "; " in msg, f"no advice on what to do: {msg}"
    assert list(out.iterdir()) == [], "a refused recording must not leave output files"


@pytest.mark.parametrize("stem", sorted(p.stem for p in CORPUS.glob("ok_*.csv")))
def test_accepted_quirks_pass_validation(ingested, stem):
    """The ok_* files are a few samples long: they pass every check of the reader, and ingest
    stops only where it must, at the release finder."""
    src, out, r = ingested[stem]
    kind = json.loads(src.with_suffix(".json").read_text(encoding="utf-8-sig"))["kind"]
    msg = one_error_line(r)
    # "no release found" (stands, shell) or "no start of motion found" (ramp)
    assert msg.startswith(f"{src}: {MAIN_SIGNAL[kind]}: no ") and " found" in msg, msg


@pytest.mark.parametrize("name", sorted(QUIRKY))
def test_crlf_and_bom_recordings_ingest_like_the_original(ingested, name):
    _, out_a, a = ingested[f"{name}:original"]
    _, out_b, b = ingested[f"{name}:quirky"]
    assert a.returncode == 0 and b.returncode == 0, a.stderr + b.stderr
    stem = Path(QUIRKY[name][0]).stem
    for suffix in (".csv", ".json"):   # normalised recording and its sidecar: the same bytes
        assert (out_a / f"{stem}{suffix}").read_bytes() == (out_b / f"{stem}{suffix}").read_bytes()
    ra = json.loads((out_a / f"{stem}.releases.json").read_text())
    rb = json.loads((out_b / f"{stem}.releases.json").read_text())
    assert ra.pop("source") != rb.pop("source")
    assert ra == rb and len(ra["releases"]) >= 1
    assert (out_b / f"{stem}.png").read_bytes()[:4] == b"\x89PNG"


def test_ingest_usage_mistakes_are_one_line(tmp_path):
    r = roboball("stage", "ingest", "--src", CORPUS / "ok_crlf.csv")
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "required: --out-csv" in r.stderr and "Traceback" not in r.stderr
    r = ingest(tmp_path / "nowhere.csv", tmp_path / "out")
    assert r.returncode == 2 and "nowhere.csv: file: not found" in one_error_line(r)


def test_a_batch_is_its_single_calls_in_one_process_and_a_bad_item_runs_none(tmp_path):
    """`roboball stage NAME --each JSON` (the batched rules): the same bytes as one call per item;
    an item the stage cannot take is named in one line before any item runs."""
    srcs = [REPO / "raw_data" / "shell_rock" / "shell_rock_6.9kpa_r1.csv", REPO / "raw_data" / "steer_stand" / "steer_stand_r1.csv"]

    def item(src, out):
        return {"src": str(src), "out_csv": str(out / f"{src.stem}.csv"), "out_releases": str(out / f"{src.stem}.releases.json"),
                "qc_png": str(out / f"{src.stem}.png")}

    (tmp_path / "batch").mkdir()
    r = roboball("stage", "ingest", "--each", json.dumps([item(s, tmp_path / "batch") for s in srcs]))
    assert r.returncode == 0, r.stderr
    for s in srcs:
        assert ingest(s, tmp_path / "one").returncode == 0
        for ext in (".csv", ".releases.json", ".png"):
            assert (tmp_path / "batch" / f"{s.stem}{ext}").read_bytes() == (tmp_path / "one" / f"{s.stem}{ext}").read_bytes()

    (tmp_path / "bad").mkdir()
    bad = [item(srcs[0], tmp_path / "bad"), {"src": str(srcs[1]), "out_csv": str(tmp_path / "bad" / "x.csv")}]
    r = roboball("stage", "ingest", "--each", json.dumps(bad))
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    assert "(item 2)" in r.stderr and "--out-releases" in r.stderr
    assert not list((tmp_path / "bad").iterdir())
    r = roboball("stage", "ingest", "--each", "[{\"src\": [1, [2]]}]")
    assert r.returncode == 2 and "item 1, field 'src'" in one_error_line(r)
