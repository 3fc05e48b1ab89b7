"""The campaign plan the workflow expands (roboball.pipeline.plan): the campaigns and their
recordings, what the run makes and what it skips with the reason, the ramp runs by pressure
whose pooled diagnoses score each other, the sweep cases, the schedule."""
from __future__ import annotations

from pathlib import Path

import pytest

from roboball.errors import ConfigError
from roboball.pipeline.plan import Campaign, campaign_id, friction_models, schedule_args, sweep_cases

from conftest import REPO
ROW = "time_s,drive_rate_rad_s\n0.0,0.0\n0.01,0.0\n"
FRICTION = {"steer_laws": ["viscous", "majd"], "drive_laws": ["majd"]}


def folder(path: Path, lines: list, header: str = "file,kind,pressure_kpa") -> Path:
    """A campaign folder with the listed recordings (name, kind, pressure) and its manifest."""
    path.mkdir(parents=True)
    rows = [header]
    for name, kind, p, *rest in lines:
        (path / name).write_text(ROW)
        rows.append(",".join([name, kind, p, *rest]))
    (path / "MANIFEST.csv").write_text("\n".join(rows) + "\n")
    return path


def config(*campaigns) -> dict:
    return {"campaigns": [{"id": cid, "name": name, "raw": str(raw), **extra} for cid, name, raw, extra in campaigns]}


RAMPS = [("ramp_10.3kpa_r1.csv", "ramp", "10.3"), ("ramp_10.3kpa_r2.csv", "ramp", "10.30"),
         ("ramp_10.3kpa_r3.csv", "ramp", "10.3"), ("ramp_20.7kpa_r1.csv", "ramp", "20.7"),
         ("shell_rock_6.9kpa_r1.csv", "shell_rock", "6.9")]
REAL = [("s.csv", "steer_stand", "", "", "real_steer_stand"), ("d.csv", "shell_rock", "unknown", "unknown", ""),
        ("c1.csv", "steer_coupled", "", "", ""), ("c2.csv", "steer_coupled", "", "", "")]
REAL_HEADER = "file,kind,pressure_kpa,steer_joint,name"


def test_ramp_runs_group_by_pressure_and_each_is_scored_by_the_others(tmp_path):
    camp = Campaign.from_config(config(("testbed", "virtual test bed", folder(tmp_path / "raw", RAMPS), {})))
    assert camp.stems("ramp") == ["ramp_10.3kpa_r1", "ramp_10.3kpa_r2", "ramp_10.3kpa_r3", "ramp_20.7kpa_r1"]
    # '10.30' and '10.3' are one pressure
    assert camp.ramp_groups() == ["ramp_10.3kpa", "ramp_20.7kpa"]
    assert camp.runs_at("ramp_10.3kpa") == ["ramp_10.3kpa_r1", "ramp_10.3kpa_r2", "ramp_10.3kpa_r3"]
    # held out: the run itself is never among the runs that give its effects ...
    assert camp.other_runs("ramp_10.3kpa_r2") == ["ramp_10.3kpa_r1", "ramp_10.3kpa_r3"]
    # ... unless it is the only run at its pressure
    assert camp.other_runs("ramp_20.7kpa_r1") == ["ramp_20.7kpa_r1"]


def test_a_second_campaign_is_a_dataset_of_its_own_and_optional_ones_may_be_missing(tmp_path):
    raw = folder(tmp_path / "raw", RAMPS)
    real = folder(tmp_path / "real", REAL, REAL_HEADER)
    camp = Campaign.from_config(config(("testbed", "virtual test bed", raw, {}),
                                       ("real", "real robot", real, {"optional": True})))
    assert not camp.notes and list(camp.datasets) == ["testbed", "real"]
    assert camp.stems("steer_stand", "real") == ["real_steer_stand"]          # named by the manifest
    assert camp.recordings["d"]["steer_joint"] == "unknown" and camp.pressure("d") is None
    assert camp.stems("shell_rock", "testbed") == ["shell_rock_6.9kpa_r1"]
    assert camp.coupled_groups() == {"real": ("real", ["c1", "c2"], None)}
    assert camp.fits(FRICTION) == [("real", "steer", "viscous"), ("real", "steer", "majd")]
    off = Campaign.from_config(config(("testbed", "t", raw, {}), ("real", "r", tmp_path / "none", {"optional": True})))
    assert list(off.datasets) == ["testbed"] and "folder" in off.notes[0] and "not found" in off.notes[0]


