"""Random valid recordings with hand releases survive the whole input
path of the pipeline.

A random release log (kind, rest angle, damping, frequency, offsets, sampling jitter, gaps,
duplicate stamps, noise, quantisation; tests/identify/test_decay.py and tests/ingest/test_recording.py cover the
pieces) is written with the recording writer, optionally rewritten with CRLF line endings and a
byte-order mark, read back through the ingest reader (`read_any`) and normalised, then given to
the release finder and the decay extractor.  The data must round-trip exactly, the analysis of
the file must equal the analysis of the in-memory data, and the only failure allowed is a
one-line RoboballError naming the file.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from roboball.identify.shell.decay import decay_table
from roboball.errors import RoboballError
from roboball.ingest.importers import read_any
from roboball.ingest.recording import Recording, normalise, write_recording
from roboball.testbed.synthetic import synthetic_release_log

MAIN = {"steer_stand": "steer_angle_rad", "drive_stand": "drive_angle_rad", "shell_rock": "pipe_angle_rad"}


@st.composite
def release_logs(draw):
    kind = draw(st.sampled_from(sorted(MAIN)))
    n = draw(st.integers(1, 2))
    rels = [dict(offset=draw(st.sampled_from([-1.0, 1.0])) * draw(st.floats(0.05, 0.8)),
                 zeta=draw(st.floats(0.02, 0.4)), omega_n=draw(st.floats(1.5, 8.0)),
                 hold_s=draw(st.floats(0.4, 1.2))) for _ in range(n)]
    # free_s is left to the generator (until the ringing has decayed to the noise): the release
    # finder does not promise to find a release whose recording ends while it still rings.
    log = dict(rest=draw(st.floats(-0.2, 0.2)), seed=draw(st.integers(0, 2 ** 16)),
               rate_hz=draw(st.sampled_from([(80.0, 100.0), (95.0, 105.0), (180.0, 220.0)])),
               gap_probability=draw(st.sampled_from([0.0, 0.01])), duplicate_probability=draw(st.sampled_from([0.0, 0.005])),
               noise=draw(st.sampled_from([0.0, 2e-4, 1e-3])), quantum=draw(st.sampled_from([0.0, 1e-3])))
    t0 = draw(st.floats(0.0, 500.0))
    t, y, _ = synthetic_release_log(rels, **log)
    meta = {"kind": kind, "pressure_kpa": draw(st.floats(3.0, 30.0)) if kind == "shell_rock" else None}
    df = pd.DataFrame({"time_s": t + t0, MAIN[kind]: y})
    return df, meta, draw(st.sampled_from(["lf", "crlf", "crlf+bom"]))


def _analyse(rec: Recording):
    """(decay table as an array, None) or (None, error message)."""
    try:
        table = decay_table(normalise(rec))
    except RoboballError as exc:
        return None, str(exc)
    return table.select_dtypes("number").to_numpy(dtype=float), None


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                HealthCheck.too_slow])
@given(case=release_logs())
def test_random_release_logs_round_trip_and_analyse_like_in_memory(tmp_path, case):
    df, meta, style = case
    path = tmp_path / "log.csv"
    write_recording(path, df, meta)
    if style != "lf":
        for p in (path, path.with_suffix(".json")):
            text = p.read_bytes().replace(b"\n", b"\r\n")
            p.write_bytes((b"\xef\xbb\xbf" if style == "crlf+bom" else b"") + text)
    rec = read_any(path)
    np.testing.assert_array_equal(rec.data.to_numpy(), df.to_numpy())     # exact round trip
    assert rec.kind == meta["kind"] and rec.pressure_kpa == meta["pressure_kpa"]

    from_file, err_file = _analyse(rec)
    from_memory, err_memory = _analyse(Recording(df.copy(), dict(rec.meta), None))
    if err_file is not None:
        assert "\n" not in err_file and err_file.startswith(f"{path}: "), err_file
        assert err_memory is not None and err_memory.split(": ", 1)[1] == err_file.split(": ", 1)[1]
        return
    assert err_memory is None
    np.testing.assert_array_equal(from_file, from_memory)
    table = decay_table(normalise(rec))
    assert len(table) >= 1
    assert np.all((table.zeta >= 0) & (table.zeta < 1)) and np.all(table.omega_n_rad_s > 0)
    assert all(math.isfinite(v) for v in table.omega_n_rad_s)
