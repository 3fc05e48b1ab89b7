"""Recording format: atomic deterministic writers, the strict reader and its one-line
errors (bad-recording corpus), normalisation, and write/read round trips."""
from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import recording_error
from roboball.atomic import atomic_write, csv_text, json_dumps_stable, write_csv_atomic, write_json_atomic
from roboball.errors import RoboballError
from roboball.ingest.errors import RecordingError
from roboball.ingest.recording import normalise, read_recording, write_recording
from roboball.ingest.sidecar import sidecar_path
from roboball.kinds import KNOWN_SIGNALS

from conftest import BAD, CORPUS, READER_VALID, SIDECAR_NAMED



def test_corpus_is_complete():
    """Every file in the corpus is covered by a test case (bad or ok), and vice versa."""
    stems = {p.stem for p in CORPUS.glob("*.csv")}
    ok = {s for s in stems if s.startswith("ok_")}
    assert stems - ok - READER_VALID == set(BAD)
    assert len(ok) >= 6
    for stem in READER_VALID:
        assert len(read_recording(CORPUS / f"{stem}.csv").data) > 100


@pytest.mark.parametrize("stem", sorted(BAD))
def test_bad_recording_one_line_error(stem):
    path = CORPUS / f"{stem}.csv"
    with pytest.raises(RecordingError) as info:
        read_recording(path)
    msg = str(info.value)
    assert "\n" not in msg and "\r" not in msg
    named = sidecar_path(path) if stem in SIDECAR_NAMED else path
    assert msg.startswith(f"{named}: "), msg
    assert BAD[stem] in msg, msg
    assert isinstance(info.value, RoboballError)


def test_missing_file(tmp_path):
    with pytest.raises(RecordingError, match=r"nope\.csv: file: not found"):
        read_recording(tmp_path / "nope.csv")


@pytest.mark.parametrize("stem", ["ok_crlf", "ok_bom"])
def test_crlf_and_bom_accepted(stem):
    rec = read_recording(CORPUS / f"{stem}.csv")
    assert list(rec.data.columns) == ["time_s", "steer_angle_rad"]
    np.testing.assert_array_equal(rec.time, [0.0, 0.01, 0.02, 0.03])
    np.testing.assert_array_equal(rec.signal("steer_angle"), [-0.035, -0.0348, -0.0346, -0.0343])
    assert rec.kind == "steer_stand" and rec.pressure_kpa is None
    assert rec.main_signal() == "steer_angle_rad"


def test_bom_crlf_sidecar_and_shell():
    rec = read_recording(CORPUS / "ok_bom_crlf.csv")
    assert rec.kind == "shell_rock" and rec.pressure_kpa == 13.8
    assert rec.main_signal() == "pipe_angle_rad"
    np.testing.assert_array_equal(rec.signal("pipe_rate_rad_s"), [0.0, 0.5, 1.0])


def test_duplicate_stamps_accepted_and_normalised():
    rec = read_recording(CORPUS / "ok_duplicate_stamps.csv")
    assert len(rec.data) == 8
    norm = normalise(rec)
    np.testing.assert_array_equal(norm.time, [0.0, 0.012, 0.025, 0.037, 0.090, 0.102])
    assert norm.meta["n_duplicates_dropped"] == 2
    # median step 0.012-0.013 s; the 0.053 s step is a gap (> 3x median), nothing else is
    assert norm.meta["gaps"] == [(0.037, 0.090)]
    assert np.all(np.diff(norm.time) > 0)
    assert rec.data.shape == (8, 2), "normalise must not modify its input"


def test_blank_lines_and_missing_final_newline():
    a = read_recording(CORPUS / "ok_blank_lines.csv")
    b = read_recording(CORPUS / "ok_no_trailing_newline.csv")
    np.testing.assert_array_equal(a.data.to_numpy(), b.data.to_numpy())


