"""roboball.diagnose.shake: the restarts of a judged fit that holds dry friction."""
import pytest

from roboball.diagnose.shake import shaken_starts


def test_the_restarts_rescale_the_dry_magnitudes_and_the_viscous_coefficient_only():
    values = {"viscous_c": 0.16, "coulomb_friction.tau_c": 0.24, "stiction.tau_s": 0.6, "stiction.v_s": 0.002,
              "q0@0": 0.4, "ts@0": 0.01}
    starts = shaken_starts(("coulomb_friction", "stiction"), values, ["viscous_c"])
    assert len(starts) == 3 * 2 * 2
    # the newest dry effect (stiction) by 0.5-1.25, the other by 0.9-1.1, the damping by 1-1.2
    assert sorted({round(v["stiction.tau_s"] / 0.6, 6) for v in starts}) == [0.5, 0.8, 1.25]
    assert sorted({round(v["coulomb_friction.tau_c"] / 0.24, 6) for v in starts}) == [0.9, 1.1]
    assert sorted({round(v["viscous_c"] / 0.16, 6) for v in starts}) == [1.0, 1.2]
    # the breakaway's width, the release states: as fitted
    assert all(v["stiction.v_s"] == 0.002 and v["q0@0"] == 0.4 and v["ts@0"] == 0.01 for v in starts)


def test_a_model_without_dry_friction_is_not_restarted_and_one_without_damping_keeps_it():
    assert shaken_starts(("quadratic_drag", "linear_stiffness"), {"viscous_c": 0.1, "quadratic_drag.c2": 0.04,
                                                                  "linear_stiffness.k": 1.0}, ["viscous_c"]) == []
    starts = shaken_starts(("rolling_resistance",), {"rolling_resistance.tau_rr": 2.0}, [])
    assert [v["rolling_resistance.tau_rr"] for v in starts] == pytest.approx([1.0, 1.6, 2.5])
