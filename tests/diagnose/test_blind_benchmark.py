"""The blind benchmark's draw (benchmarks/diagnose_blind.py): every concealed effect shows."""
import sys
from pathlib import Path

import pytest

from conftest import REPO
sys.path.insert(0, str(REPO / "benchmarks"))

import diagnose_blind  # noqa: E402


def test_draw_is_reproducible_and_spans_every_kind_and_set():
    a, b = diagnose_blind.draw_cases(6), diagnose_blind.draw_cases(6)
    assert a == b and len(a) >= 40
    assert {c["kind"] for c in a} == set(diagnose_blind.SETS)
    assert sum(not c["effects"] for c in a) == 10
    assert diagnose_blind.draw_cases(7) != a


def test_a_concealed_effect_below_the_noise_is_redrawn_and_no_other_case_changes():
    """Seed 6's steer_stand-13 drew stiction of 0.88 N m above 0.18 N m of kinetic friction:
    the swings never come to rest in the recording, and the breakaway torque, acting only for an
    instant at each reversal, changes the recording by one noise level (0.6 mrad RMS); no method
    can find it.  The case is redrawn until every concealed effect shows by two noise levels."""
    cases = diagnose_blind.draw_cases(6)
    case = next(c for c in cases if c["id"] == "steer_stand-13")
    vis = diagnose_blind.visibility(case)
    assert vis["stiction"] < diagnose_blind.VISIBLE < vis["coulomb_friction"]
    shown, (dense, meta, rng) = diagnose_blind.visible_draw(case)
    assert shown["rejected"][0]["effects"] == case["effects"]
    assert set(shown["effects"]) == set(case["effects"]) and shown["effects"] != case["effects"]
    assert all(v >= diagnose_blind.VISIBLE for v in shown["visibility"].values())
    assert shown["seed"] == case["seed"] and shown["releases"] == case["releases"]
    assert diagnose_blind.draw_cases(6) == cases
    lo, hi = diagnose_blind.WITH_STICTION["coulomb_friction"]["tau_c"]
    assert lo <= shown["effects"]["coulomb_friction"]["tau_c"] <= hi
    lo, hi = diagnose_blind.RANGES["steer_stand"]["stiction"]["tau_s"]
    assert lo <= shown["effects"]["stiction"]["tau_s"] <= hi
    assert meta["kind"] == "steer_stand" and len(dense) > 1000


def test_visibility_is_measured_on_the_signal_the_diagnosis_fits():
    assert diagnose_blind.SIGNAL == {"steer_stand": "steer_angle_rad", "shell_rock": "pipe_angle_rad",
                                     "ramp": "drive_rate_rad_s"}
    assert diagnose_blind.noise_level("steer_stand") == pytest.approx(4.9e-4, rel=0.02)
    assert diagnose_blind.noise_level("ramp") == pytest.approx(0.015, rel=0.02)
