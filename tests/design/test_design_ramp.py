"""roboball.design on a ramp diagnosis (roboball.design.ramp): the experiments are the ramp's
angle.  The user's recording is a campaign ramp run (raw_data/), the diagnosis folder is written
by hand (a breakaway that fades with speed, its size poorly pinned), so the tests need no search:
the design must find that a shallower ramp, where the breakaway decides how the shell starts,
pins it better than another run on the user's ramp."""
import json
from pathlib import Path

import numpy as np
import pytest

from roboball.design import design, ramp
from roboball.design.inputs import read_source
from roboball.diagnose.report import model_setup
from roboball.errors import RoboballError
from roboball.reduced.ramp import RampModel
from roboball.reduced.stand import StandModel

REPO = Path(__file__).resolve().parents[2]
RUN = REPO / "raw_data" / "ramp" / "ramp_10.3kpa_r1.csv"
NOISE = 0.005           # rad/s: the averaged rate's noise on the campaign's runs
TAU_S, V_S = 4.5, 2.9   # N m, rad/s: the campaign's diagnosed breakaway at 10.3 kPa


def _diagnosis(tmp_path, tau_ci=(1.5, 7.5), setup=True):
    values = {"stiction.tau_s": TAU_S, "stiction.v_s": V_S}
    ci = {"stiction.tau_s": list(tau_ci), "stiction.v_s": [V_S - 0.2, V_S + 0.2]}
    folder = tmp_path / "diag"
    folder.mkdir()
    (folder / "diagnosis.json").write_text(json.dumps({
        "kind": "ramp", "verdict": "augmented", "located": [], "baseline": {"fitted": {}},
        "missing_physics": [{"effect": "stiction", "parameters": {"tau_s": TAU_S, "v_s": V_S},
                             "ci95": {"tau_s": list(tau_ci), "v_s": ci["stiction.v_s"]}}],
        "fit": {"rmse_after": 0.03, "units": "rad/s"}}))
    det = {"recording": str(RUN), "fit_noise": NOISE, "final_values": values, "ci95": ci}
    if setup:
        det["model_setup"] = model_setup(RampModel(ramp_angle_deg=16.0))
    (folder / "details.json").write_text(json.dumps(det))
    return folder


def test_details_keep_what_rebuilds_a_ramps_model():
    majd = {"f_w": 0.1, "f_c": 0.5, "sigma": 0.2, "omega_c": 0.3, "n": 2.0}
    setup = model_setup(RampModel(ramp_angle_deg=12.0, friction={"drive": majd}))
    assert setup["ramp_angle_deg"] == pytest.approx(12.0) and setup["friction"] == {"drive": majd}
    assert model_setup(RampModel(ramp_angle_deg=16.0))["friction"] == {}          # Table I
    assert model_setup(StandModel("steer_stand")) == {}


def test_a_shallower_ramp_pins_a_breakaway_better_than_the_users(tmp_path):
    src, js = design(_diagnosis(tmp_path), out_dir=tmp_path / "out")
    (choice,) = js["choices"]
    assert choice["about"] == "parameter" and choice["choice"].startswith("stiction.tau_s")
    best, user = choice["best"], choice["user_like"]
    assert user["ramp_angle_deg"] == 16.0 and user["users_angle"] and user["refitted"]
    assert best["pressure_kpa"] == user["pressure_kpa"] == 10.3          # not varied: the user's
    assert best["refitted"] and best["settles"], best
    assert best["ramp_angle_deg"] < 16.0, best
    assert best["separation"] > 2.5 * user["separation"], (best, user)
    md = (tmp_path / "out" / "design.md").read_text()
    assert f"ramp of {best['ramp_angle_deg']:g} deg" in md
    assert (tmp_path / "out" / "design.png").stat().st_size > 10000


def test_every_candidate_runs_on_every_ramp_until_the_first_leaves_it(tmp_path):
    src = read_source(_diagnosis(tmp_path))
    (choice,) = src.choices
    g = ramp.grid(src, choice)
    assert set(ramp.ANGLES_DEG) <= set(g.releases) and 16.0 in g.releases and g.feasible.all()
    length = ramp.ramp_length(src.prep)
    for w in range(len(g.releases)):
        n = int(g.moving[w].sum())
        rolled = [np.trapezoid(y[w][:n], g.t[:n]) for y in g.central.values()]
        assert max(rolled) <= length * 1.01                # counted only on the ramp
        if n < len(g.t):                                   # and up to where the first one leaves
            assert max(np.trapezoid(y[w][:n + 2], g.t[:n + 2]) for y in g.central.values()) > length
    # steeper ramps are rolled faster: the counted run is shorter
    assert g.moving[-1].sum() < g.moving[list(g.releases).index(16.0)].sum() < g.moving[0].sum()


def test_a_parameters_two_ends_refitted_keep_that_parameter(tmp_path):
    """Freed, the low end would just become the high end: no separation anywhere."""
    src = read_source(_diagnosis(tmp_path))
    (choice,) = src.choices
    g = ramp.grid(src, choice)
    w = list(g.releases).index(16.0)
    assert ramp.refit_gap(src, choice, g, w) > 1.0


def test_a_ramp_diagnosis_without_its_setup_gets_a_one_line_error(tmp_path):
    with pytest.raises(RoboballError, match="model_setup.*rerun the diagnosis"):
        read_source(_diagnosis(tmp_path, setup=False))


def test_the_command_names_the_ramp(tmp_path, capsys):
    from roboball.cli.main import main

    folder = _diagnosis(tmp_path)
    assert main(["design", str(folder), "--out", str(tmp_path / "out")]) == 0
    line = capsys.readouterr().out.splitlines()[0]
    assert line.startswith("stiction.tau_s within [1.5, 7.5]: a descent on a ramp of ") and "settles it" in line, line


def test_a_best_ramp_at_the_end_of_those_considered_is_said_to_be(tmp_path):
    """On the campaign's runs a loss law's choice comes out best on the steepest ramp considered:
    the why says that a steeper one may part the candidates further."""
    from roboball.design.why import why

    src = read_source(_diagnosis(tmp_path))
    (choice,) = src.choices
    best = {"closest_pair": [c.label for c in choice.candidates], "ramp_angle_deg": float(max(ramp.ANGLES_DEG)),
            "rms_difference_rad_s": 0.1, "separation": 5.0, "refitted": True}
    assert "the steepest ramp considered" in why(src, choice, best, None)
    assert "considered" not in why(src, choice, dict(best, ramp_angle_deg=12.0), None)