def test_ramp_default_angle_and_extra_keys():
    from roboball.config import load_robot

    rec = read_recording(CORPUS / "ok_ramp_default_angle.csv")
    assert rec.kind == "ramp" and rec.main_signal() == "drive_rate_rad_s"
    assert rec.ramp_angle_deg == 16.0 and rec.meta["ramp_angle_deg_source"] == "default"
    # the reader's default is the robot facts' ramp (kept as a literal so that reading a
    # recording does not depend on configs/robot.yaml undeclared)
    assert rec.ramp_angle_deg == load_robot().ramp_angle_deg
    assert rec.ramp_exit_s == 0.15
    assert rec.meta["operator"] == "jd"  # unknown keys are preserved
    # the drive joint is continuous: 12.7 rad of drive angle on a ramp is not "degrees"
    assert rec.signal("drive_angle_rad")[-1] == 12.7
    # a flag overrides the default and says so
    rec2 = read_recording(CORPUS / "ok_ramp_default_angle.csv", ramp_angle_deg=12.0)
    assert rec2.ramp_angle_deg == 12.0 and rec2.meta["ramp_angle_deg_source"] == "flag"


def test_flags_supply_and_override_sidecar():
    rec = read_recording(CORPUS / "missing_sidecar.csv", kind="steer_stand")
    assert rec.kind == "steer_stand" and rec.pressure_kpa is None
    rec = read_recording(CORPUS / "shell_without_pressure.csv", pressure_kpa=17.2)
    assert rec.pressure_kpa == 17.2
    rec = read_recording(CORPUS / "ok_bom_crlf.csv", pressure_kpa=6.9)
    assert rec.pressure_kpa == 6.9
    with pytest.raises(RecordingError, match=r"field pressure_kpa \(flag --pressure-kpa\): 900 kPa"):
        read_recording(CORPUS / "ok_bom_crlf.csv", pressure_kpa=900)
    with pytest.raises(RecordingError, match="unknown kind 'rmp'; did you mean 'ramp'"):
        read_recording(CORPUS / "ok_crlf.csv", kind="rmp")


def test_signal_lookup_errors():
    rec = read_recording(CORPUS / "ok_crlf.csv")
    with pytest.raises(RecordingError, match="column pipe_angle: not in this recording"):
        rec.signal("pipe_angle")


# --------------------------------------------------------------------------------------
# atomic writers
# --------------------------------------------------------------------------------------
def test_atomic_write_replaces_only_on_success(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("old\n")
    with pytest.raises(RuntimeError):
        with atomic_write(target) as fh:
            fh.write("half")
            raise RuntimeError("crash")
    assert target.read_text() == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.txt"], "temp file left behind"
    with atomic_write(target) as fh:
        fh.write("new\n")
    assert target.read_text() == "new\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.txt"]
    mask = os.umask(0)
    os.umask(mask)
    assert (target.stat().st_mode & 0o777) == (0o666 & ~mask)


def test_json_stable_and_nan_refused(tmp_path):
    obj = {"b": 0.1, "a": [1, 2.5e-12, np.float64(3.0)], "c": {"z": None, "y": True}}
    text = json_dumps_stable(obj)
    assert text.endswith("\n") and text.index('"a"') < text.index('"b"') < text.index('"c"')
    assert json.loads(text) == {"a": [1, 2.5e-12, 3.0], "b": 0.1, "c": {"y": True, "z": None}}
    write_json_atomic(tmp_path / "x.json", obj)
    assert (tmp_path / "x.json").read_text() == text
    with pytest.raises(ValueError):
        write_json_atomic(tmp_path / "bad.json", {"x": float("nan")})
    assert not (tmp_path / "bad.json").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.json"]


def test_csv_deterministic_and_exact(tmp_path):
    rng = np.random.default_rng(3)
    df = pd.DataFrame({"time_s": np.cumsum(rng.uniform(0.01, 0.0125, 50)),
                       "steer_angle_rad": rng.normal(0, 0.3, 50)})
    write_csv_atomic(df, tmp_path / "a.csv")
    write_csv_atomic(df.copy(), tmp_path / "b.csv")
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()
    back = np.loadtxt(tmp_path / "a.csv", delimiter=",", skiprows=1)
    np.testing.assert_array_equal(back, df.to_numpy())  # the repr format is exact
    text = csv_text(df, float_format="%.9g")
    assert text.splitlines()[1] == "%.9g,%.9g" % (df.iloc[0, 0], df.iloc[0, 1])
    assert b"\r" not in (tmp_path / "a.csv").read_bytes()


