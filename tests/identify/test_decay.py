"""Decay extraction: damping ratio and frequency recovered from realistic synthetic logs
(irregular 80-100 Hz sampling, gaps, duplicate stamps, noise, 1 mrad quantisation), the
log-decrement cross-checks, dry-friction signature, and the real logs."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from roboball.identify.shell.decay import DECAY_COLUMNS, decay_table, extract_decay
from roboball.identify.shell.log_decrement import log_decrement_zeta
from roboball.errors import RoboballError
from roboball.ingest.importers import read_any
from roboball.ingest.recording import Recording
from roboball.ingest.releases.find import find_releases
from roboball.testbed.synthetic import synthetic_release_log

from conftest import REAL_DATA as REAL
STEER = REAL / "steering_static_stand_response.csv"
SHELL = REAL / "dynamic_data.csv"
needs_real = pytest.mark.skipif(not (STEER.exists() and SHELL.exists()), reason=f"real logs not found in {REAL}")

LOGGING = dict(rate_hz=(80.0, 100.0), gap_probability=0.01, max_gap_s=0.05, duplicate_probability=0.003,
               noise=0.0005, quantum=0.001)


@pytest.mark.parametrize("omega_n", [2.0, 3.5, 6.0])
@pytest.mark.parametrize("zeta", [0.03, 0.06, 0.10, 0.15, 0.25])
def test_acceptance_single_release_within_2_percent(zeta, omega_n):
    seed = int(zeta * 1000 + omega_n * 10)
    offset = 0.5 if seed % 2 else -0.4
    t, y, truth = synthetic_release_log([dict(offset=offset, zeta=zeta, omega_n=omega_n, hold_s=0.8)],
                                        rest=-0.035, seed=seed, **LOGGING)
    assert np.any(np.diff(t) == 0) or LOGGING["duplicate_probability"] * len(t) < 3
    assert np.diff(t).max() > 0.03  # there are gaps
    (rel,) = find_releases(t, y, "steer_stand")
    res = extract_decay(t, y, rel)
    omega_d = omega_n * math.sqrt(1 - zeta ** 2)
    assert res.zeta == pytest.approx(zeta, rel=0.02)
    assert res.omega_n == pytest.approx(omega_n, rel=0.02)
    assert res.omega_d == pytest.approx(omega_d, rel=0.02)
    # the errors are honest: the truth lies within 4 standard errors
    assert abs(res.zeta - zeta) < 4 * res.zeta_se + 1e-4
    assert abs(res.omega_n - omega_n) < 4 * res.omega_n_se + 1e-4
    assert res.rest == pytest.approx(-0.035, abs=1e-3)
    assert res.amplitude0 == pytest.approx(abs(offset) / math.sqrt(1 - zeta ** 2), rel=0.03)
    assert res.rmse == pytest.approx(math.sqrt(0.0005 ** 2 + 0.001 ** 2 / 12), rel=0.25)
    # log-decrement cross-check agrees with the fit for a viscous oscillator
    assert res.zeta_logdec == pytest.approx(zeta, rel=0.08)
    assert res.n_cycles > 1.5


def test_acceptance_three_releases_in_one_file():
    specs = [dict(offset=0.6, zeta=0.05, omega_n=5.5, hold_s=0.6),
             dict(offset=-0.9, zeta=0.12, omega_n=3.0, hold_s=1.0),
             dict(offset=0.3, zeta=0.22, omega_n=2.2, hold_s=0.7)]
    t, y, truth = synthetic_release_log(specs, rest=0.011, seed=42, **LOGGING)
    rec = Recording(pd.DataFrame({"time_s": t, "pipe_angle_rad": y}), {"kind": "shell_rock", "pressure_kpa": 13.8})
    df = decay_table(rec)
    assert list(df.columns) == DECAY_COLUMNS
    assert len(df) == 3
    for (_, row), spec in zip(df.iterrows(), specs):
        assert row["zeta"] == pytest.approx(spec["zeta"], rel=0.02)
        assert row["omega_n_rad_s"] == pytest.approx(spec["omega_n"], rel=0.02)
        assert row["omega_d_rad_s"] == pytest.approx(spec["omega_n"] * math.sqrt(1 - spec["zeta"] ** 2), rel=0.02)
        assert row["pressure_kpa"] == 13.8 and row["kind"] == "shell_rock"
        assert row["zeta_se"] > 0 and row["omega_n_se_rad_s"] > 0
    assert list(df["release"]) == [1, 2, 3]


def test_standard_errors_are_calibrated():
    """Over repeated noisy runs the spread of the estimates matches the reported errors."""
    zs, ses = [], []
    for seed in range(12):
        t, y, _ = synthetic_release_log([dict(offset=0.05, zeta=0.08, omega_n=4.0)], seed=seed,
                                        noise=0.002, quantum=0.0)
        (rel,) = find_releases(t, y, "steer_stand")
        res = extract_decay(t, y, rel)
        zs.append(res.zeta)
        ses.append(res.zeta_se)
    ratio = np.std(zs, ddof=1) / np.mean(ses)
    assert 0.5 < ratio < 2.0
    assert abs(np.mean(zs) - 0.08) < 3 * np.std(zs, ddof=1) / math.sqrt(len(zs)) + 1e-3


def _coulomb_decay(A, omega, d, t):
    """Free response with pure dry friction: each half cycle oscillates about +-d and loses
    2 d of amplitude; stops when the amplitude falls below d."""
    y = np.empty_like(t)
    x0, t0, s = A, 0.0, 1.0
    half = math.pi / omega
    for i, ti in enumerate(t):
        while ti > t0 + half and abs(x0) > 3 * d:
            x0 = 2 * s * d - x0
            t0 += half
            s = -s
        if abs(x0) <= 3 * d and ti > t0 + half:
            y[i] = 2 * s * d - x0
        else:
            y[i] = s * d + (x0 - s * d) * math.cos(omega * (ti - t0))
    return y


def test_dry_friction_signature():
    rng = np.random.default_rng(8)
    t = np.cumsum(rng.uniform(0.010, 0.0125, 1200))
    rest = -0.035
    y = rest + np.where(t < 1.0, 0.9, _coulomb_decay(0.9, 5.4, 0.025, t - 1.0))
    y = np.round((y + rng.normal(0, 0.0005, t.size)) / 0.001) * 0.001
    (rel,) = find_releases(t, y, "steer_stand")
    res = extract_decay(t, y, rel)
    assert res.period_s == pytest.approx(2 * math.pi / 5.4, rel=0.02)
    assert res.zeta_late > 1.5 * res.zeta_early  # amplitude falls linearly, not geometrically
    assert res.residual_lag1 > 0.5 and res.se_inflation > 1.5  # model error is smooth; errors inflated


def test_log_decrement_formula():
    delta = 0.4  # per cycle
    vals = [(-1) ** k * math.exp(-delta / 2 * k) for k in range(8)]
    assert log_decrement_zeta(vals) == pytest.approx(delta / math.sqrt(4 * math.pi ** 2 + delta ** 2), rel=1e-9)
    assert math.isnan(log_decrement_zeta([1.0, -0.5]))


@needs_real
def test_real_steer_decay():
    rec = read_any(STEER)
    df = decay_table(rec)
    assert len(df) == 3
    assert df["period_s"].between(1.15, 1.25).all()  # README: swing periods 1.15-1.25 s
    assert df["zeta"].between(0.03, 0.2).all()
    # dry friction: the pendulum stops abruptly; damping grows as the swings shrink
    assert (df["zeta_late"] > df["zeta_early"]).all()
    assert (df["se_inflation"] > 2).all()
    assert df["rest_rad"].between(-0.05, -0.015).all()


@needs_real
def test_real_shell_decay():
    rec = read_any(SHELL)
    df = decay_table(rec)
    assert len(df) == 1
    row = df.iloc[0]
    assert row["period_early_s"] == pytest.approx(2.0, abs=0.15)  # README: about 2.0 s first
    assert 1.5 < row["period_s"] < 2.6
    assert 0.05 < row["zeta"] < 0.5
    assert math.isnan(row["pressure_kpa"])  # not logged with the real file


def test_decay_table_errors():
    t = np.arange(0, 10, 0.01)
    rec = Recording(pd.DataFrame({"time_s": t, "steer_angle_rad": np.full(t.size, -0.035)}),
                    {"kind": "steer_stand", "pressure_kpa": None}, Path("quiet.csv"))
    with pytest.raises(RoboballError, match=r"^quiet\.csv: steer_angle_rad: no release found"):
        decay_table(rec)
    ramp = Recording(pd.DataFrame({"time_s": t, "drive_rate_rad_s": t}), {"kind": "ramp", "pressure_kpa": 10.0},
                     Path("ramp.csv"))
    with pytest.raises(RoboballError, match="needs a free oscillation"):
        decay_table(ramp)


@settings(max_examples=25, deadline=None)
@given(
    zeta=st.floats(0.01, 0.5),
    omega=st.floats(1.0, 9.0),
    offset=st.floats(0.01, 1.2),
    sign=st.sampled_from([-1.0, 1.0]),
    noise=st.sampled_from([0.0, 1e-4, 1e-3, 5e-3]),
    quantum=st.sampled_from([0.0, 1e-3]),
    seed=st.integers(0, 10_000),
)
def test_property_decay_never_crashes(zeta, omega, offset, sign, noise, quantum, seed):
    t, y, truth = synthetic_release_log([dict(offset=sign * offset, zeta=zeta, omega_n=omega, free_s=12.0)],
                                        seed=seed, noise=noise, quantum=quantum)
    for rel in find_releases(t, y, "steer_stand"):
        try:
            res = extract_decay(t, y, rel)
        except RoboballError:
            continue
        assert 0.0 <= res.zeta <= 0.95
        assert res.omega_d > 0 and np.isfinite(res.omega_n)
        assert res.t_fit_start_s >= rel.t_release_s and res.t_fit_end_s <= rel.t_end_s + 1e-9
        assert np.isfinite(res.rmse)


# --------------------------------------------------------------------------------------
# Error propagation, residual degrees of freedom and cycle lengths
# --------------------------------------------------------------------------------------
def _omega_n_of(p):
    return p[3] / math.sqrt(1.0 - p[2] ** 2)


def _fd_delta_se(fit, h=1e-7):
    """omega_n's standard error by the delta method with a central-difference gradient."""
    p = np.asarray(fit.params, dtype=float)
    g = np.zeros(5)
    for i in range(5):
        dp = np.zeros(5)
        dp[i] = h * max(1.0, abs(p[i]))
        g[i] = (_omega_n_of(p + dp) - _omega_n_of(p - dp)) / (2 * dp[i])
    return math.sqrt(float(g @ fit.cov @ g))


