"""Importers for the authors' native logs, tested on both real logs and on small
synthetic native files."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from conftest import COUPLED, real_file, recording_error
from roboball.ingest.importers import detect_format, import_native, read_any
from roboball.ingest.errors import RecordingError
from roboball.ingest.recording import write_recording

from conftest import REAL_DATA as REAL
STEER = REAL / "steering_static_stand_response.csv"
SHELL = REAL / "dynamic_data.csv"
needs_real = pytest.mark.skipif(not (STEER.exists() and SHELL.exists()), reason=f"real logs not found in {REAL}")


@needs_real
def test_detect_real_formats():
    assert detect_format(STEER) == "steer_log"
    assert detect_format(SHELL) == "shell_log"


@needs_real
def test_import_real_steer_log():
    raw = pd.read_csv(STEER)
    rec = import_native(STEER)
    assert list(rec.data.columns) == ["time_s", "steer_angle_rad"]
    assert len(rec.data) == len(raw) == 4072
    assert rec.kind == "steer_stand" and rec.pressure_kpa is None
    assert rec.meta["time_offset_s"] == pytest.approx(1.079)
    np.testing.assert_allclose(rec.time, raw["steer_timestamp"] - raw["steer_timestamp"][0], atol=1e-12)
    assert rec.time[0] == 0.0 and rec.time[-1] == pytest.approx(52.632, abs=1e-9)
    np.testing.assert_array_equal(rec.signal("steer_angle_rad"), raw["pend_angle"])
    # the log has one duplicated stamp and rests at about -0.03 to -0.04 rad
    assert int(np.sum(np.diff(rec.time) == 0)) == 1
    assert -0.045 < np.median(rec.signal("steer_angle")[-500:]) < -0.025


@needs_real
def test_import_real_shell_log():
    raw = pd.read_csv(SHELL, dtype={"timestamp": "int64"})
    rec = import_native(SHELL)
    assert list(rec.data.columns) == ["time_s", "pipe_angle_rad", "pipe_rate_rad_s"]
    assert rec.kind == "shell_rock"
    assert rec.pressure_kpa is None and rec.meta["pressure_source"] == "unknown"
    assert rec.meta["time_offset_ns"] == int(raw["timestamp"][0])
    expected = (raw["timestamp"].to_numpy() - raw["timestamp"][0]) * 1e-9
    np.testing.assert_allclose(rec.time, expected, rtol=0, atol=1e-12)
    assert rec.time[-1] == pytest.approx(46.599966752, abs=1e-9)
    # about 100 Hz with gaps up to 50 ms
    dt = np.diff(rec.time)
    assert 0.009 < np.median(dt) < 0.011 and dt.max() < 0.05
    np.testing.assert_array_equal(rec.signal("pipe_angle"), raw["ball_roll.position"])
    np.testing.assert_array_equal(rec.signal("pipe_rate"), raw["ball_roll.velocity"])
    # the shell settles at about +0.011 rad
    assert rec.signal("pipe_angle")[-1] == pytest.approx(0.011, abs=0.002)


@needs_real
def test_read_any_and_flags(tmp_path):
    rec = read_any(SHELL, pressure_kpa=13.8)
    assert rec.pressure_kpa == 13.8 and rec.meta["pressure_source"] == "flag"
    with pytest.raises(RecordingError, match="can only be kind shell_rock, not 'steer_stand'"):
        read_any(SHELL, kind="steer_stand")
    with pytest.raises(RecordingError, match="pressure_kpa.*600 kPa is outside"):
        read_any(SHELL, pressure_kpa=600)
    # An imported log written as a recording reads back identically through read_any.
    steer = read_any(STEER)
    out = write_recording(tmp_path / "steer.csv", steer)
    back = read_any(out)
    assert detect_format(out) == "recording"
    np.testing.assert_array_equal(back.data.to_numpy(), steer.data.to_numpy())
    assert back.kind == "steer_stand"


def test_synthetic_native_logs(tmp_path):
    steer = tmp_path / "stand.csv"
    steer.write_text("steer_timestamp,pend_angle\r\n5.5,-0.04\r\n5.512,-0.041\r\n5.512,-0.041\r\n5.53,-0.05\r\n")
    rec = read_any(steer)
    np.testing.assert_allclose(rec.time, [0.0, 0.012, 0.012, 0.03], atol=1e-12)
    assert rec.meta["source_format"] == "steer_log"

    shell = tmp_path / "shell.csv"
    t0 = 1765208426656  # integer nanoseconds
    shell.write_text(
        "timestamp,ball_roll.position,ball_roll.velocity\n"
        f"{t0},-0.4,0.0\n{t0 + 10_000_000},-0.399,0.1\n{t0 + 20_500_000},-0.397,0.2\n"
    )
    (tmp_path / "shell.json").write_text('{"pressure_kpa": 10.3}')  # a sidecar next to a native log is used
    rec = read_any(shell)
    np.testing.assert_allclose(rec.time, [0.0, 0.010, 0.0205], rtol=0, atol=1e-15)
    assert rec.pressure_kpa == 10.3 and rec.meta["pressure_source"] == "sidecar"
    assert rec.main_signal() == "pipe_angle_rad"


@pytest.mark.parametrize(
    "text, match",
    [
        ("steer_timestamp,pend_angle\n0.0,-0.04\n0.01,oops\n", "line 3, column pend_angle: 'oops' is not a number"),
        ("steer_timestamp,pend_angle\n0.0,-0.04\n0.01,45.0\n", "line 3, column steer_angle_rad: .*looks like degrees"),
        ("steer_timestamp,pend_angle\n0.02,-0.04\n0.01,-0.04\n", "line 3, column time_s: time goes backwards"),
        ("timestamp,ball_roll.position,ball_roll.velocity\n0.0,-0.4,0\n0.01,-0.4,0\n0.02,-0.4,0\n", "line 3, column timestamp: 0.01 is not an integer number of nanoseconds"),
        ("timestamp,ball_roll.position,ball_roll.velocity\n0,-0.4,0\n10,-0.4,0\n20,-0.4,0\n", "too small for nanoseconds"),
        ("timestamp,ball_roll.position,ball_roll.velocity\n0,-0.4,0\n10000000,-0.4\n", "truncated last line"),
        ("stamp,angle\n0,1\n", "not a recording .* nor a known native log"),
    ],
)
def test_native_errors_are_one_line(tmp_path, text, match):
    path = tmp_path / "native.csv"
    path.write_text(text)
    with pytest.raises(RecordingError, match=match) as info:
        read_any(path)
    assert "\n" not in str(info.value) and str(info.value).startswith(str(path))


def test_import_native_refuses_recording(tmp_path):
    path = tmp_path / "rec.csv"
    path.write_text("time_s,steer_angle_rad\n0,0.1\n0.01,0.1\n")
    with pytest.raises(RecordingError, match="already a recording"):
        import_native(path)
    rec = read_any(path, kind="steer_stand")
    assert rec.kind == "steer_stand"


# --------------------------------------------------------------------------------------
# small synthetic native logs: exact values and exact one-line messages
# --------------------------------------------------------------------------------------
SHELL_HEADER = "timestamp,ball_roll.position,ball_roll.velocity\n"


def _native(tmp_path: Path, text: str, name: str = "native.csv") -> Path:
    path = tmp_path / name
    path.write_bytes(text.encode("utf-8"))
    return path


def _message(path: Path, read=read_any, **flags) -> str:
    return recording_error(read, path, **flags)


def test_epoch_nanoseconds_are_converted_exactly(tmp_path):
    # ns since the epoch exceed 2**53: float64 would round the steps to multiples of 256 ns
    t0 = 1_765_208_426_656_000_000
    path = _native(tmp_path, SHELL_HEADER + f"{t0},-0.4,0.0\n{t0 + 10_000_001},-0.399,0.1\n{t0 + 20_000_003},-0.397,0.2\n")
    rec = read_any(path)
    assert rec.meta["time_offset_ns"] == t0
    np.testing.assert_allclose(rec.time, [0.0, 0.010000001, 0.020000003], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(rec.signal("pipe_angle_rad"), [-0.4, -0.399, -0.397])
    np.testing.assert_array_equal(rec.signal("pipe_rate_rad_s"), [0.0, 0.1, 0.2])
    # no sidecar, no flag: the pressure is explicitly unknown
    assert rec.pressure_kpa is None and rec.meta["pressure_source"] == "unknown"
    assert rec.meta["source_format"] == "shell_log" and rec.meta["source_file"] == "native.csv"


def test_shell_log_columns_found_by_name_in_any_order(tmp_path):
    path = _native(tmp_path, "ball_roll.velocity,timestamp,ball_roll.position\n0.5,0,0.1\n0.6,10000000,0.2\n")
    assert detect_format(path) == "shell_log"
    rec = read_any(path)
    assert list(rec.data.columns) == ["time_s", "pipe_angle_rad", "pipe_rate_rad_s"]
    np.testing.assert_allclose(rec.time, [0.0, 0.01], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(rec.signal("pipe_angle_rad"), [0.1, 0.2])
    np.testing.assert_array_equal(rec.signal("pipe_rate_rad_s"), [0.5, 0.6])


def test_steer_log_in_nanoseconds_is_named_by_its_native_column(tmp_path):
    # nanoseconds since boot (5.5 s): far above 1e9 "seconds"
    path = _native(tmp_path, "steer_timestamp,pend_angle\n5500000000,-0.04\n5512000000,-0.041\n5530000000,-0.05\n")
    assert _message(path) == (f"{path}: column steer_timestamp: values up to 5.53e+09 are not seconds; "
                              "the steer log's timestamps must be in seconds")


def test_native_errors_name_file_lines_across_blank_lines(tmp_path):
    frac = _native(tmp_path, SHELL_HEADER + "0,-0.4,0\n\n10000000.5,-0.4,0\n", "frac.csv")
    assert _message(frac) == (f"{frac}: line 4, column timestamp: 10000000.5 is not an integer number of nanoseconds; "
                              "the shell log's timestamp column must be integer nanoseconds")
    back = _native(tmp_path, "steer_timestamp,pend_angle\n0,0.1\n\n0.02,0.1\n0.01,0.1\n", "back.csv")
    assert _message(back) == (f"{back}: line 5, column time_s: time goes backwards (0.01 s after 0.02 s on line 4); "
                              "sort the rows by time or remove the out-of-order sample")


def test_kind_flag_must_match_the_native_log(tmp_path):
    shell = _native(tmp_path, SHELL_HEADER + "0,-0.4,0\n10000000,-0.4,0\n", "shell.csv")
    assert _message(shell, kind="ramp") == (f"{shell}: field kind: a shell log can only be kind shell_rock, not 'ramp'; "
                               "drop --kind or use the matching log")
    steer = _native(tmp_path, "steer_timestamp,pend_angle\n0,-0.04\n0.01,-0.04\n", "steer.csv")
    assert _message(steer, import_native, kind="shell_rock") == (f"{steer}: field kind: a steer log can only be kind steer_stand, not 'shell_rock'; "
                               "drop --kind or use the matching log")
    assert read_any(steer, kind="steer_stand").kind == "steer_stand"


def test_epoch_nanoseconds_under_a_spaced_header_blank_lines_and_crlf(tmp_path):
    """Epoch nanoseconds are re-read from the very rows parsed (not by a second CSV reader that
    knows nothing of the first one's header stripping, blank lines or line endings)."""
    t0 = 1_765_208_426_656_000_000
    text = (" timestamp , ball_roll.position,ball_roll.velocity\r\n"
            f"{t0},-0.4,0.0\r\n\r\n{t0 + 10_000_001},-0.399,0.1\r\n{t0 + 20_000_003},-0.397,0.2\r\n")
    rec = read_any(_native(tmp_path, text))
    assert rec.meta["time_offset_ns"] == t0
    np.testing.assert_allclose(rec.time, [0.0, 0.010000001, 0.020000003], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(rec.signal("pipe_angle_rad"), [-0.4, -0.399, -0.397])


def test_epoch_nanoseconds_written_as_floats_are_a_one_line_error(tmp_path):
    """1.765e18 has lost the nanoseconds a float cannot hold: refused, naming line and column."""
    path = _native(tmp_path, SHELL_HEADER + "1765208426656000000,-0.4,0.0\n1.76520842667e18,-0.399,0.1\n"
                   "1765208426676000000,-0.397,0.2\n")
    msg = _message(path)
    assert "line 3, column timestamp" in msg and "'1.76520842667e18' is not an integer number of nanoseconds" in msg
    assert "\n" not in msg


# --------------------------------------------------------------------------------------
# the coupled steer-direction test and the steer-stand trial (recordings.md, native formats)
# --------------------------------------------------------------------------------------
COUPLED_HEADER = "timestamp,ball_roll.position,roll_joint.position\n"
TRIAL_HEADER = "timestamp,roll_joint.position,roll_joint.velocity\n"


@pytest.mark.parametrize("name", COUPLED)
def test_import_real_coupled_logs(name):
    path = real_file(name)
    raw = pd.read_csv(path, dtype={"timestamp": "int64"})
    assert detect_format(path) == "coupled_log"
    rec = read_any(path)
    assert list(rec.data.columns) == ["time_s", "pipe_angle_rad", "steer_angle_rad"]
    assert rec.kind == "steer_coupled" and rec.main_signal() == "pipe_angle_rad"
    assert rec.pressure_kpa is None and rec.meta["pressure_source"] == "unknown"
    assert rec.meta["source_format"] == "coupled_log" and rec.meta["time_offset_ns"] == int(raw["timestamp"][0])
    np.testing.assert_allclose(rec.time, (raw["timestamp"].to_numpy() - raw["timestamp"][0]) * 1e-9, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(rec.signal("pipe_angle_rad"), raw["ball_roll.position"])
    np.testing.assert_array_equal(rec.signal("steer_angle_rad"), raw["roll_joint.position"])
    # README: 3.3-5.3 s at about 50 Hz; tilted to about -0.36 rad with the pendulum at about +0.39 rad
    assert 3.2 < rec.time[-1] < 5.4 and 0.015 < np.median(np.diff(rec.time)) < 0.025
    assert rec.signal("pipe_angle_rad")[0] == pytest.approx(-0.36, abs=0.03)
    assert rec.signal("steer_angle_rad")[0] == pytest.approx(0.38, abs=0.03)


def test_synthetic_coupled_log(tmp_path):
    path = _native(tmp_path, COUPLED_HEADER + "13307865436928,-0.378,0.396\n13307884630496,-0.372,0.395\n"
                   "13307903000000,-0.369,0.394\n")
    assert detect_format(path) == "coupled_log"
    rec = read_any(path)
    np.testing.assert_allclose(rec.time, [0.0, 0.019193568, 0.037563072], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(rec.signal("pipe_angle_rad"), [-0.378, -0.372, -0.369])
    np.testing.assert_array_equal(rec.signal("steer_angle_rad"), [0.396, 0.395, 0.394])
    # its pipe angle alone is a shell rocking record, by flag; no other kind
    shell = read_any(path, kind="shell_rock", pressure_kpa=13.8)
    assert shell.kind == "shell_rock" and shell.pressure_kpa == 13.8 and shell.meta["pressure_source"] == "flag"
    assert _message(path, kind="steer_stand") == (
        f"{path}: field kind: a coupled steer log can only be kind steer_coupled or shell_rock, not 'steer_stand'; "
        "drop --kind or use the matching log")


def test_synthetic_steer_trial_log(tmp_path):
    path = _native(tmp_path, TRIAL_HEADER + "5500000000,0.9,0.0\n5512500000,0.899,-0.1\n5525000000,0.897,-0.2\n")
    assert detect_format(path) == "steer_trial_log"
    rec = read_any(path)
    assert list(rec.data.columns) == ["time_s", "steer_angle_rad", "steer_rate_rad_s"]
    assert rec.kind == "steer_stand" and rec.pressure_kpa is None and "pressure_source" not in rec.meta
    assert rec.meta["source_format"] == "steer_trial_log" and rec.meta["time_offset_ns"] == 5_500_000_000
    np.testing.assert_allclose(rec.time, [0.0, 0.0125, 0.025], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(rec.signal("steer_angle_rad"), [0.9, 0.899, 0.897])
    np.testing.assert_array_equal(rec.signal("steer_rate_rad_s"), [0.0, -0.1, -0.2])
    assert _message(path, kind="shell_rock") == (
        f"{path}: field kind: a steer-stand trial log can only be kind steer_stand, not 'shell_rock'; "
        "drop --kind or use the matching log")


@pytest.mark.parametrize("header, what", [(COUPLED_HEADER, "coupled steer log"), (TRIAL_HEADER, "steer-stand trial log")])
def test_nanosecond_errors_name_the_log(tmp_path, header, what):
    frac = _native(tmp_path, header + "0,0.4,0\n10000000.5,0.4,0\n", "frac.csv")
    assert _message(frac) == (f"{frac}: line 3, column timestamp: 10000000.5 is not an integer number of nanoseconds; "
                              f"the {what}'s timestamp column must be integer nanoseconds")
    fine = _native(tmp_path, header + "0,0.4,0\n10,0.4,0\n20,0.4,0\n", "fine.csv")
    assert "far too small for nanoseconds" in _message(fine)


def test_a_header_with_every_shell_column_stays_a_shell_log(tmp_path):
    """Detection keeps its order: a log holding the shell log's columns is a shell log, whatever
    else it holds (as before the coupled format was known)."""
    path = _native(tmp_path, "timestamp,ball_roll.position,roll_joint.position,ball_roll.velocity\n"
                   "0,-0.4,0.3,0\n10000000,-0.39,0.3,0.1\n")
    assert detect_format(path) == "shell_log"
    assert list(read_any(path).data.columns) == ["time_s", "pipe_angle_rad", "pipe_rate_rad_s"]


def test_unknown_header_lists_every_native_format(tmp_path):
    msg = _message(_native(tmp_path, "stamp,angle\n0,1\n"))
    assert "timestamp,ball_roll.position,roll_joint.position" in msg
    assert "timestamp,roll_joint.position,roll_joint.velocity" in msg and "\n" not in msg


def test_steer_coupled_recordings_are_read_and_written(tmp_path):
    """steer_coupled is a kind of the recording format: pipe angle and steer angle, pressure null
    where unknown; both signals must be there."""
    data = pd.DataFrame({"time_s": [0.0, 0.02, 0.04], "pipe_angle_rad": [-0.36, -0.35, -0.34],
                         "steer_angle_rad": [0.39, 0.39, 0.38]})
    out = write_recording(tmp_path / "coupled.csv", data, {"kind": "steer_coupled", "pressure_kpa": None})
    back = read_any(out)
    assert back.kind == "steer_coupled" and back.pressure_kpa is None
    np.testing.assert_array_equal(back.data.to_numpy(), data.to_numpy())
    assert json.loads((tmp_path / "coupled.json").read_text())["pressure_kpa"] is None
    lone = tmp_path / "lone.csv"
    lone.write_text("time_s,pipe_angle_rad\n0,-0.36\n0.02,-0.35\n")
    assert _message(lone, kind="steer_coupled") == (
        f"{lone}: line 1 (header): missing column steer_angle_rad needed for kind steer_coupled "
        "(columns: time_s, pipe_angle_rad); add the column or check the kind")
