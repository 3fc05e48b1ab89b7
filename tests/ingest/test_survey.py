"""`roboball manifest DIR` (roboball.ingest.survey): a campaign's manifest from a folder of logs,
its kinds and settings from sidecars, native formats and flags, and the one-line refusals."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from roboball.cli.main import main
from roboball.errors import RoboballError
from roboball.ingest.manifest import read_manifest
from roboball.ingest.survey import survey, write_manifest

NATIVE = {  # the authors' formats (recordings.md), a few samples each
    "steering_static_stand_response.csv": "steer_timestamp,pend_angle\n100.0,0.3\n100.01,0.29\n",
    "dynamic_data.csv": "timestamp,ball_roll.position,ball_roll.velocity\n0,-0.4,0.0\n10000000,-0.39,0.1\n",
    "trimmed_1.csv": "timestamp,ball_roll.position,roll_joint.position\n0,-0.36,0.39\n20000000,-0.35,0.38\n",
}


def logs(tmp_path: Path, extra: dict | None = None) -> Path:
    d = tmp_path / "logs"
    d.mkdir()
    for name, text in {**NATIVE, **(extra or {})}.items():
        (d / name).write_text(text)
    return d


def test_native_logs_are_recognised_and_a_shell_log_needs_a_pressure_or_unknown(tmp_path):
    d = logs(tmp_path)
    with pytest.raises(RoboballError) as info:
        survey(d)
    assert str(info.value) == (f"{d / 'dynamic_data.csv'}: a shell_rock log without a shell pressure (none in a "
                               "sidecar); give --pressure-kpa P (gauge, kPa), or --pressure-kpa unknown if it was "
                               "not logged")
    rows = {r["file"]: r for r in survey(d, pressure_kpa="unknown", steer_joint="unknown", name="lab")}
    assert {f: r["kind"] for f, r in rows.items()} == {"dynamic_data.csv": "shell_rock",
                                                        "steering_static_stand_response.csv": "steer_stand",
                                                        "trimmed_1.csv": "steer_coupled"}
    assert rows["dynamic_data.csv"]["steer_joint"] == "unknown" and rows["trimmed_1.csv"]["steer_joint"] == ""
    assert rows["steering_static_stand_response.csv"]["pressure_kpa"] == ""     # a stand has no shell pressure
    assert {r["campaign"] for r in rows.values()} == {"lab"}


def test_sidecars_come_first_and_flags_fill_in_only_what_files_do_not_say(tmp_path):
    d = logs(tmp_path, {"r1.csv": "time_s,drive_rate_rad_s\n0,0\n0.01,0.1\n"})
    (d / "r1.json").write_text(json.dumps({"kind": "ramp", "pressure_kpa": 13.8}))
    (d / "dynamic_data.json").write_text(json.dumps({"pressure_kpa": 6.9, "steer_joint": "free"}))
    rows = {r["file"]: r for r in survey(d, pressure_kpa="20.7", kind="shell_rock", ramp_angle_deg=12)}
    assert (rows["r1.csv"]["kind"], rows["r1.csv"]["pressure_kpa"], rows["r1.csv"]["ramp_angle_deg"]) == \
        ("ramp", "13.8", "12")
    assert (rows["dynamic_data.csv"]["pressure_kpa"], rows["dynamic_data.csv"]["steer_joint"]) == ("6.9", "free")
    # --kind shell_rock is one a coupled log may be read as, but no steer log
    assert rows["trimmed_1.csv"]["kind"] == "shell_rock" and rows["trimmed_1.csv"]["pressure_kpa"] == "20.7"
    assert rows["steering_static_stand_response.csv"]["kind"] == "steer_stand"


def test_what_cannot_be_told_is_refused_naming_the_file(tmp_path):
    d = logs(tmp_path, {"plain.csv": "time_s,steer_angle_rad\n0,0.1\n0.01,0.1\n"})
    with pytest.raises(RoboballError, match=r"plain.csv: kind unknown \(no sidecar plain.json with a kind\); give --kind"):
        survey(d, pressure_kpa="unknown")
    (d / "odd.csv").write_text("stamp,angle\n0,1\n")
    with pytest.raises(RoboballError, match=r"odd.csv: line 1 \(header\): not a recording"):
        survey(d, pressure_kpa="unknown", kind="steer_stand")
    with pytest.raises(RoboballError, match="--pressure-kpa '2 psi': give the gauge pressure in kPa"):
        survey(d, pressure_kpa="2 psi")


def test_the_written_manifest_is_the_one_the_workflow_reads_and_is_not_overwritten(tmp_path, capsys):
    d = logs(tmp_path)
    assert main(["manifest", str(d), "--pressure-kpa", "unknown", "--steer-joint", "unknown"]) == 0
    assert f"wrote {d / 'MANIFEST.csv'} (3 recordings)" in capsys.readouterr().out
    m = read_manifest(d)
    assert m["dynamic_data"]["pressure_kpa"] == "unknown" and m["dynamic_data"]["steer_joint"] == "unknown"
    assert m["trimmed_1"]["kind"] == "steer_coupled"
    before = (d / "MANIFEST.csv").read_text()
    assert main(["manifest", str(d), "--pressure-kpa", "6.9"]) == 2
    err = capsys.readouterr().err
    assert err.strip() == f"roboball: error: {d / 'MANIFEST.csv'}: exists; give --force to replace it"
    assert (d / "MANIFEST.csv").read_text() == before
    assert main(["manifest", str(d), "--pressure-kpa", "6.9", "--force"]) == 0
    assert read_manifest(d)["dynamic_data"]["pressure_kpa"] == "6.9"
    # nothing is written when the workflow's reader would refuse the rows
    with pytest.raises(Exception):
        write_manifest(d, [{"file": "missing.csv", "kind": "steer_stand"}], force=True)
    assert read_manifest(d)["dynamic_data"]["pressure_kpa"] == "6.9" and not list(d.glob(".MANIFEST*"))


def test_a_manifest_can_live_outside_a_folder_that_must_stay_as_it_is(tmp_path, capsys):
    """--out FILE: the logs' folder (an archive, a read-only share) is left byte for byte as it
    was; the manifest's paths stay relative to it, and the workflow reads it through
    `campaign_manifest` (make figures RAW=DIR MANIFEST=FILE)."""
    from roboball.pipeline.plan import Campaign
    d = logs(tmp_path)
    before = sorted((p.name, p.read_bytes()) for p in d.iterdir())
    out = tmp_path / "elsewhere" / "lab.csv"
    out.parent.mkdir()
    assert main(["manifest", str(d), "--pressure-kpa", "unknown", "--out", str(out)]) == 0
    assert f"next: make figures RAW={d} MANIFEST={out}" in capsys.readouterr().out
    assert sorted((p.name, p.read_bytes()) for p in d.iterdir()) == before
    assert sorted(p.name for p in out.parent.iterdir()) == ["lab.csv"]      # no check file left
    assert read_manifest(d, out)["trimmed_1"]["src"] == str(d / "trimmed_1.csv")
    camp = Campaign.from_config({"campaign_dir": str(d), "campaign_manifest": str(out)})
    assert set(camp.recordings) == {"steering_static_stand_response", "dynamic_data", "trimmed_1"}
    assert main(["manifest", str(d), "--pressure-kpa", "6.9", "--out", str(tmp_path / "none" / "m.csv")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_a_read_only_folder_of_logs_is_told_about_out(tmp_path, monkeypatch, capsys):
    """Where DIR cannot be written (an archive, a share), the one-line error says how to keep the
    manifest elsewhere.  (Checked with os.access, which a root user always passes: patched here.)"""
    import os
    d = logs(tmp_path)
    real_access = os.access
    monkeypatch.setattr(os, "access", lambda p, mode: False if Path(p) == d else real_access(p, mode))
    assert main(["manifest", str(d), "--pressure-kpa", "unknown"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"roboball: error: {d / 'MANIFEST.csv'}: the folder {d} is not writable; give --out FILE to keep "
                   "the manifest elsewhere (make figures RAW=DIR MANIFEST=FILE)")
    assert main(["manifest", str(d), "--pressure-kpa", "unknown", "--out", str(tmp_path / "m.csv")]) == 0
