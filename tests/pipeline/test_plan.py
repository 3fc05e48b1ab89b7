"""The campaign plan the workflow expands (roboball.pipeline.plan): recordings, real logs, the
ramp runs by pressure whose pooled diagnoses score each other, the sweep cases, the schedule."""
from __future__ import annotations

from pathlib import Path

import pytest

from roboball.errors import ConfigError
from roboball.pipeline.plan import Campaign, friction_models, schedule_args, sweep_cases

from conftest import REPO
ROW = "time_s,drive_rate_rad_s\n0.0,0.0\n0.01,0.0\n"


def campaign_dir(tmp_path: Path, lines: list[str], real: bool = True) -> dict:
    """A raw-data folder with the listed recordings (file,kind,pressure_kpa) and, with `real`,
    a folder of real logs; returns the workflow config that points at them."""
    raw = tmp_path / "raw"
    raw.mkdir(parents=True)
    rows = ["file,kind,pressure_kpa"]
    for name, kind, p in lines:
        (raw / name).write_text(ROW)
        rows.append(f"{name},{kind},{p}")
    (raw / "MANIFEST.csv").write_text("\n".join(rows) + "\n")
    real_dir = tmp_path / "real"
    if real:
        real_dir.mkdir()
    return {"raw_data": str(raw),
            "real_data": {"enabled": "auto", "path": str(real_dir), "steer_stand": "s.csv", "shell_rock": "d.csv"}}


RAMPS = [("ramp_10.3kpa_r1.csv", "ramp", "10.3"), ("ramp_10.3kpa_r2.csv", "ramp", "10.30"),
         ("ramp_10.3kpa_r3.csv", "ramp", "10.3"), ("ramp_20.7kpa_r1.csv", "ramp", "20.7"),
         ("shell_rock_6.9kpa_r1.csv", "shell_rock", "6.9")]


def test_ramp_runs_group_by_pressure_and_each_is_scored_by_the_others(tmp_path):
    camp = Campaign.from_config(campaign_dir(tmp_path, RAMPS))
    assert camp.stems("ramp") == ["ramp_10.3kpa_r1", "ramp_10.3kpa_r2", "ramp_10.3kpa_r3", "ramp_20.7kpa_r1"]
    # '10.30' and '10.3' are one pressure
    assert camp.ramp_groups() == ["ramp_10.3kpa", "ramp_20.7kpa"]
    assert camp.runs_at("ramp_10.3kpa") == ["ramp_10.3kpa_r1", "ramp_10.3kpa_r2", "ramp_10.3kpa_r3"]
    # held out: the run itself is never among the runs that give its effects ...
    assert camp.other_runs("ramp_10.3kpa_r2") == ["ramp_10.3kpa_r1", "ramp_10.3kpa_r3"]
    # ... unless it is the only run at its pressure
    assert camp.other_runs("ramp_20.7kpa_r1") == ["ramp_20.7kpa_r1"]


def test_real_logs_join_when_their_folder_exists_and_stay_apart(tmp_path):
    camp = Campaign.from_config(campaign_dir(tmp_path, RAMPS))
    assert camp.real_on and not camp.notes
    assert camp.stems("steer_stand", real=True) == ["real_steer_stand"]
    assert camp.recordings["real_shell_rock"]["src"] == str(tmp_path / "real" / "d.csv")
    assert camp.stems("shell_rock") == ["shell_rock_6.9kpa_r1"]          # the campaign's only

    off = Campaign.from_config(campaign_dir(tmp_path / "b", RAMPS, real=False))
    assert not off.real_on and "real_steer_stand" not in off.recordings
    assert "real logs not found" in off.notes[0]


def test_real_logs_required_but_missing_or_shadowed_are_refused_in_one_line(tmp_path):
    cfg = campaign_dir(tmp_path, RAMPS, real=False)
    cfg["real_data"]["enabled"] = True
    with pytest.raises(ConfigError, match="real_data.path .*: folder not found"):
        Campaign.from_config(cfg)

    cfg = campaign_dir(tmp_path / "b", RAMPS + [("real_steer_stand.csv", "steer_stand", "")])
    with pytest.raises(ConfigError) as info:
        Campaign.from_config(cfg)
    assert "recording real_steer_stand: the name of a real log" in str(info.value)
    assert "\n" not in str(info.value)


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


def test_the_repository_campaign():
    import yaml

    config = yaml.safe_load((REPO / "configs" / "config.yaml").read_text())
    config["raw_data"] = str(REPO / "raw_data")
    camp = Campaign.from_config(config)
    assert len(camp.stems("ramp")) == 15 and len(camp.ramp_groups()) == 5
    assert all(len(camp.other_runs(s)) == 2 for s in camp.stems("ramp"))
    assert len(sweep_cases(config["shell"]["sweep_factors"])) == 6
