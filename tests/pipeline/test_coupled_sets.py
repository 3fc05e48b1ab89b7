"""The coupled steer test of repeats at a logged pressure (a campaign's coupled runs, issue 46):
every model runs at that pressure and nothing but the held-out diagnosis is fitted to the repeats."""
import json

import numpy as np
import pandas as pd

from roboball.diagnose.coupled import Repeat, run
from roboball.ingest.recording import write_recording
from roboball.pipeline.coupled import steer_coupled
from roboball.sim.coupled import model_spec
from roboball.sim.schedule import ShellLaws

LAWS = ShellLaws(0.23, -0.0386, 2.70, 0.0276)
FRICTION = {"f_w": 0.2, "f_c": 0.45, "sigma": 10.0, "omega_c": 0.1, "n": 1.0}
P_KPA = 10.3


def _recording(path, pipe0, steer0, rate=50.0, duration=3.0):
    """A noiseless coupled run of the injected model at P_KPA, written as a recording."""
    t = np.arange(0.0, duration, 1.0 / rate)
    pred = run(model_spec("injected", P_KPA, LAWS, FRICTION), Repeat(path.stem, t, t * 0 + pipe0, t * 0 + steer0))
    rec = pd.DataFrame({"time_s": t, "pipe_angle_rad": pred["pipe_angle_rad"], "steer_angle_rad": pred["steer_angle_rad"]})
    write_recording(path, rec, {"kind": "steer_coupled", "pressure_kpa": P_KPA})
    return str(path)


def _run(tmp_path, laws: ShellLaws) -> dict:
    recs = [_recording(tmp_path / "c_r1.csv", -0.36, 0.38), _recording(tmp_path / "c_r2.csv", -0.33, 0.35)]
    reg = tmp_path / "reg.csv"
    reg.write_text(f"name,value\nzeta_a,{laws.zeta_a}\nzeta_b,{laws.zeta_b}\nomega_n_c,{laws.omega_n_c}\n"
                   f"omega_n_d,{laws.omega_n_d}\n")
    fric = tmp_path / "steer_majd.json"
    fric.write_text(json.dumps(FRICTION))
    out = {k: str(tmp_path / v) for k, v in dict(out_json="s.json", out_csv="traces.csv", out_png="s2.png",
                                                  table_csv="t.csv", table_md="t.md").items()}
    steer_coupled(recs, str(reg), str(fric), pressure_kpa=P_KPA, campaign="lab", **out)
    return out


def test_repeats_at_a_logged_pressure_run_every_model_there_and_fit_nothing(tmp_path):
    out = _run(tmp_path, LAWS)
    table = pd.read_csv(out["table_csv"])
    # nothing fitted to these repeats but the diagnosis, held out: no refit of the authors'
    # objective, every score a prediction, every pressure the logged one
    assert "ours_nm" not in set(table.model) and (table.model == "diagnosed").sum() == 2
    assert table.held_out.all()
    assert set(table.pressure_kpa.dropna()) == {P_KPA}
    rms = table.groupby("model")[["rms_pipe_angle_rad", "rms_steer_angle_rad"]].max()
    # the model that made the runs, at the logged pressure, reproduces them; the others do not
    assert (rms.loc["injected"] < 1e-3).all()
    assert (rms.drop(["injected", "diagnosed"]).rms_pipe_angle_rad > 0.02).all()
    summary = json.loads(open(out["out_json"]).read())
    assert summary["pressure"] == {"p_kpa": P_KPA, "model": "logged", "folds": {"c_r1": P_KPA, "c_r2": P_KPA}}
    assert summary["authors_objective"] is None and summary["left_out"] == {}
    # the runs are the injected model's own: each fold's diagnosis at the logged pressure keeps it
    assert [f["pressure_kpa"] for f in summary["diagnosed"]] == [P_KPA, P_KPA]
    assert (rms.loc["diagnosed"] < 0.005).all()
    md = open(out["table_md"]).read()
    assert f"Pressure: logged with the recordings, {P_KPA:g} kPa" in md and "Authors' objective" not in md
    assert (tmp_path / "s2.png").stat().st_size > 10000 and (tmp_path / "s2.pdf").is_file()


def test_at_a_logged_pressure_the_hydroelastic_models_run_without_a_regression(tmp_path):
    """Shell laws from releases at one pressure do not depend on it, so an unlogged pressure
    cannot be fitted and the models that need one are left out; a logged one is their input."""
    constant = ShellLaws(float(LAWS.zeta(P_KPA)), 0.0, float(LAWS.omega_n(P_KPA)), 0.0)
    out = _run(tmp_path, constant)
    table = pd.read_csv(out["table_csv"])
    assert {"point", "injected", "hydroelastic", "hydro_half", "authors_nm", "authors_hand", "diagnosed"} == set(table.model)
    assert set(table[table.model.isin(["injected", "hydroelastic", "hydro_half"])].pressure_kpa) == {P_KPA}
    # the same laws at that pressure: the injected shell still reproduces the runs
    assert table[table.model == "injected"].rms_pipe_angle_rad.max() < 1e-3
    summary = json.loads(open(out["out_json"]).read())
    assert summary["pressure"]["model"] == "logged" and summary["pressure"]["laws"] == "pressure-free"
    assert "the hydroelastic models take their modulus from the logged pressure (eq. 10)" in open(out["table_md"]).read()
