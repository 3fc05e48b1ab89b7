"""The virtual robot in the experiment the real shell-direction logs were recorded in: the
pendulum free on its steer joint (the authors' coupled repeats; docs/testbed.md, "Against the
real robot with its pendulum free").  Slow: 15 + 3 Drake runs of 3-5 s at the test bed's step."""
import numpy as np
import pytest

from conftest import REAL_DATA
from roboball.diagnose.coupled import read_repeats, rms
from roboball.testbed.physics import load_truth, true_robot, with_com_moved
from roboball.testbed.run import coupled_release

pytestmark = pytest.mark.slow
PRESSURES = (6.9, 10.3, 13.8, 17.2, 20.7)


@pytest.fixture(scope="module")
def repeats():
    files = sorted(REAL_DATA.glob("steer_coupled_*.csv"))
    if len(files) != 3:
        pytest.skip(f"the three coupled repeats not found in {REAL_DATA}")
    return read_repeats(files)


def _run(rep, p_kpa, truth, robot=None):
    return coupled_release(p_kpa, rep.t, rep.pipe[0], rep.steer[0], rep.release_rates(), truth=truth, robot=robot)


@pytest.mark.xfail(strict=True, reason="measured: at its best pressure (6.9 kPa) the test bed as calibrated swings to "
                   "+0.07 rad where the real shell swings to +0.27..+0.33, pipe RMS 0.121, 0.169, 0.131 rad; it has "
                   "no sideways imbalance, which all three real shell-direction logs show (docs/testbed.md)")
def test_the_virtual_robot_follows_the_real_coupled_repeats_within_0_1_rad_at_some_pressure(repeats):
    truth = load_truth()
    worst = {p: max(rms(_run(rep, p, truth), rep)["pipe_angle_rad"] for rep in repeats) for p in PRESSURES}
    assert min(worst.values()) < 0.1, worst


def test_a_2_cm_sideways_imbalance_of_the_pipe_assembly_closes_the_gap_at_10_3_kpa(repeats):
    """The lead docs/testbed.md gives for the next calibration: the test bed's shell as it is,
    the pipe assembly's centre of mass moved 2 cm along its y axis.  Measured: pipe RMS 0.071,
    0.073, 0.035 rad, steer 0.099, 0.091, 0.063; largest pipe angle +0.25..+0.27 (real +0.27..+0.33);
    as built: 0.135, 0.167, 0.130 and +0.04..+0.06."""
    truth = load_truth()
    robot = with_com_moved(true_robot(truth), "pipe_assembly", -0.02)
    for rep in repeats:
        moved, built = _run(rep, 10.3, truth, robot), _run(rep, 10.3, truth)
        err = rms(moved, rep)
        assert err["pipe_angle_rad"] < 0.08 and err["steer_angle_rad"] < 0.11, (rep.name, err)
        assert err["pipe_angle_rad"] < 0.6 * rms(built, rep)["pipe_angle_rad"]
        assert 0.2 < np.max(moved["pipe_angle_rad"]) < 0.35