# --------------------------------------------------------------------------------------
# write_recording
# --------------------------------------------------------------------------------------
def test_write_recording_round_trip_and_bytes(tmp_path):
    t = np.arange(0, 2, 0.0113)
    df = pd.DataFrame({"time_s": t, "pipe_angle_rad": 0.3 * np.cos(3 * t), "pipe_rate_rad_s": -0.9 * np.sin(3 * t)})
    meta = {"kind": "shell_rock", "pressure_kpa": 13.8, "note": "synthetic"}
    out = write_recording(tmp_path / "run.csv", df, meta)
    assert out == tmp_path / "run.csv" and (tmp_path / "run.json").exists()
    rec = read_recording(out)
    np.testing.assert_array_equal(rec.data.to_numpy(), df.to_numpy())
    assert rec.meta == meta
    first = (out.read_bytes(), (tmp_path / "run.json").read_bytes())
    write_recording(out, rec)  # a Recording can be written back as is
    assert (out.read_bytes(), (tmp_path / "run.json").read_bytes()) == first


@pytest.mark.parametrize(
    "columns, meta, match",
    [
        ({"time_s": [0.0, 0.01], "steer_angle_rad": [0.1, float("nan")]}, {"kind": "steer_stand"}, "non-finite"),
        ({"time_s": [0.0, 0.01], "steer_angle_rad": [0.1, 90.0]}, {"kind": "steer_stand"}, "looks like degrees"),
        ({"time_s": [0.0, 0.01], "steer_angle_rad": [0.1, 0.2]}, {"kind": "shell_rock", "pressure_kpa": 10}, "missing column pipe_angle_rad"),
        ({"time_s": [0.01, 0.0], "pipe_angle_rad": [0.1, 0.2]}, {"kind": "shell_rock", "pressure_kpa": 10}, "time goes backwards"),
        ({"time_s": [0.0, 0.01], "pipe_angle_rad": [0.1, 0.2]}, {"kind": "shell_rock"}, "needs the shell gauge pressure"),
        ({"t": [0.0, 0.01], "pipe_angle_rad": [0.1, 0.2]}, {"kind": "shell_rock", "pressure_kpa": 10}, "expected 'time_s'"),
    ],
)
def test_write_recording_refuses_bad_input_and_writes_nothing(tmp_path, columns, meta, match):
    with pytest.raises(RecordingError, match=match):
        write_recording(tmp_path / "bad.csv", pd.DataFrame(columns), meta)
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------------------
# property-based: random valid recordings round-trip; random junk never crashes the reader
# --------------------------------------------------------------------------------------
finite = st.floats(min_value=-6.0, max_value=6.0, allow_nan=False, allow_infinity=False)


@st.composite
def valid_recordings(draw):
    n = draw(st.integers(min_value=2, max_value=60))
    steps = draw(st.lists(st.one_of(st.just(0.0), st.floats(1e-4, 0.05)), min_size=n - 1, max_size=n - 1))
    if all(s == 0.0 for s in steps):
        steps[0] = 0.01
    t0 = draw(st.floats(-100.0, 1000.0, allow_nan=False))
    t = t0 + np.concatenate([[0.0], np.cumsum(steps)])
    kind = draw(st.sampled_from(["steer_stand", "drive_stand", "shell_rock", "ramp"]))
    main = {"steer_stand": "steer_angle_rad", "drive_stand": "drive_angle_rad",
            "shell_rock": "pipe_angle_rad", "ramp": "drive_rate_rad_s"}[kind]
    others = draw(st.lists(st.sampled_from([s for s in KNOWN_SIGNALS if s != main]), unique=True, max_size=3))
    cols = {"time_s": t}
    for name in [main] + others:
        cols[name] = np.array(draw(st.lists(finite, min_size=n, max_size=n)))
    meta = {"kind": kind}
    if kind in ("shell_rock", "ramp") or draw(st.booleans()):
        meta["pressure_kpa"] = draw(st.floats(0.5, 499.0))
    else:
        meta["pressure_kpa"] = None
    if kind == "ramp" and draw(st.booleans()):
        meta["ramp_angle_deg"] = draw(st.floats(1.0, 45.0))
    return pd.DataFrame(cols), meta


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(rec=valid_recordings(), fmt=st.sampled_from(["repr", "%.9g"]))
def test_property_round_trip(tmp_path, rec, fmt):
    df, meta = rec
    path = tmp_path / "prop.csv"
    write_recording(path, df, meta, float_format=fmt)
    back = read_recording(path)
    assert list(back.data.columns) == list(df.columns)
    if fmt == "repr":
        np.testing.assert_array_equal(back.data.to_numpy(), df.to_numpy())
    else:
        np.testing.assert_allclose(back.data.to_numpy(), df.to_numpy(), rtol=1e-8, atol=1e-300)
    assert back.kind == meta["kind"]
    norm = normalise(back)
    assert np.all(np.diff(norm.time) > 0)
    assert len(norm.time) == len(np.unique(df["time_s"].to_numpy()))


