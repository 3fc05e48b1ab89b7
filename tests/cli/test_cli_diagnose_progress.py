"""`roboball diagnose` says what it is doing while it works (roboball.cli.diagnose.Progress): the
baseline and each selection round in plain words, and a line after every few silent seconds."""
from __future__ import annotations

import io
import time

from roboball.cli.diagnose import Progress


def test_progress_lines_in_plain_words():
    out = io.StringIO()
    p = Progress("ramp_13.8kpa_r1.csv", every_s=60.0, out=out)
    assert out.getvalue() == ""                  # nothing before the recording is read and checked
    p("data: 3 release window(s) of ramp")
    p("baseline: rmse 2.388, held-out 2.388, rho1 0.998")
    p("   cv stage1: 12 problems, 400 calls")                     # the search's detail: not shown
    p("round: best so far viscous_damping+rolling_resistance; viscous_damping dBIC -3e+04 cv 0.01 (kept)")
    p.close()
    lines = out.getvalue().splitlines()
    assert len(lines) == 3, lines
    assert lines[0].endswith("diagnosing ramp_13.8kpa_r1.csv (3 release window(s) of ramp): fitting the baseline model ...")
    assert "baseline fitted (RMS error 2.388, held out 2.388)" in lines[1]
    assert "round 1 done: best model so far viscous_damping + rolling_resistance" in lines[2]
    assert not any("dBIC" in line or "cv stage" in line for line in lines)


def test_a_heartbeat_while_nothing_else_is_said():
    out = io.StringIO()
    p = Progress("x.csv", every_s=0.3, out=out)
    p("data: 1 release window(s) of shell_rock")
    time.sleep(1.6)
    p.close()
    beats = [line for line in out.getvalue().splitlines() if "still working (fitting the baseline model)" in line]
    assert len(beats) >= 1


def test_verbose_shows_the_search_itself():
    out = io.StringIO()
    p = Progress("x.csv", verbose=True, every_s=60.0, out=out)
    p("   cv stage1: 12 problems, 400 calls")
    p.close()
    assert "cv stage1: 12 problems" in out.getvalue()
