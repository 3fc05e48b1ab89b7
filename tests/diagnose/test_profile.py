"""A joint's breakaway gets its 95% interval from the profile likelihood, and the keep rule tests
its zero there (roboball.diagnose.profile; docs/diagnosis.md, Known limits).  Stand-in fits with
a known cost, so each number can be worked out by hand; the real steer log's profile is in the
slow suite (tests/diagnose/test_diagnose.py)."""
from __future__ import annotations

import math
from types import SimpleNamespace

import pytest

from roboball.diagnose import profile
from roboball.diagnose.fit import Problem
from roboball.diagnose.scored import Scored, Settings
from roboball.diagnose.select import Selector
from roboball.metrics import n_eff
from roboball.physics import effects as fx
from roboball.reduced.models import model_for

Q = profile.Q95
TAU_S = fx.LIBRARY["stiction"].params[0]


def test_the_interval_is_the_hull_of_the_values_within_the_quantile_with_its_ends_interpolated():
    pts = [(0.0, 10.0), (0.1, 6.0), (0.2, 2.0), (0.5, 0.0), (1.0, 1.0), (2.0, 8.0)]
    low, high, open_high = profile.interval(pts, 0.5)
    assert low == pytest.approx(0.2 - 0.1 * (Q - 2.0) / (6.0 - 2.0))
    assert high == pytest.approx(1.0 + 1.0 * (Q - 1.0) / (8.0 - 1.0))
    assert not open_high
    # a rough profile: a value inside beyond one outside still belongs to the interval
    low, high, _ = profile.interval(pts[:4] + [(1.0, 5.0), (1.5, 1.0), (2.0, 8.0)], 0.5)
    assert 1.5 < high < 2.0
    # flat to the last value: the data bound it from below only
    low, high, open_high = profile.interval([(0.0, 9.0), (1.0, 0.0), (20.0, 0.5)], 1.0)
    assert open_high and high == 20.0 and 0.0 < low < 1.0
    # the estimate belongs to its interval even where a held fit ended lower than it
    low, high, _ = profile.interval([(0.5, 5.0), (1.0, 0.0), (2.0, 9.0)], 0.5)
    assert low == 0.5


def test_the_grid_surrounds_the_estimate_and_spans_the_range_to_the_bound():
    g = profile.grid(0.6, TAU_S.lo, TAU_S.hi, TAU_S.typical)
    assert g == sorted(g) and 0.0 < g[0] and g[-1] == TAU_S.hi
    assert 0.6 not in g and {0.3, 1.2} <= {round(x, 12) for x in g}
    assert g[0] == pytest.approx(0.1 * TAU_S.typical)
    assert all(x <= TAU_S.hi for x in profile.grid(15.0, TAU_S.lo, TAU_S.hi, TAU_S.typical))


def _stand_in(cost, rss_zero=None, n=1000, k=3, rho1=0.0, x_hat=0.5):
    """A selector on the steer stand whose held fits cost `cost(x)` (RSS at breakaway x), the final
    Coulomb + stiction fit at `x_hat` (RSS `cost(x_hat)`) and the fit without the stiction."""
    model = model_for("steer_stand")

    def problem(effects, values):
        return Problem(effects=tuple(effects), values=dict(values), free=["viscous_c", "stiction.tau_s"], masks={})

    def fit(problems, max_iter):
        for p in problems:
            p.rss, p.n = cost(p.values["stiction.tau_s"]), n

    def scored(effects, rss):
        prob = Problem(effects=effects, values={"stiction.tau_s": x_hat, "stiction.v_s": fx.V_STRIBECK},
                       free=[f"p{i}" for i in range(k)], masks={})
        prob.rss, prob.n = rss, n
        return Scored(effects=effects, full=prob, rho1=rho1)

    sc = scored(("coulomb_friction", "stiction"), cost(x_hat))
    without = scored(("coulomb_friction",), rss_zero) if rss_zero is not None else None
    sel = SimpleNamespace(model=model, s=Settings(), full_problem=problem, engine=SimpleNamespace(fit=fit),
                          fit_of=lambda key: without if without is not None and key == without.key else None,
                          ci95=lambda s: {"stiction.tau_s": (x_hat - 1e-3, x_hat + 1e-3), "coulomb_friction.tau_c": (0.2, 0.3)})
    return sel, sc