junk_cell = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.text(alphabet="0123456789.-+eEnaif x,\"", max_size=8),
    st.just(""),
)


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    header=st.lists(st.sampled_from(["time_s", "steer_angle_rad", "pipe_angle_rad", "time", "steer_angle_deg", "x"]),
                    min_size=1, max_size=4),
    rows=st.lists(st.lists(junk_cell, min_size=0, max_size=5), max_size=12),
    newline=st.sampled_from(["\n", "\r\n", "\r"]),
    bom=st.booleans(),
)
def test_property_reader_never_crashes(tmp_path, header, rows, newline, bom):
    text = ("\ufeff" if bom else "") + newline.join([",".join(header)] + [",".join(r) for r in rows])
    path = tmp_path / "junk.csv"
    path.write_text(text, encoding="utf-8", newline="")
    (tmp_path / "junk.json").write_text('{"kind": "steer_stand", "pressure_kpa": null}')
    try:
        rec = read_recording(path)
    except RecordingError as exc:
        assert "\n" not in str(exc) and str(exc).startswith(str(path))
        return
    # Whatever was accepted is a proper recording.
    assert rec.data.columns[0] == "time_s"
    assert np.all(np.isfinite(rec.data.to_numpy()))
    assert np.all(np.diff(rec.time) >= 0) and np.ptp(rec.time) > 0
    assert np.all(np.abs(rec.signal("steer_angle_rad")) <= 2 * math.pi)


# --------------------------------------------------------------------------------------
# exact one-line messages, boundaries and normalise details (small synthetic files)
# --------------------------------------------------------------------------------------
STAND = '{"kind": "steer_stand", "pressure_kpa": null}'


def _csv(tmp_path: Path, name: str, text: str, sidecar: str | None = STAND) -> Path:
    path = tmp_path / name
    path.write_bytes(text.encode("utf-8"))
    if sidecar is not None:
        sidecar_path(path).write_text(sidecar)
    return path


def _message(path: Path, **flags) -> str:
    return recording_error(read_recording, path, **flags)


@pytest.mark.parametrize("text, message", [
    pytest.param("time_s,steer_angle_rad\r\n0,0.1\r\n0.01,x\r\n0.02,0.1\r\n",
                 "line 3, column steer_angle_rad: 'x' is not a number; fix the cell or delete the row",
                 id="crlf_line_numbers_count_each_line_once"),
    pytest.param("time_s,steer_angle_rad,pipe_angle_rad,steer_angle_rad\n0,0.1,0,0\n0.01,0.1,0,0\n",
                 "line 1 (header): column steer_angle_rad appears twice (columns 2 and 4); keep one of them",
                 id="duplicate_column_names_both_column_numbers"),
    pytest.param("time_s,pipe_angle_rad,steer_angle_deg\n0,0.1,5\n0.01,0.1,5\n",
                 "line 1 (header), column 3: column 'steer_angle_deg' is in degrees; units must be SI; "
                 "convert degrees to radians and name it steer_angle_rad",
                 id="degree_column_named_with_its_1_based_column_number"),
    pytest.param("time_s,steer_angle_rad\n0,0.1\n\n0.02,0.1\n0.01,0.1\n",
                 "line 5, column time_s: time goes backwards (0.01 s after 0.02 s on line 4); "
                 "sort the rows by time or remove the out-of-order sample",
                 id="time_backwards_names_both_file_lines_across_a_blank_line"),
    pytest.param("time_s,steer_angle_rad\n0,0.1\n",
                 "file: only one data row; a recording needs at least two samples",
                 id="single_data_row_is_refused_as_such"),
])
def test_bad_file_gets_its_one_line_message(tmp_path, text, message):
    path = _csv(tmp_path, "bad.csv", text)
    assert _message(path) == f"{path}: {message}"