@pytest.mark.parametrize("zeta", [0.05, 0.3, 0.6])
def test_omega_n_se_matches_finite_difference_delta_method(zeta):
    from roboball.identify.shell.damped_sine import DampedSineFit

    rng = np.random.default_rng(int(zeta * 100))
    L = rng.normal(size=(5, 5)) * 0.01
    cov = L @ L.T + np.diag([1e-6, 1e-4, 4e-4, 1e-4, 1e-3])
    params = np.array([0.01, 0.5, zeta, 4.0, -0.3])
    fit = DampedSineFit(t0=0.0, params=params, cov=cov, rmse=0.001, n=100, rho1=0.0, inflation=1.0, success=True)
    assert fit.omega_n == pytest.approx(4.0 / math.sqrt(1 - zeta ** 2), rel=1e-12)
    assert fit.omega_n_se == pytest.approx(_fd_delta_se(fit), rel=1e-6)
    # zeta's uncertainty alone: se = omega_d zeta / (1 - zeta^2)^1.5 * se(zeta)
    cz = np.zeros((5, 5))
    cz[2, 2] = 0.02 ** 2
    fz = DampedSineFit(t0=0.0, params=params, cov=cz, rmse=0.001, n=100, rho1=0.0, inflation=1.0, success=True)
    assert fz.omega_n_se == pytest.approx(4.0 * zeta / (1 - zeta ** 2) ** 1.5 * 0.02, rel=1e-12)
    assert fz.omega_n_se == pytest.approx(_fd_delta_se(fz), rel=1e-6)


