"""`roboball diagnose`: bad input gives the same
one-line errors as the pipeline's ingest (exit code 2, no traceback, no output folder).

`roboball diagnose` loads its whole model library before it reads the file (about 6 s), so this
runs a representative case of each family of checks (file, header, cells, time column, sidecar,
metadata, content) rather than the whole corpus, which tests/cli/test_cli_bad_input.py runs through
`roboball stage ingest`."""
from __future__ import annotations

import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from conftest import CORPUS, INGEST_ERRORS, one_error_line
ROBOBALL = str(Path(sys.executable).parent / "roboball")
CASES = ["empty", "misspelled_column", "nan_value", "time_backwards", "malformed_sidecar", "unknown_kind",
         "no_release"]


def diagnose(*args) -> subprocess.CompletedProcess:
    return subprocess.run([ROBOBALL, "diagnose", *map(str, args)], capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    root = tmp_path_factory.mktemp("diagnose")
    with ThreadPoolExecutor(max_workers=2) as pool:
        futures = {s: pool.submit(diagnose, CORPUS / f"{s}.csv", "--out", root / s, "--no-drake") for s in CASES}
        return {s: (root / s, f.result()) for s, f in futures.items()}


@pytest.mark.parametrize("stem", CASES)
def test_diagnose_refuses_bad_recordings_in_one_line(results, stem):
    out, r = results[stem]
    assert r.returncode == 2, r.stderr
    msg = one_error_line(r)
    assert INGEST_ERRORS[stem] in msg, msg
    assert "; " in msg, f"no advice on what to do: {msg}"
    assert not out.exists(), "a refused recording must not leave an output folder"


def test_diagnose_usage_mistakes(tmp_path):
    r = diagnose(tmp_path / "nowhere.csv", "--out", tmp_path / "out")
    assert r.returncode == 2 and "nowhere.csv: file not found" in one_error_line(r)
    r = diagnose(CORPUS / "ok_crlf.csv", "--out", tmp_path / "out", "--kind", "stear_stand")
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "unknown kind 'stear_stand'" in r.stderr
    assert not (tmp_path / "out").exists()


def test_an_output_path_that_is_a_file_is_refused_before_the_work(tmp_path):
    """--out names a folder: a file there, or a file above it, is refused in one line naming it,
    before the recording is diagnosed, and the file is left as it was."""
    blocker = tmp_path / "taken"
    blocker.write_text("keep me")
    for out, words in ((blocker, "taken: is a file; give a folder"),
                       (blocker / "sub", "taken: is a file, so")):
        r = diagnose(CORPUS / "ok_crlf.csv", "--out", out, "--no-drake")
        assert r.returncode == 2 and words in one_error_line(r), r.stderr
    assert blocker.read_text() == "keep me"