def test_a_quadratic_profile_gives_the_chi_square_interval_and_a_flat_one_reaches_the_bound():
    c = 0.1
    sel, sc = _stand_in(lambda x: 1.0 + c * (x - 0.5) ** 2, rss_zero=1.0 + c * 0.25)
    ci, profs = profile.profiled_ci95(sel, sc)
    scale = 1.0 / (1000 - 3) * 1000 / n_eff(1000, 0.0)
    half = math.sqrt(Q * scale / c)          # 0.196 N m
    lo, hi = ci["stiction.tau_s"]
    assert lo == pytest.approx(0.5 - half, rel=0.05) and hi == pytest.approx(0.5 + half, rel=0.05)
    assert ci["coulomb_friction.tau_c"] == (0.2, 0.3)          # the other parameters keep their Wald intervals
    p = profs["stiction.tau_s"]
    assert not p["to_bound"] and p["lowest"] is None and p["lr_zero"] == pytest.approx(c * 0.25 / scale)
    # flat above 0.3 N m (the joint held): the interval runs to the law's bound
    sel, sc = _stand_in(lambda x: 1.0 + (0.05 if x < 0.3 else 0.0), rss_zero=1.05)
    ci, profs = profile.profiled_ci95(sel, sc)
    assert ci["stiction.tau_s"][1] == TAU_S.hi and profs["stiction.tau_s"]["to_bound"]
    assert 0.25 < ci["stiction.tau_s"][0] < 0.35        # between the grid values 0.25 (outside) and 0.35
    # a lower held fit is reported, and the likelihood ratios are counted from it
    sel, sc = _stand_in(lambda x: 1.0 - (0.001 if x > 10 else 0.0), rss_zero=1.05)
    _, profs = profile.profiled_ci95(sel, sc)
    assert profs["stiction.tau_s"]["lowest"]["value"] > 10 and profs["stiction.tau_s"]["lr_estimate"] > 0
    # a model without a joint's breakaway has no profile
    sel.model = model_for("ramp", ramp_angle_deg=None)
    assert profile.profiled_ci95(sel, sc)[1] == {}


def test_the_keep_rule_tests_a_joints_breakaway_at_zero_by_its_profile_alone():
    """A narrow Wald interval clear of zero does not make a joint's breakaway itself; the fit
    without it must be worse by the chi-square quantile of its one free parameter (v_s held), in
    noise variances inflated for the residual's autocorrelation, at the law's bound too."""
    sel = Selector.__new__(Selector)
    sel.s, sel.model, sel.fits = Settings(), model_for("steer_stand"), {}
    ci = {"stiction.tau_s": (6.62, 6.65), "stiction.v_s": (fx.V_STRIBECK, fx.V_STRIBECK)}

    def fitted(effects, rss, tau_s=6.6, rho1=0.0):
        prob = Problem(effects=effects, values={"stiction.tau_s": tau_s, "stiction.v_s": fx.V_STRIBECK},
                       free=["a", "b", "c"], masks={})
        prob.rss, prob.n = rss, 1000
        return Scored(effects=effects, full=prob, rho1=rho1)

    sc = fitted(("coulomb_friction", "stiction"), 1.0)
    scale = 1.0 / 997
    near = fitted(("coulomb_friction",), 1.0 + 3.3 * scale)        # the real steer log's 2.93-3.29
    far = fitted(("coulomb_friction",), 1.0 + 4.0 * scale)
    assert "likelihood ratio at zero 3.3, not above 3.84" in sel.not_itself(sc, "stiction", ci, near)
    assert sel.not_itself(sc, "stiction", ci, far) == ""
    sc.rho1 = 0.9                # 19 samples per independent one: the same gain is not enough
    assert sel.not_itself(sc, "stiction", ci, far)
    sc.rho1 = 0.0
    sc.full.values["stiction.tau_s"] = TAU_S.hi                    # holding the joint, at the bound
    assert sel.not_itself(sc, "stiction", ci, far) == ""