def test_angle_just_above_two_pi_is_degrees(tmp_path):
    # 7 (degrees, by mistake) is above 2*pi = 6.283 rad and must be refused; 6.28 is fine
    path = _csv(tmp_path, "seven.csv", "time_s,steer_angle_rad\n0,0.1\n0.01,7.0\n")
    assert _message(path) == (f"{path}: line 3, column steer_angle_rad: |value| 7 exceeds 2*pi: looks like degrees, "
                              "not radians; convert to radians (multiply by pi/180)")
    ok = _csv(tmp_path, "ok.csv", "time_s,steer_angle_rad\n0,0.1\n0.01,6.28\n")
    assert read_recording(ok).signal("steer_angle_rad")[-1] == 6.28


def test_write_recording_names_the_csv_line_the_row_would_have(tmp_path):
    df = pd.DataFrame({"time_s": [0.0, 0.01, 0.02], "steer_angle_rad": [0.1, 0.1, 7.0]})
    path = tmp_path / "mem.csv"
    with pytest.raises(RecordingError) as info:
        write_recording(path, df, {"kind": "steer_stand"})
    # header = line 1, so the third data row is line 4
    assert str(info.value) == (f"{path}: line 4, column steer_angle_rad: |value| 7 exceeds 2*pi: looks like degrees, "
                               "not radians; convert to radians (multiply by pi/180)")
    assert list(tmp_path.iterdir()) == []


def test_pressure_bound_is_inclusive_at_500_kpa(tmp_path):
    ok = _csv(tmp_path, "p500.csv", "time_s,pipe_angle_rad\n0,0.1\n0.01,0.1\n", '{"kind": "shell_rock", "pressure_kpa": 500}')
    assert read_recording(ok).pressure_kpa == 500.0
    bad = _csv(tmp_path, "p5005.csv", "time_s,pipe_angle_rad\n0,0.1\n0.01,0.1\n", '{"kind": "shell_rock", "pressure_kpa": 500.5}')
    assert _message(bad) == (f"{bad}: field pressure_kpa (sidecar p5005.json): 500.5 kPa is outside (0, 500] kPa; "
                             "give the shell gauge pressure in kPa (1 psi = 6.895 kPa)")


def test_ramp_exit_before_first_sample_refused(tmp_path):
    path = _csv(tmp_path, "exit.csv", "time_s,drive_rate_rad_s\n1.0,0.1\n1.01,0.1\n",
                '{"kind": "ramp", "pressure_kpa": 13.8, "ramp_exit_s": 0.5}')
    assert _message(path) == (f"{path}: field ramp_exit_s (sidecar exit.json): 0.5 s is before the first sample (1 s); "
                              "give the time the robot left the ramp, in the recording's time base")
    assert _message(path, ramp_exit_s=0.25).startswith(f"{path}: field ramp_exit_s (flag --ramp-exit-s): 0.25 s is before")
    assert read_recording(path, ramp_exit_s=1.0).ramp_exit_s == 1.0


def test_ramp_angle_from_sidecar_says_sidecar(tmp_path):
    path = _csv(tmp_path, "ang.csv", "time_s,drive_rate_rad_s\n0,0.1\n0.01,0.1\n",
                '{"kind": "ramp", "pressure_kpa": 13.8, "ramp_angle_deg": 12}')
    rec = read_recording(path)
    assert rec.ramp_angle_deg == 12.0 and rec.meta["ramp_angle_deg_source"] == "sidecar"


def test_normalise_keeps_the_first_sample_of_a_duplicate_stamp(tmp_path):
    path = _csv(tmp_path, "dups.csv", "time_s,steer_angle_rad\n0,0.1\n0.01,0.2\n0.01,0.3\n0.02,0.4\n")
    norm = normalise(read_recording(path))
    np.testing.assert_array_equal(norm.time, [0.0, 0.01, 0.02])
    np.testing.assert_array_equal(norm.signal("steer_angle_rad"), [0.1, 0.2, 0.4])
    assert norm.meta["n_duplicates_dropped"] == 1


def test_normalise_gap_threshold_is_three_median_steps(tmp_path):
    # steps 10, 10, 10, 25, 10, 10, 35 ms: median 10 ms; only the 35 ms step exceeds 3x
    t = "0 0.01 0.02 0.03 0.055 0.065 0.075 0.11".split()
    path = _csv(tmp_path, "gaps.csv", "time_s,steer_angle_rad\n" + "".join(f"{x},0.1\n" for x in t))
    norm = normalise(read_recording(path))
    assert norm.meta["gaps"] == [(0.075, 0.11)]
    assert norm.meta["median_dt_s"] == pytest.approx(0.01, abs=1e-12)
    assert norm.meta["n_duplicates_dropped"] == 0
