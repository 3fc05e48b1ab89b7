"""Pressure regressions zeta(p) = a exp(b p) and omega_n(p) = c + d p: exactness, interval
coverage over a fixed set of 100 seeds, bands, and the table built from a decay table."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from roboball.errors import RoboballError
from roboball.regress import fit_omega_linear, fit_regressions, fit_zeta_exp, regression_table

PRESSURES = np.repeat([6.9, 10.3, 13.8, 17.2, 20.7], 3)  # 3 releases per pressure
A, B, C, D = 0.30, -0.04, 2.30, 0.06  # zeta_a (1), zeta_b (1/kPa), omega_n_c (rad/s), omega_n_d (rad/s/kPa)
SEEDS = list(range(100))  # fixed


def test_noise_free_recovery():
    z = A * np.exp(B * PRESSURES)
    w = C + D * PRESSURES
    fz = fit_zeta_exp(PRESSURES, z)
    fw = fit_omega_linear(PRESSURES, w)
    assert fz.value("zeta_a") == pytest.approx(A, rel=1e-9)
    assert fz.value("zeta_b") == pytest.approx(B, rel=1e-9)
    assert fw.value("omega_n_c") == pytest.approx(C, rel=1e-12)
    assert fw.value("omega_n_d") == pytest.approx(D, rel=1e-12)
    np.testing.assert_allclose(fz.predict([0.0, 10.0]), [A, A * np.exp(10 * B)], rtol=1e-9)


def _coverage(weighted: bool):
    hits = dict(zeta_a=0, zeta_b=0, omega_n_c=0, omega_n_d=0)
    band_hits = []
    truth = dict(zeta_a=A, zeta_b=B, omega_n_c=C, omega_n_d=D)
    for seed in SEEDS:
        rng = np.random.default_rng(seed)
        z_true = A * np.exp(B * PRESSURES)
        z_sd = 0.06 * z_true  # damping ratios scatter by about 6% between releases
        z = z_true + rng.normal(0.0, z_sd)
        w_sd = np.full(PRESSURES.size, 0.04)
        w = C + D * PRESSURES + rng.normal(0.0, w_sd)
        fz = fit_zeta_exp(PRESSURES, z, z_sd if weighted else None)
        fw = fit_omega_linear(PRESSURES, w, w_sd if weighted else None)
        for fit in (fz, fw):
            for name in fit.names:
                lo, hi = fit.ci(name)
                hits[name] += lo <= truth[name] <= hi
        grid = np.linspace(6.9, 20.7, 9)
        lo, hi = fz.band(grid)
        band_hits.append(np.mean((lo <= A * np.exp(B * grid)) & (A * np.exp(B * grid) <= hi)))
    return hits, float(np.mean(band_hits))


def test_ci95_coverage_weighted():
    """Acceptance: with the per-release errors as weights the 95% intervals cover the true
    a, b, c, d in at least 90 of the 100 fixed seeds."""
    hits, band = _coverage(weighted=True)
    assert all(v >= 90 for v in hits.values()), hits
    assert all(v <= 100 for v in hits.values())
    assert band >= 0.88


def test_ci95_coverage_unweighted_homoscedastic():
    hits = dict(zeta_a=0, zeta_b=0, omega_n_c=0, omega_n_d=0)
    truth = dict(zeta_a=A, zeta_b=B, omega_n_c=C, omega_n_d=D)
    for seed in SEEDS:
        rng = np.random.default_rng(10_000 + seed)
        z = A * np.exp(B * PRESSURES) + rng.normal(0.0, 0.01, PRESSURES.size)
        w = C + D * PRESSURES + rng.normal(0.0, 0.04, PRESSURES.size)
        for fit in (fit_zeta_exp(PRESSURES, z), fit_omega_linear(PRESSURES, w)):
            for name in fit.names:
                lo, hi = fit.ci(name)
                hits[name] += lo <= truth[name] <= hi
    assert all(v >= 90 for v in hits.values()), hits


def test_intervals_are_not_trivially_wide():
    rng = np.random.default_rng(7)
    z = A * np.exp(B * PRESSURES) * (1 + 0.06 * rng.normal(size=PRESSURES.size))
    fz = fit_zeta_exp(PRESSURES, z)
    lo, hi = fz.ci("zeta_b")
    assert hi - lo < 0.5 * abs(B)  # informative: the slope's sign is resolved
    assert hi < 0
    assert fz.dof == PRESSURES.size - 2 and fz.t_quantile() == pytest.approx(2.160, abs=1e-3)


def test_prediction_band_wider_than_confidence_band():
    rng = np.random.default_rng(1)
    w = C + D * PRESSURES + rng.normal(0.0, 0.04, PRESSURES.size)
    fw = fit_omega_linear(PRESSURES, w)
    p = np.array([5.0, 13.8, 25.0])
    clo, chi = fw.band(p, kind="confidence")
    plo, phi = fw.band(p, kind="prediction")
    assert np.all(phi - plo > chi - clo)
    assert (chi - clo)[1] < (chi - clo)[0] and (chi - clo)[1] < (chi - clo)[2]  # narrowest mid-range
    with pytest.raises(ValueError):
        fw.band(p, kind="other")


def test_prediction_band_covers_new_measurements():
    """Averaged over fits, 95% of new measurements fall inside the 95% prediction band."""
    from scipy.stats import norm

    p = np.array([6.9, 13.8, 20.7])
    mu = C + D * p
    probs = []
    for seed in SEEDS:
        rng = np.random.default_rng(20_000 + seed)
        fw = fit_omega_linear(PRESSURES, C + D * PRESSURES + rng.normal(0.0, 0.04, PRESSURES.size))
        lo, hi = fw.band(p, kind="prediction")
        probs.append(norm.cdf((hi - mu) / 0.04) - norm.cdf((lo - mu) / 0.04))
    assert 0.92 < float(np.mean(probs)) < 0.98


def _decay_df(seed=0, with_se=True):
    rng = np.random.default_rng(seed)
    z = A * np.exp(B * PRESSURES) * (1 + 0.05 * rng.normal(size=PRESSURES.size))
    w = C + D * PRESSURES + rng.normal(0, 0.03, PRESSURES.size)
    df = pd.DataFrame({"pressure_kpa": PRESSURES, "zeta": z, "omega_n_rad_s": w})
    if with_se:
        df["zeta_se"] = 0.05 * z
        df["omega_n_se_rad_s"] = 0.03
    # a stand run without pressure is ignored
    df.loc[len(df)] = {"pressure_kpa": np.nan, "zeta": 0.1, "omega_n_rad_s": 5.6,
                       **({"zeta_se": 0.01, "omega_n_se_rad_s": 0.01} if with_se else {})}
    return df


def test_regression_table():
    table = regression_table(_decay_df())
    assert list(table["name"]) == ["zeta_a", "zeta_b", "omega_n_c", "omega_n_d"]
    assert list(table["unit"]) == ["1", "1/kPa", "rad/s", "rad/s/kPa"]
    assert (table["n_points"] == 15).all()
    truth = [A, B, C, D]
    for (_, row), tv in zip(table.iterrows(), truth):
        assert row["ci95_low"] < row["value"] < row["ci95_high"]
        assert row["ci95_low"] - 3 * row["se"] < tv < row["ci95_high"] + 3 * row["se"]
    regs = fit_regressions(_decay_df())
    lo, hi = regs.zeta_band([6.9, 20.7])
    assert np.all(lo < hi)
    lo, hi = regs.omega_n_band([13.8], kind="prediction")
    assert lo[0] < C + D * 13.8 < hi[0]


def test_weights_all_or_nothing():
    df = _decay_df(with_se=True)
    df.loc[3, "zeta_se"] = np.nan
    regs = fit_regressions(df)
    assert regs.zeta.se is None and regs.omega_n.se is not None
    unweighted = fit_regressions(df, weighted=False)
    assert unweighted.omega_n.se is None


def test_regression_errors():
    with pytest.raises(RoboballError, match="need at least 3 points at 2 or more pressures"):
        fit_zeta_exp([13.8, 13.8, 13.8], [0.1, 0.11, 0.12])
    with pytest.raises(RoboballError, match="must be positive"):
        fit_zeta_exp([6.9, 10.3, 13.8], [0.1, -0.01, 0.12])
    with pytest.raises(RoboballError, match="missing column"):
        regression_table(pd.DataFrame({"pressure_kpa": [1.0], "zeta": [0.1]}))