def test_missing_campaigns_and_names_used_twice_are_refused_in_one_line(tmp_path):
    raw = folder(tmp_path / "raw", RAMPS)
    with pytest.raises(ConfigError, match=r"campaign 'real robot': folder .*none not found"):
        Campaign.from_config(config(("testbed", "t", raw, {}), ("real", "real robot", tmp_path / "none", {})))
    other = folder(tmp_path / "other", [("ramp_10.3kpa_r1.csv", "ramp", "10.3")])
    with pytest.raises(ConfigError) as info:
        Campaign.from_config(config(("testbed", "t", raw, {}), ("b", "b", other, {})))
    msg = str(info.value)
    assert f"{other / 'MANIFEST.csv'}: line 2: ramp_10.3kpa_r1: same name as {raw / 'MANIFEST.csv'}: line 2" in msg
    assert "\n" not in msg


def test_a_users_campaign_is_named_by_the_command_line_its_manifest_or_its_folder(tmp_path):
    raw = folder(tmp_path / "My Robot", REAL, REAL_HEADER)
    camp = Campaign.from_config({"campaign_dir": str(raw)})
    assert camp.datasets == {"my_robot": {"name": "My Robot", "diagnose_recordings": True}}
    assert Campaign.from_config({"campaign_dir": str(raw), "campaign_name": "Lab 2"}).datasets.keys() == {"lab_2"}
    named = folder(tmp_path / "x", [("s.csv", "steer_stand", "", "bench A")], "file,kind,pressure_kpa,campaign")
    assert Campaign.from_config({"campaign_dir": str(named)}).name("bench_a") == "bench A"
    assert campaign_id("Roboball, real (2025)") == "roboball_real_2025"


def test_the_plan_says_what_it_skips_and_why(tmp_path):
    lines = [("steer_stand_r1.csv", "steer_stand", ""), ("shell_a.csv", "shell_rock", "13.8"),
             ("shell_b.csv", "shell_rock", "13.8"), ("ramp_r1.csv", "ramp", "13.8")]
    camp = Campaign.from_config({"campaign_dir": str(folder(tmp_path / "lab", lines))})
    plan = camp.plan_lines(FRICTION)
    assert "make  Fig. 7 and Table I rows: steer friction of 'lab'" in plan
    assert "skip  Fig. 8 and Table I rows: drive friction of 'lab': no drive_stand recording in 'lab'" in plan
    assert any(p.startswith("skip  zeta(p), omega_n(p) regression") and p.endswith(
        "shell releases at one pressure only (13.8 kPa): decay table and diagnosis made, no regression") for p in plan)
    assert any("ramp descents" in p and "point contact and the diagnosed model only" in p for p in plan)
    assert "note  ramp runs: no drive_stand Majd fit in 'lab': its drive friction is Table I's (configs/robot.yaml), " \
           "without posterior draws" in plan
    assert "note  ramp runs: one run at 13.8 kPa: the diagnosed model is scored there on the run its diagnosis " \
           "was fitted on (in sample, marked in Figs. 13, 14)" in plan
    assert "skip  Fig. S2 (coupled steer test): no steer_coupled recording" in plan
    assert camp.ramp_friction(FRICTION) == {"steer": "results/friction/lab/steer_majd.json"}
    assert not camp.has_regression() and camp.diagnosed_stems() == ["steer_stand_r1", "shell_a", "shell_b"]
    assert all(p.startswith(("make  ", "skip  ", "note  ", "campaign ")) for p in plan)


