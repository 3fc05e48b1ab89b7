"""A joint's breakaway is refitted from several starts before it is judged (roboball.diagnose.restarts)."""
import sys

import pytest

from roboball.diagnose import diagnose
from roboball.diagnose import restarts
from roboball.diagnose.scored import Settings
from roboball.reduced.models import model_for
from roboball.reduced.shell_steer import ShellSteerModel

from conftest import REPO


def test_only_a_joints_breakaway_is_rough():
    stand = model_for("steer_stand")
    assert restarts.rough(stand, ("coulomb_friction", "stiction"))
    assert not restarts.rough(stand, ("coulomb_friction", "quadratic_drag"))
    # the ramp's breakaway fades over a fitted width (smooth), and is left as it is
    ramp = model_for("ramp", ramp_angle_deg=None)
    assert "stiction" in ramp.candidates and not restarts.rough(ramp, ("stiction", "quadratic_drag"))
    # a shell's candidates hold no stiction
    assert "stiction" not in model_for("shell_rock").candidates and "stiction" not in ShellSteerModel().candidates


def test_the_design_scales_the_dry_friction_and_the_damping_within_their_bounds_and_keeps_the_fit_itself():
    values = {"viscous_c": 0.2, "coulomb_friction.tau_c": 0.3, "stiction.tau_s": 16.0, "q0@0": 0.8}
    info = {"viscous_c": (0.1, 0.0, 5.0), "coulomb_friction.tau_c": (0.1, 0.0, 5.0), "stiction.tau_s": (0.2, 0.0, 20.0)}
    got = restarts.starts(values, info)
    assert len(got) == 2 * 2 * 2 + 1 and got[-1] == values
    assert {v["stiction.tau_s"] for v in got[:-1]} == {8.0, 20.0}           # 16 x 1.25 clipped at 20 N m
    assert {v["coulomb_friction.tau_c"] for v in got[:-1]} == {0.3 * 0.9, 0.3 * 1.1}
    assert {v["viscous_c"] for v in got[:-1]} == {0.2, 0.2 * 1.2}
    assert all(v["q0@0"] == 0.8 for v in got)                               # release states as they were
    assert len(restarts.starts({"stiction.tau_s": 0.5}, info)) == 3         # a parameter the model lacks


@pytest.mark.slow       # two diagnoses of a 4-release stand recording: about 30 s
def test_a_breakaway_fit_stuck_in_a_poor_optimum_is_restarted_and_the_stiction_found(tmp_path):
    """The blind benchmark's seed 6 steer_stand-13 (Coulomb friction + a stiction that shows by 4.7
    noise levels): under the pipeline's pinned numerics the screening fit of Coulomb + stiction
    ended in a poor optimum, the stiction failed the keep rule and the recording was reported
    `unexplained` with Coulomb friction alone (with this machine's default vector code it was
    found).  Refitted from the design's starts it is found under both."""
    sys.path.insert(0, str(REPO / "benchmarks"))
    import blind_cases
    import diagnose_blind

    case = next(c for c in blind_cases.draw_cases(6) if c["id"] == "steer_stand-13")
    case, made = diagnose_blind.visible_draw(case)
    csv = diagnose_blind._write(*made, tmp_path, case)
    settings = Settings(max_effects=2)
    _, js = diagnose(str(csv), settings=settings, drake=False)
    assert sorted(m["effect"] for m in js["missing_physics"]) == ["coulomb_friction", "stiction"]
    assert js["verdict"] == "augmented"
    tau_c = next(m for m in js["missing_physics"] if m["effect"] == "coulomb_friction")["parameters"]["tau_c"]
    assert tau_c == pytest.approx(case["effects"]["coulomb_friction"]["tau_c"], rel=0.1)


def test_a_restart_replaces_the_fit_only_where_it_ends_lower_and_keeps_the_lowest():
    """restart_rough_fits with a stand-in engine whose fit costs a start by its breakaway: the
    model with a stiction takes its lowest start's fit; a model without one, and a model whose
    own fit is already the lowest, keep theirs."""
    from types import SimpleNamespace

    from roboball.diagnose.fit import Problem
    from roboball.diagnose.scored import Scored

    def problem(effects, values):
        return Problem(effects=tuple(effects), values=dict(values), free=list(values), masks={})

    def fit(problems, max_iter):
        for p in problems:      # the cost: lowest at a breakaway of 0.5 N m
            p.rss, p.n = (p.values.get("stiction.tau_s", 0.4) - 0.5) ** 2 + 1e-6, 100

    info = {"stiction.tau_s": (0.2, 0.0, 20.0), "coulomb_friction.tau_c": (0.1, 0.0, 5.0), "viscous_c": (0.1, 0.0, 5.0)}
    selector = SimpleNamespace(model=model_for("steer_stand"), engine=SimpleNamespace(info=info, fit=fit),
                               s=Settings(), log=lambda *a: None, full_problem=problem)

    def scored(effects, tau_s):
        p = problem(effects, {"viscous_c": 0.2, "coulomb_friction.tau_c": 0.3,
                              **({"stiction.tau_s": tau_s} if tau_s is not None else {})})
        fit([p], 1)
        return Scored(effects=tuple(effects), full=p)

    stuck, right = scored(("coulomb_friction", "stiction"), 0.4), scored(("coulomb_friction", "stiction"), 0.5)
    plain = scored(("coulomb_friction",), None)
    before = {id(x): x.full for x in (stuck, right, plain)}
    restarts.restart_rough_fits(selector, [stuck, right, plain])
    assert stuck.full is not before[id(stuck)] and stuck.values["stiction.tau_s"] == pytest.approx(0.5)
    assert right.full is before[id(right)] and plain.full is before[id(plain)]