def test_omega_n_se_of_a_real_fit_matches_finite_difference():
    t, y, _ = synthetic_release_log([dict(offset=0.4, zeta=0.35, omega_n=3.0)], seed=5, noise=0.003, quantum=0.0)
    (rel,) = find_releases(t, y, "steer_stand")
    res = extract_decay(t, y, rel)
    assert res.omega_n_se == pytest.approx(_fd_delta_se(res.fit), rel=1e-6)


def test_damped_sine_fit_residual_variance_uses_n_minus_5():
    """Tiny fit (9 points, 5 parameters): cov = s2 (J^T J)^-1 infl^2 with s2 = RSS / (n - 5)."""
    from roboball.identify.shell.damped_sine import damped_sine, fit_damped_sine

    truth = np.array([0.02, 1.0, 0.1, 3.0, -0.1])
    tau = np.linspace(0.0, 4.0, 9)
    rng = np.random.default_rng(4)
    y = damped_sine(tau, *truth) + rng.normal(0.0, 0.01, tau.size)
    fit = fit_damped_sine(tau + 10.0, y, 10.0, truth * 1.02)
    assert fit.n == 9
    p = fit.params
    r = damped_sine(tau, *p) - y
    rss = float(r @ r)
    assert fit.rmse == pytest.approx(math.sqrt(rss / 9), rel=1e-9)
    s2 = rss / (9 - 5)
    J = np.empty((9, 5))
    for i in range(5):
        dp = np.zeros(5)
        dp[i] = 1e-6
        J[:, i] = (damped_sine(tau, *(p + dp)) - damped_sine(tau, *(p - dp))) / 2e-6
    rc = r - r.mean()
    rho = min(max(float(rc[:-1] @ rc[1:]) / float(rc @ rc), 0.0), 0.99)
    infl2 = (1 + rho) / (1 - rho)
    assert fit.inflation ** 2 == pytest.approx(infl2, rel=1e-9)
    np.testing.assert_allclose(fit.cov, np.linalg.inv(J.T @ J) * s2 * infl2, rtol=1e-5, atol=1e-14)


