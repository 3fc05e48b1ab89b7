"""The keep rule: the tests a candidate effect must pass to be added to the model.

The best candidate of a round (lowest BIC) is kept only if
- it lowers the BIC, n ln(RSS / n) + k ln(n) (k fitted parameters including the release
  states), by more than `bic_min` = 10 ("very strong" evidence);
- it lowers the held-out RMS by at least `cv_gain` = 5%;
- it is material: it lowers the held-out mean square by at least `material_noise` = 4
  noise variances (an RMS of two noise levels), so the sub-noise corrections that absorb
  small model-form differences (integrator, contact compliance) are not reported.  The
  noise is that of the signal the fit compares (`Prepared.fit_noise`): the sensor's, or
  for a ramp's averaged trend the noise left in the average (about a tenth of the raw
  variance); a trend's residual measured in raw variances would let nothing be material;
- the 95% interval of its magnitude excludes zero, and so does that of every parameter at
  whose zero it becomes a simpler vocabulary entry (`Effect.reduces_to`: backlash whose
  free play b may be zero is linear stiffness, one parameter fewer for the same fit).

95% intervals come from the Jacobian at the optimum, cov = s^2 (J^T J)^-1, inflated by
n / n_eff with n_eff = n (1 - rho1) / (1 + rho1) for the residual's lag-1 autocorrelation rho1.
That (Wald) interval is the quadratic approximation of the profile likelihood's, and a law that
acts only where the joint turns or sticks (dry friction, a breakaway) is far from quadratic in its
magnitude: a breakaway that halved a stand's fit RMS, in the mean square 53 inflated noise
variances per effective sample, had a Wald interval of -1.1 to 2.3 N m about its 0.6.  Where the
Wald interval of the magnitude includes zero, zero is tested where the profile is known, at the
fit of the same model without the effect: it is outside the 95% interval when the likelihood
ratio, (RSS_without - RSS) / (s^2 n / n_eff), exceeds the chi-square quantile for the effect's
parameter count (`profile_excludes_zero`), and the magnitude lies inside its bounds: the
chi-square holds for an interior estimate only, and a magnitude pinned at its physical bound is a
stand-in pushed as far as it may go (the real shell log, locked, fitted a softening cubic
stiffness at its bound of -200 N m/rad^3, Wald interval -476 to 76, for the free pendulum it has
no term for) and keeps the Wald test.  A joint's breakaway (a stiction held in the creep band) is
tested by the profile alone, at its bound too: its cost is rough at the scale of a stick event, and
its Wald interval is that roughness's curvature (roboball.diagnose.profile).

A model of several effects is kept only if every one of them passes these tests against the same
model without it (roboball.diagnose.select).  Candidates that pass every test but materiality
are `immaterial`: reported, not added.
"""
from __future__ import annotations

import math

import numpy as np

from roboball.physics import effects as fx
from roboball.diagnose.data import Prepared
from roboball.diagnose.fit import effect_keys
from roboball.diagnose.profile import Q95, rough_magnitudes
from roboball.diagnose.scored import Scored
from roboball.metrics import bic, inflated_variance, lag1, n_eff


def immaterial(steps: list, final=None) -> list:
    """Grown models of the search (`steps`: Diagnosis.steps, or the "rounds" of details.json)
    that add one effect to the final model (`final`: its effects; default: the largest model
    marked kept) which the data support (it lowers the BIC and the held-out error, and its
    interval excludes zero) but which falls short of materiality alone: not added, reported so
    the user can judge it."""
    if final is None:
        kept = [set(i.get("set", ())) for step in steps for i in step if i.get("kept")]
        final = max(kept, key=len) if kept else set()
    final = set(final)
    return [i for step in steps for i in step
            if set(i.get("parent", ())) == final and i.get("failed") == ["material"]]


def residuals(prep: Prepared, pred: dict) -> dict:
    return {w.index: pred[w.index] - w.y for w in prep.windows if w.index in pred}