def test_coupled_repeats_make_one_fig_s2_per_logged_pressure_and_one_of_unlogged_pressure(tmp_path):
    lines = [("steer_stand_r1.csv", "steer_stand", ""), ("shell_a.csv", "shell_rock", "6.9"),
             ("shell_b.csv", "shell_rock", "20.7"), ("c_a1.csv", "steer_coupled", "6.9"),
             ("c_a2.csv", "steer_coupled", "6.90"), ("c_b1.csv", "steer_coupled", "20.7"),
             ("c_u1.csv", "steer_coupled", ""), ("c_u2.csv", "steer_coupled", "unknown")]
    camp = Campaign.from_config({"campaign_dir": str(folder(tmp_path / "lab", lines))})
    # a set is named by its campaign's id (as Fig. 7's files are) and its logged pressure
    assert camp.coupled_groups() == {"lab": ("lab", ["c_u1", "c_u2"], None),
                                     "lab_6.9kpa": ("lab", ["c_a1", "c_a2"], 6.9), "lab_20.7kpa": ("lab", ["c_b1"], 20.7)}
    sets, skipped = camp.coupled_plan(FRICTION)
    assert list(sets) == ["lab", "lab_6.9kpa"]
    assert skipped == [("lab_20.7kpa", "one steer_coupled recording; leave-one-out needs two repeats")]
    plan = camp.plan_lines(FRICTION)
    assert "make  Fig. S2 (coupled steer test, 2 repeats of 'lab', pressure not logged)" in plan
    assert "make  Fig. S2 (coupled steer test, 2 repeats of 'lab', at 6.9 kPa)" in plan
    assert "skip  Fig. S2 (coupled steer test of 'lab', at 20.7 kPa): one steer_coupled recording; leave-one-out " \
           "needs two repeats" in plan
    # no steer fit in its campaign, no set
    raw = folder(tmp_path / "two", [("c1.csv", "steer_coupled", "6.9"), ("c2.csv", "steer_coupled", "6.9")])
    two = Campaign.from_config(config(("lab", "lab", folder(tmp_path / "lab2", lines), {}), ("b", "bench B", raw, {})))
    assert set(two.coupled_groups()) == {"lab", "lab_6.9kpa", "lab_20.7kpa", "b_6.9kpa"}
    sets, skipped = two.coupled_plan(FRICTION)
    assert set(sets) == {"lab", "lab_6.9kpa"}
    assert ("b_6.9kpa", "no steer_stand Majd fit in 'bench B' for its steer friction") in skipped


def test_sweep_cases_scale_modulus_dissipation_and_both():
    cases = sweep_cases([0.5, 1.5])
    assert cases == {"modulus_x0.5": (0.5, 1.0), "dissipation_x0.5": (1.0, 0.5), "both_x0.5": (0.5, 0.5),
                     "modulus_x1.5": (1.5, 1.0), "dissipation_x1.5": (1.0, 1.5), "both_x1.5": (1.5, 1.5)}


def test_friction_models_and_schedule_arguments():
    assert friction_models({"steer_laws": ["viscous", "majd"], "drive_laws": ["majd"]}) == \
        [("steer", "viscous"), ("steer", "majd"), ("drive", "majd")]
    assert schedule_args({"csv": "s.csv"}) == "--schedule-csv s.csv"
    assert schedule_args({"time_s": [0.0, 2.0], "pressure_kpa": [20.7, 6.9]}) == \
        "--schedule-time-s 0.0 2.0 --schedule-pressure-kpa 20.7 6.9"
    assert schedule_args({}) == schedule_args(None) == "--schedule-time-s 0.0 3.0 --schedule-pressure-kpa 20.7 6.9"


def test_the_repository_campaigns():
    import yaml

    config = yaml.safe_load((REPO / "configs" / "config.yaml").read_text())
    camp = Campaign.from_config(config, base=str(REPO))
    assert len(camp.stems("ramp")) == 15 and len(camp.ramp_groups()) == 5 and camp.has_regression()
    assert all(len(camp.other_runs(s)) == 2 for s in camp.stems("ramp"))
    assert len(sweep_cases(config["shell"]["sweep_factors"])) == 6
    assert camp.ramp_friction(config["friction"]) == {"steer": "results/friction/testbed/steer_majd.json",
                                                      "drive": "results/friction/testbed/drive_majd.json"}
    if "real" in camp.datasets:       # the public real logs, through the same manifest mechanism
        assert camp.stems("steer_coupled", "real") == [f"steer_coupled_20250429_{t}" for t in ("165825", "165853",
                                                                                              "165914")]
        assert camp.diagnosed_stems() == ["real_steer_stand", "real_shell_rock"]
    # the campaign's coupled runs: two at each pressure, one Fig. S2 each (and the real repeats')
    sets, skipped = camp.coupled_plan(config["friction"])
    assert not skipped and [n for n in sets if n.startswith("testbed")] == [
        f"testbed_{p}kpa" for p in ("6.9", "10.3", "13.8", "17.2", "20.7")]
    assert all(len(stems) == 2 and d == "testbed" for n, (d, stems, p) in sets.items() if n != "real")