def test_periods_are_full_cycles():
    """On a synthetic viscous release every reported period (first, last, each) is a full
    cycle 2 pi / omega_d, not a half cycle."""
    zeta, omega_n = 0.05, 3.0
    omega_d = omega_n * math.sqrt(1 - zeta ** 2)
    t, y, _ = synthetic_release_log([dict(offset=0.5, zeta=zeta, omega_n=omega_n, hold_s=0.8)],
                                    rest=0.01, seed=3, **LOGGING)
    (rel,) = find_releases(t, y, "steer_stand")
    res = extract_decay(t, y, rel)
    assert len(res.periods_s) >= 3
    assert res.period_early_s == pytest.approx(2 * math.pi / omega_d, rel=0.03)
    assert res.period_late_s == pytest.approx(2 * math.pi / omega_d, rel=0.05)
    np.testing.assert_allclose(res.periods_s, 2 * math.pi / omega_d, rtol=0.05)
    assert res.period_early_s == pytest.approx(res.period_s, rel=0.03)
    rec = Recording(pd.DataFrame({"time_s": t, "pipe_angle_rad": y}), {"kind": "shell_rock", "pressure_kpa": 13.8})
    row = decay_table(rec).iloc[0]
    assert row["period_early_s"] == pytest.approx(2 * math.pi / omega_d, rel=0.03)