class KeepRule:
    """The keep rule and the statistics it reads, for the selection (roboball.diagnose.select.
    Selector) to inherit: it needs only `self.s` (Settings) and `self.prep` (the noise of the
    signal the fit compares, `fit_noise`, and the windows)."""

    def score(self, sc: Scored, reference: Scored | None = None) -> None:
        sc.rho1 = lag1(residuals(self.prep, sc.full.pred))
        n = sc.full.n
        sc.bic = bic(sc.full.rss, n, sc.full.k, n)
        if reference is not None:
            sc.delta_bic = sc.bic - bic(reference.full.rss, reference.full.n, reference.full.k, n)

    def explained(self, sc: Scored, reference: Scored) -> float:
        """Mean squared residual the model removes relative to `reference`, in noise variances."""
        return (reference.full.rss - sc.full.rss) / sc.full.n / self.prep.fit_noise ** 2

    def failures(self, sc: Scored, reference: Scored, base: Scored, ci: dict | None = None) -> list:
        """Every condition of the keep rule that `sc` fails against `reference`, in the rule's
        order, as (condition, why) with condition "bic", "heldout", "material" or "itself"
        (`ci`: sc's 95% intervals, when the caller has them)."""
        s = self.s
        out = []
        if not sc.delta_bic < -s.bic_min:
            out.append(("bic", f"delta BIC {sc.delta_bic:.1f} not below -{s.bic_min:g}"))
        if not sc.cv_rmse < (1.0 - s.cv_gain) * reference.cv_rmse:
            out.append(("heldout", f"held-out RMS {sc.cv_rmse:.4g} not {s.cv_gain:.0%} below {reference.cv_rmse:.4g}"))
        need = max(s.material_noise, s.material_share * base.cv_rmse ** 2 / self.prep.fit_noise ** 2)
        gain = self.heldout_gain(sc, reference)
        if not gain >= need:
            out.append(("material", f"lowers the held-out mean square by {gain:.3g} noise variances, below {need:.3g}"))
        e = sc.effects[-1]
        without = reference if reference.key == sc.key - {e} else self.fit_of(sc.key - {e})
        why = self.not_itself(sc, e, ci, without)
        if why:
            out.append(("itself", why))
        return out

    def heldout_gain(self, sc: Scored, reference: Scored) -> float:
        """Held-out mean square `sc` removes relative to `reference`, in noise variances."""
        return (reference.cv_rmse ** 2 - sc.cv_rmse ** 2) / self.prep.fit_noise ** 2

    def qualifies(self, sc: Scored, reference: Scored, base: Scored) -> tuple[bool, str]:
        """The keep rule: information criterion, held-out error, materiality, significance."""
        fails = self.failures(sc, reference, base)
        return (False, fails[0][1]) if fails else (True, "kept")

    # ---- confidence intervals -------------------------------------------------------------
    def ci95(self, sc: Scored) -> dict:
        p = sc.full
        J = p.J
        n, k = J.shape
        s2 = p.rss / max(n - k, 1)
        infl = n / n_eff(n, sc.rho1)
        scale = np.array([max(np.linalg.norm(J[:, j]), 1e-300) for j in range(k)])
        Js = J / scale
        try:
            cov = np.linalg.pinv(Js.T @ Js) / np.outer(scale, scale) * s2 * infl
        except np.linalg.LinAlgError:
            cov = np.full((k, k), np.nan)
        out = {}
        for j, key in enumerate(p.free):
            sd = math.sqrt(max(cov[j, j], 0.0))
            out[key] = (p.values[key] - 1.96 * sd, p.values[key] + 1.96 * sd)
        for key in effect_keys(sc.effects):      # a parameter the model holds is known exactly
            if key in self.model.held_params:
                out[key] = (p.values[key], p.values[key])
        return out

    def fit_of(self, key: frozenset) -> Scored | None:
        """The best fit of a set of effects, where the caller keeps them (the selection's `fits`)."""
        return getattr(self, "fits", {}).get(key)

    def profile_excludes_zero(self, sc: Scored, effect: str, without: Scored | None, rough: bool = False) -> bool:
        """Whether the profile likelihood puts `effect`'s magnitude at zero outside its 95%
        interval: the fit `without` the effect is the profile at zero (module docstring).  With
        `rough` (a joint's breakaway, roboball.diagnose.profile) a magnitude at its bound is tested
        too (there it only holds the joint), over the effect's free parameters alone."""
        from scipy.special import chdtri      # chi-square's inverse survival function

        if without is None or without.full.n != sc.full.n:
            return False
        eff = fx.LIBRARY[effect]
        mag = eff.params[0]
        x = sc.values[f"{effect}.{mag.name}"]
        margin = 1e-6 * (mag.hi - mag.lo)
        if not mag.lo + margin < x < mag.hi - margin and not rough:
            return False
        free = [p for p in eff.params if f"{effect}.{p.name}" not in self.model.held_params]
        return bool(self.zero_ratio(sc, without) > chdtri(len(free) if rough else len(eff.params), 0.05))

    @staticmethod
    def zero_ratio(sc: Scored, without: Scored | None) -> float | None:
        """The likelihood ratio of the fit `without` an effect against `sc`, in noise variances
        inflated for the residual's autocorrelation (None where `without` is not on sc's samples)."""
        if without is None or without.full.n != sc.full.n:
            return None
        n, k = sc.full.n, sc.full.k
        return (without.full.rss - sc.full.rss) / inflated_variance(sc.full.rss, n, k, sc.rho1)

    def not_itself(self, sc: Scored, effect: str, ci: dict | None = None, without: Scored | None = None) -> str:
        """Why the fitted `effect` is not shown to be itself ("" when it is): the 95% interval
        of its magnitude includes zero (the Wald interval, or where it does, the profile's at the
        fit `without` the effect), or that of a parameter at whose zero it becomes a simpler
        vocabulary entry (backlash whose free play may be zero is linear stiffness, which is then
        the effect to report: fewer parameters, the same fit)."""
        ci = ci if ci is not None else self.ci95(sc)
        eff = fx.LIBRARY[effect]
        simpler = dict(eff.reduces_to)
        if f"{effect}.{eff.params[0].name}" in rough_magnitudes(self.model, sc.effects):
            # its Wald interval is the curvature of a rough cost (diagnose.profile): the profile decides
            if not self.profile_excludes_zero(sc, effect, without, rough=True):
                ratio = self.zero_ratio(sc, without)
                at = f" (likelihood ratio at zero {ratio:.3g}, not above {Q95:.3g})" if ratio is not None else ""
                return f"the profile likelihood puts its magnitude's 95% interval at zero{at}"
            return ""
        for name in eff.defining_params():
            lo, hi = ci[f"{effect}.{name}"]
            if lo <= 0.0 <= hi and not (name == eff.params[0].name and self.profile_excludes_zero(sc, effect, without)):
                if name in simpler:
                    return f"95% interval of {name} includes zero: {effect} with {name} = 0 is {simpler[name]}"
                return "95% interval of its magnitude includes zero"
        return ""
