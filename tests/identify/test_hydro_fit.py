"""The hydroelastic calibration's fit (roboball.identify.shell.hydro) on a synthetic shell whose
answer is known: a smooth "Drake" with the shape Drake shows (omega_n falls with the modulus,
zeta grows with the dissipation and falls with the modulus), plus a bias the grid's surrogate
cannot see, must be inverted to the true modulus and dissipation, with intervals that hold them."""
import math

import numpy as np
import pandas as pd
import pytest

from roboball.errors import RoboballError
from roboball.identify.shell import hydro as hy
from roboball.physics import shell as sl


def synthetic(modulus, dissipation, wobble=0.0):
    """zeta, omega_n of a made-up shell; `wobble` adds a ripple the cubic surfaces cannot follow."""
    x, y = math.log(modulus), math.log(dissipation)
    zeta = 0.33 * dissipation * (modulus / 1e4) ** -0.45 * (1 + wobble * math.sin(3 * x))
    omega = (3.2 - 0.17 * (x - math.log(1e4)) + 0.01 * y) * (1 + wobble * math.cos(2 * x + y))
    return zeta, omega


def grid_table(wobble):
    rows = []
    for m in np.geomspace(1e4, 3e6, 8):
        for d in np.geomspace(0.1, 30, 6):
            z, w = synthetic(m, d, wobble)
            rows.append({"hydro_modulus_pa": m, "hydro_dissipation_s_m": d, "zeta": z, "omega_n_rad_s": w})
    rows.append({"hydro_modulus_pa": 1e4, "hydro_dissipation_s_m": 50.0, "zeta": 0.95, "omega_n_rad_s": 0.5})
    rows.append({"hydro_modulus_pa": 1e4, "hydro_dissipation_s_m": 0.05, "zeta": float("nan"), "omega_n_rad_s": float("nan")})
    return pd.DataFrame(rows)


def target_at(modulus, dissipation, wobble, n=3, spread=0.01):
    z, w = synthetic(modulus, dissipation, wobble)
    k = np.arange(n) - (n - 1) / 2
    return pd.DataFrame({"zeta": z * (1 + spread * k), "zeta_se": 0.002, "omega_n_rad_s": w * (1 + 0.5 * spread * k),
                         "omega_n_se_rad_s": 0.005, "pressure_kpa": 13.8})


@pytest.mark.parametrize("true", [(3.0e4, 0.8), (2.0e5, 3.0), (1.5e6, 10.0)])
def test_recovers_known_parameters_through_the_evaluator(true):
    wobble = 0.02                                  # the surrogate is 2% off; Drake-in-the-loop corrects it
    grid = grid_table(wobble)
    sur = hy.Surrogate.fit(grid)
    usable = np.isfinite(grid.zeta) & (grid.zeta < hy.ZETA_MAX)
    assert sur.n_points == usable.sum() < len(grid)      # the NaN and the overdamped (bound) runs are left out
    target = hy.Target.of(target_at(*true, wobble))
    calls = []

    def evaluate(m, d):
        calls.append((m, d))
        return synthetic(m, d, wobble)

    cal = hy.calibrate(sur, target, evaluate, tol=0.002, max_evals=4)
    assert cal.best.error(target) <= 0.002
    assert cal.best.modulus == pytest.approx(true[0], rel=0.05)
    assert cal.best.dissipation == pytest.approx(true[1], rel=0.05)
    assert (cal.best.modulus, cal.best.dissipation) in calls       # reported values were evaluated
    iv = hy.intervals(sur, target, cal, draws=200)
    assert iv["modulus_low"] < true[0] < iv["modulus_high"]
    assert iv["dissipation_low"] < true[1] < iv["dissipation_high"]
    assert not iv["at_bound"]


def test_weakly_identified_modulus_gets_a_wide_interval():
    """Where omega_n hardly follows the modulus the modulus interval must be wide, not pretend."""
    def flat(m, d):
        z, _ = synthetic(m, d)
        return z, 3.0 - 0.002 * math.log(m)          # omega_n nearly independent of the modulus

    rows = [{"hydro_modulus_pa": m, "hydro_dissipation_s_m": d, "zeta": flat(m, d)[0], "omega_n_rad_s": flat(m, d)[1]}
            for m in np.geomspace(1e4, 3e6, 8) for d in np.geomspace(0.1, 30, 6)]
    sur = hy.Surrogate.fit(pd.DataFrame(rows))
    pts = pd.DataFrame({"zeta": [0.10, 0.11, 0.12], "zeta_se": 0.002, "omega_n_rad_s": [2.970, 2.980, 2.975],
                        "omega_n_se_rad_s": 0.005})
    target = hy.Target.of(pts)
    cal = hy.calibrate(sur, target, flat, tol=0.01)
    iv = hy.intervals(sur, target, cal, draws=200)
    assert iv["modulus_high"] / iv["modulus_low"] > 10
    assert abs(cal.best.omega_n / target.omega_n - 1) < 0.01


