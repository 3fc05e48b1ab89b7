"""Trimmed logs in the diagnosis (diagnosis.md: a recording that starts at, or just after, the
let-go is diagnosed from its first sample, not refused), and the steer_coupled kind in the stages
that do not handle it (one line naming the file, never a traceback)."""
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from conftest import COUPLED, real_file
from roboball.cli.main import main as cli_main
from roboball.diagnose.data import prepare
from roboball.ingest.recording import Recording
from roboball.testbed.synthetic import synthetic_release_log


def _trimmed_shell_log(folder: Path, samples_after: int) -> Path:
    """The real shell log in its native format, cut at its let-go near 33 s (plus a few samples)."""
    lines = real_file("dynamic_data.csv").read_text().splitlines()
    stamps = np.array([int(line.split(",")[0]) for line in lines[1:]])
    i = int(np.searchsorted((stamps - stamps[0]) * 1e-9, 33.0)) + samples_after
    path = folder / "trimmed_shell.csv"
    path.write_text("\n".join([lines[0]] + lines[1 + i:]) + "\n")
    return path


def _cli(args, capsys) -> tuple[int, str, str]:
    try:
        code = cli_main(args)
    except SystemExit as exc:          # argparse usage errors
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err.strip()


@pytest.mark.slow       # the real shell log's diagnosis (about 12 s); run by make test-slow and CI
def test_trimmed_real_shell_log_is_diagnosed_from_its_first_sample(tmp_path, capsys):
    """`roboball diagnose` on the real shell log cut 3 samples after its let-go, kind from the
    flag: a diagnosis, its one release at the first sample; its window (from the first turning
    point after it, as for the whole log) gives the whole log's numbers."""
    path = _trimmed_shell_log(tmp_path, 3)
    out = tmp_path / "diag"
    code, printed, err = _cli(["diagnose", str(path), "--kind", "shell_rock", "--out", str(out), "--no-drake"], capsys)
    assert code == 0, err
    js = json.loads((out / "diagnosis.json").read_text())
    assert js["kind"] == "shell_rock" and js["verdict"] in ("adequate", "augmented", "unexplained")
    (w,) = json.loads((out / "details.json").read_text())["windows"]
    assert w["t_let_go_s"] == 0.0
    assert w["start"] == "turning point" and w["t_release_s"] == pytest.approx(0.96, abs=0.05)
    # the whole log (README): released near 33 s; its baseline misfit is the same window's
    assert js["fit"]["rmse_before"] == pytest.approx(0.2235, abs=0.002)


def test_a_coupled_log_diagnosed_as_shell_rocking_starts_at_its_first_sample(tmp_path):
    """The coupled repeat's pipe angle, diagnosed as shell rocking by flag: one release at its
    first sample, and too few swings follow to start the window anywhere later."""
    from roboball.diagnose import diagnose
    from roboball.diagnose.scored import Settings

    d, js = diagnose(real_file(COUPLED[0]), kind="shell_rock", settings=Settings(max_effects=1))
    (w,) = d.prep.windows
    assert w.release.t_release_s == 0.0 and w.start == "release" and w.t[0] == 0.0
    assert js["kind"] == "shell_rock" and js["fit"]["rmse_after"] <= js["fit"]["rmse_before"]


@pytest.mark.parametrize("samples_after", [0, 3])
def test_a_synthetic_trimmed_log_has_one_window_from_its_first_sample(samples_after):
    spec = dict(offset=0.5, zeta=0.08, omega_n=5.0, move_s=0.0, hold_s=0.0)
    t, y, _ = synthetic_release_log([spec], rest=-0.035, lead_s=0.0, seed=4)
    t, y = t[samples_after:], y[samples_after:]
    rec = Recording(pd.DataFrame({"time_s": t, "steer_angle_rad": y}), {"kind": "steer_stand", "pressure_kpa": None},
                    Path("trimmed.csv"))
    (w,) = prepare(rec).windows
    assert w.release.t_release_s == t[0] and w.release.held_from_s == t[0]
    assert w.start == "turning point" and w.t0 == pytest.approx(t[0] + np.pi / 5.0, abs=0.1)


