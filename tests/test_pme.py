"""Issue 5, acceptance 4: the PME sign convention (a model faster than the robot is positive)."""
import numpy as np
import pytest

from roboball.pipeline.simulation import pme, speed_errors
from roboball.sim.forces import InjectedShell
from roboball.sim.plant import SimSpec
from roboball.sim.scenarios import simulate


def test_pme_by_hand():
    w_e = np.array([0.0, 0.2, 2.0, 4.0])        # first two below the 0.5 rad/s floor: left out
    w_s = np.array([0.3, 0.9, 2.2, 4.4])        # 10% too fast where defined
    assert pme(w_e, w_s) == pytest.approx(10.0)
    assert pme(w_s[2:], w_e[2:]) == pytest.approx(100 * np.mean([(2.0 - 2.2) / 2.2, (4.0 - 4.4) / 4.4]))


def test_unsigned_errors_do_not_cancel_where_eq12_does():
    """A model 2% fast early and 2% slow late scores 0 by eq. 12, 2% by the mean absolute
    point error; the RMS error covers every sample, the ones below the floor too."""
    w_e = np.array([0.1, 1.0, 2.0, 3.0, 4.0])
    w_s = np.array([0.2, 1.02, 2.04, 2.94, 3.92])
    e = speed_errors(w_e, w_s)
    assert e["pme_percent"] == pytest.approx(0.0, abs=1e-12)
    assert e["mape_percent"] == pytest.approx(2.0)
    assert e["rmse_rad_s"] == pytest.approx(np.sqrt(np.mean((w_s - w_e) ** 2)))
    assert speed_errors(w_e, w_e) == {"pme_percent": 0.0, "mape_percent": 0.0, "rmse_rad_s": 0.0}


def test_pme_sign_on_a_run_where_the_answer_is_known():
    """'Recording' = the point-contact robot with extra rolling damping; the undamped point model
    rolls faster, so its PME must be positive, and the recording scored against itself is zero."""
    friction = {"steer": "majd", "drive": "majd"}
    damped = SimSpec(kind="ramp", contact="point", friction=friction,
                     extra_terms=[InjectedShell(k_inject=0.0, c_inject=2.0, steer=False, drive=True)])
    rec = simulate(damped, 0.0, 1.5, sample_rate_hz=100)
    fast = simulate(SimSpec(kind="ramp", contact="point", friction=friction), 0.0, 1.5, sample_rate_hz=100)
    assert pme(rec.drive_rate_rad_s, fast.drive_rate_rad_s) > 2.0
    assert pme(fast.drive_rate_rad_s, rec.drive_rate_rad_s) < -2.0
    assert pme(rec.drive_rate_rad_s, rec.drive_rate_rad_s) == 0.0