def test_unreachable_target_sits_on_the_grid_bound_and_says_so():
    sur = hy.Surrogate.fit(grid_table(0.0))
    pts = target_at(1e4, 1.0, 0.0)
    pts["omega_n_rad_s"] *= 1.2                     # faster than the softest grid shell can rock
    target = hy.Target.of(pts)
    cal = hy.calibrate(sur, target, synthetic, tol=0.01)
    iv = hy.intervals(sur, target, cal, draws=100)
    assert iv["at_bound"]
    assert cal.best.modulus == pytest.approx(1e4, rel=1e-3)
    assert cal.best.error(target) > 0.1


def test_target_interval_counts_release_scatter():
    one = hy.Target.of(target_at(1e5, 1.0, 0.0, n=1))
    three = hy.Target.of(target_at(1e5, 1.0, 0.0, n=3, spread=0.05))
    assert one.zeta_se == pytest.approx(0.002)
    assert three.zeta_se > 0.05 * three.zeta / math.sqrt(3) * 0.9
    with pytest.raises(RoboballError):
        hy.Target.of(target_at(1e5, 1.0, 0.0).assign(zeta=float("nan")))


def test_volume_law_recovers_a_power_law():
    weight = 405.0
    p = np.array([6.9, 10.3, 13.8, 17.2, 20.7])
    v = sl.contact_volume_power(p * 1e3, 3e-3, 13.8e3, -1.3)
    e = sl.modulus_of_volume(weight, v)
    fits = pd.DataFrame({"pressure_kpa": p, "hydro_modulus_pa": e, "hydro_modulus_ci95_low_pa": e * 0.9,
                         "hydro_modulus_ci95_high_pa": e * 1.1})
    law = hy.volume_law(fits, weight)
    assert law["exponent"] == pytest.approx(-1.3, abs=1e-6)
    assert sl.contact_volume_power(13.8e3, law["v_ref_m3"], law["p_ref_pa"], law["exponent"]) == pytest.approx(3e-3)
    assert sl.volume_of_modulus(weight, sl.modulus_of_volume(weight, 2e-3)) == pytest.approx(2e-3)


def test_a_run_that_sinks_steps_back_towards_the_last_good_one():
    """Drake's softest shells sink through the ground (no decay): the fit must step back, not fail.
    Here "Drake" is the surrogate's shell 1.3 times stiffer, so the answer (1.54e4 Pa) lies below
    where it sinks (1.6e4 Pa) and the first Newton step lands there."""
    sur = hy.Surrogate.fit(grid_table(0.0))
    target = hy.Target.of(target_at(2.0e4, 0.5, 0.0))

    def sinks_below(m, d):
        return (float("nan"), float("nan")) if m < 1.6e4 else synthetic(1.3 * m, d)

    cal = hy.calibrate(sur, target, sinks_below, tol=0.001, max_evals=6)
    assert cal.failed and all(e.modulus < 1.6e4 for e in cal.failed)
    assert 1.6e4 <= cal.best.modulus < 2.0e4
    assert cal.best.error(target) < 0.1
    with pytest.raises(RoboballError, match="sinks"):
        hy.calibrate(sur, target, lambda m, d: (float("nan"), float("nan")))


def test_volume_law_at_one_pressure_gives_its_volume_and_no_exponent():
    fits = pd.DataFrame({"pressure_kpa": [13.8], "hydro_modulus_pa": [1e4], "hydro_modulus_ci95_low_pa": [9e3],
                         "hydro_modulus_ci95_high_pa": [1.1e4]})
    law = hy.volume_law(fits, 400.0)
    assert law["v_ref_m3"] == pytest.approx(0.04) and math.isnan(law["exponent"])


def test_a_pinned_modulus_stops_once_the_steps_no_longer_matter():
    """With omega_n out of reach the modulus sits on the grid's softest edge and only the
    dissipation moves; once the Newton step would change zeta by under a tenth of the tolerance,
    no further (Drake) run is made: the campaign's hydro fits spent their last one or two runs each
    on dissipation changes of 0.004-0.09%."""
    sur = hy.Surrogate.fit(grid_table(0.0))
    pts = target_at(1e4, 1.0, 0.0)
    pts["omega_n_rad_s"] *= 1.2                     # faster than the softest grid shell can rock
    target = hy.Target.of(pts)
    calls = []

    def drake(m, d):                                # 3% more damping than the grid says, 1% ripple
        calls.append((m, d))
        z, w = synthetic(m, d, 0.01)
        return 1.03 * z, w

    cal = hy.calibrate(sur, target, drake, tol=0.01, max_evals=8)
    assert cal.best.modulus == pytest.approx(1e4, rel=1e-3)
    assert abs(cal.evaluations[-1].zeta / target.zeta - 1) < 0.01     # the dissipation matched zeta
    assert 2 <= len(calls) <= 4, calls                      # not all eight runs
    steps = np.diff(np.log([d for _, d in calls]))
    assert abs(steps[-1]) > 1e-3                             # the last run made was still a step that mattered
