"""Shared by every test folder (tests are grouped by the package they test: ingest/, identify/,
physics/, reduced/, sim/, diagnose/, pipeline/, figures/, report/, cli/, testbed/, config/,
metrics/).  Test modules import the constants and helpers below with `from conftest import ...`."""
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("MPLBACKEND", "Agg")

REPO = Path(__file__).resolve().parents[1]
# The real logs sit in ../shared beside the repository (in CI as here), never inside it;
# ROBOBALL_REAL_DATA points the tests elsewhere.
REAL_DATA = Path(os.environ.get("ROBOBALL_REAL_DATA", REPO.parent / "shared" / "data" / "roboball_real"))

# The bad-recording corpus (tests/bad_recordings/README.md) and what each file must be refused with.
CORPUS = REPO / "tests" / "bad_recordings"
# file stem -> substring the one-line error must contain
BAD = {
    "empty": "empty file",
    "whitespace_only": "empty file",
    "header_only": "header only, no data rows",
    "first_column_not_time": "first column is 't', expected 'time_s'",
    "native_steer_log": "native steer-stand log",
    "misspelled_column": "did you mean 'steer_angle_rad'",
    "unknown_column": "unknown signal column 'temperature_c'",
    "degree_column_name": "is in degrees",
    "no_signal_column": "no signal column",
    "missing_main_signal": "missing column pipe_angle_rad needed for kind shell_rock",
    "duplicate_column": "appears twice",
    "non_numeric_cell": "line 4, column steer_angle_rad: 'abc' is not a number",
    "empty_cell": "line 3, column steer_angle_rad: empty cell",
    "nan_value": "line 3, column steer_angle_rad: non-finite value 'nan'",
    "inf_value": "line 4, column steer_angle_rad: non-finite value 'inf'",
    "time_backwards": "line 5, column time_s: time goes backwards",
    "all_equal_timestamps": "all 5 timestamps are equal",
    "nanosecond_stamps": "look like nanoseconds",
    "nanosecond_steps": "look like nanoseconds",
    "degrees_not_radians": "line 4, column steer_angle_rad: |value| 45 exceeds 2*pi: looks like degrees",
    "truncated_last_line": "line 4: truncated last line (2 of 3 fields)",
    "truncated_last_value": "line 4: truncated last line",
    "short_row_in_middle": "line 3: has 1 field but the header has 2",
    "long_row": "line 3: has 3 fields but the header has 2",
    "missing_sidecar": "sidecar missing_sidecar.json: missing",
    "malformed_sidecar": "malformed JSON",
    "sidecar_not_object": "must hold a JSON object",
    "sidecar_without_kind": "field kind: missing",
    "unknown_kind": "unknown kind 'steer'; did you mean 'steer_stand'",
    "negative_pressure": "-13.8 kPa is outside (0, 500] kPa",
    "zero_pressure": "0 kPa is outside (0, 500] kPa",
    "absurd_pressure": "13800 kPa is outside (0, 500] kPa",
    "pressure_not_number": "'2 psi' is not a number",
    "shell_without_pressure": "kind shell_rock needs the shell gauge pressure",
    "ramp_null_pressure": "kind ramp needs the shell gauge pressure",
    "ramp_angle_out_of_range": "120 deg is outside (0, 90) deg",
    "not_utf8": "line 3: not UTF-8 text",
}
# Errors that are about the sidecar name the sidecar file, all others the CSV.
SIDECAR_NAMED = {"malformed_sidecar", "sidecar_not_object"}
# Well-formed recordings that the pipeline's ingest must still refuse (tests/cli/test_cli_bad_input.py).
READER_VALID = {"no_release"}

# What `roboball stage ingest` says where it differs from read_recording (tests/ingest/test_recording.py):
# ingest also reads the authors' native formats, and refuses a recording without a release.
INGEST_ERRORS = {
    **BAD,
    "first_column_not_time": "not a recording (first column time_s) nor a known native log",
    "native_steer_log": "steer_angle_rad: no release found",
    "no_release": "steer_angle_rad: no release found",
}


def one_error_line(r: subprocess.CompletedProcess) -> str:
    """The single line a user error must produce on stderr (Drake/Python warnings aside)."""
    assert "Traceback" not in r.stderr, r.stderr
    lines = [l for l in r.stderr.splitlines() if l.strip() and "Warning" not in l and "WARNING" not in l]
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("roboball: error: "), lines[0]
    return lines[0][len("roboball: error: "):]
COUPLED = ("steer_coupled_20250429_165825.csv", "steer_coupled_20250429_165853.csv",
           "steer_coupled_20250429_165914.csv")


def closed_loop_recording(folder, case: int, draw: int = 0, from_rest=None, free_s: float = 2.0, name: str = "first",
                          stream: int = 1, first_release=(0.05, 0.1), noise: float | None = None) -> tuple[dict, Path]:
    """(case, CSV path): a recording of `roboball design`'s steer-setting closed loop (seed 47),
    made by the test bed as benchmarks/design_closed_loop.py makes it: case `case`'s draw `draw`
    with the benchmark's `--first-release` (None: its default) and `--noise`, released at
    `from_rest` (rad from rest; None: the case's own first release), each left `free_s`."""
    import sys

    sys.path.insert(0, str(REPO / "benchmarks"))
    import design_closed_loop as loop

    saved = dict(loop.FIRST_RELEASE), dict(loop.NOISE)
    if first_release is not None:
        loop.FIRST_RELEASE["steer_setting"] = tuple(first_release)
    if noise is not None:
        loop.NOISE["steer_setting"] = noise
    try:
        c = loop.draw_case("steer_setting", case, 47, draw)
        path = loop.record(c, [c["release"]] if from_rest is None else from_rest, free_s, Path(folder), name, stream)
    finally:
        for table, old in zip((loop.FIRST_RELEASE, loop.NOISE), saved):
            table.clear()
            table.update(old)
    return c, path


def real_file(name: str) -> Path:
    """Path of one real log in REAL_DATA; skips the test (saying where it looked) if it is missing."""
    path = REAL_DATA / name
    if not path.exists():
        pytest.skip(f"real log {name} not found in {REAL_DATA}")
    return path


def recording_error(read, path, **flags) -> str:
    """The one-line RecordingError message `read(path, **flags)` raises (fails if it raises none)."""
    from roboball.ingest.errors import RecordingError
    with pytest.raises(RecordingError) as info:
        read(path, **flags)
    return str(info.value)


def fit_damped(t, y):
    """Independent damped-sinusoid fit used to check Drake runs (not the project's extractor)."""
    from scipy.optimize import curve_fit

    t = np.asarray(t, float)
    y = np.asarray(y, float)
    rest0 = np.mean(y[len(y) // 2:])
    yc = y - rest0
    zc = np.where(np.diff(np.sign(yc)) != 0)[0]
    w0 = np.pi / np.mean(np.diff(t[zc])) if len(zc) > 2 else 2.0

    def f(t, A, z, w, ph, c):
        return c + A * np.exp(-z * w * t) * np.cos(w * np.sqrt(1 - z * z) * t + ph)

    p, _ = curve_fit(f, t, y, p0=[y[0] - rest0, 0.01, w0, 0.0, rest0], maxfev=20000)
    return {"amplitude": p[0], "zeta": p[1], "omega_n": p[2], "rest": p[4],
            "rmse": float(np.sqrt(np.mean((f(t, *p) - y) ** 2)))}


@pytest.fixture(scope="session")
def robot():
    from roboball.config import load_robot

    return load_robot()