# --------------------------------------------------------------------------------------------
# steer_coupled: diagnosed and simulated in Drake (issue 27), not by the reduced models nor the
# campaign manifest (the real repeats come from the config's real_data)
# --------------------------------------------------------------------------------------------
def test_a_steer_coupled_recording_is_refused_by_the_reduced_model_diagnosis_by_name():
    from roboball.errors import RoboballError
    rec = Recording(pd.DataFrame({"time_s": [0.0, 0.02], "pipe_angle_rad": [-0.3, -0.29],
                                  "steer_angle_rad": [0.3, 0.3]}),
                    {"kind": "steer_coupled", "pressure_kpa": None}, Path("runs/coupled.csv"))
    with pytest.raises(RoboballError, match=r"^runs/coupled.csv: kind steer_coupled is not supported in the "
                                            r"reduced-model diagnosis yet \(roboball.diagnose.diagnose runs it in Drake\)$"):
        prepare(rec)


def test_diagnosing_a_steer_coupled_log_without_its_friction_fit_is_a_one_line_error(capsys, tmp_path):
    path = real_file(COUPLED[1])
    missing = tmp_path / "no_fit.json"
    regression = tmp_path / "shell_regression.csv"      # present, so the missing fit is what is named
    regression.write_text("name,value\nzeta_a,0.23\nzeta_b,-0.0386\nomega_n_c,2.70\nomega_n_d,0.0276\n")
    code, _, err = _cli(["diagnose", str(path), "--out", str(tmp_path / "d"), "--friction-steer", str(missing),
                         "--regression", str(regression)], capsys)
    assert code != 0 and len(err.splitlines()) == 1, err
    assert f"{missing}: steer friction fit (pipeline rule friction_fit, real steer stand) not found" in err
    assert "give the file with --friction-steer" in err      # what to do about it
    assert "Traceback" not in err
    # and without the regression, that is named first, in one line
    code, _, err = _cli(["diagnose", str(path), "--out", str(tmp_path / "d"), "--friction-steer", str(missing),
                         "--regression", str(tmp_path / "none.csv")], capsys)
    assert code != 0 and len(err.splitlines()) == 1 and "none.csv: shell regression table" in err, err


def test_the_workflow_manifest_takes_steer_coupled_with_or_without_a_pressure(tmp_path):
    from roboball.ingest.manifest import read_manifest
    raw = tmp_path / "raw"
    raw.mkdir()
    (raw / "c.csv").write_text("time_s,pipe_angle_rad,steer_angle_rad\n0,-0.3,0.3\n0.02,-0.29,0.3\n")
    (raw / "d.csv").write_text("time_s,pipe_angle_rad,steer_angle_rad\n0,-0.3,0.3\n0.02,-0.29,0.3\n")
    (raw / "MANIFEST.csv").write_text("file,kind,pressure_kpa\nc.csv,steer_coupled,\nd.csv,steer_coupled,unknown\n")
    m = read_manifest(raw)
    assert (m["c"]["kind"], m["c"]["pressure_kpa"], m["d"]["pressure_kpa"]) == ("steer_coupled", "", "unknown")


def test_steer_coupled_is_a_recorded_kind_with_two_signals():
    from roboball.kinds import MAIN_SIGNAL, PRESSURE_REQUIRED, RECORDED, SECOND_SIGNAL, SIMULATED
    assert "steer_coupled" in RECORDED and "steer_coupled" in SIMULATED
    assert (MAIN_SIGNAL["steer_coupled"], SECOND_SIGNAL["steer_coupled"]) == ("pipe_angle_rad", "steer_angle_rad")
    assert "steer_coupled" not in PRESSURE_REQUIRED
