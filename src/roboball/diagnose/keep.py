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
from roboball.diagnose.scored import Scored
from roboball.metrics import bic, lag1, n_eff


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
        why = self.not_itself(sc, sc.effects[-1], ci)
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

    def not_itself(self, sc: Scored, effect: str, ci: dict | None = None) -> str:
        """Why the fitted `effect` is not shown to be itself ("" when it is): the 95% interval
        of its magnitude includes zero, or that of a parameter at whose zero it becomes a
        simpler vocabulary entry (backlash whose free play may be zero is linear stiffness,
        which is then the effect to report: fewer parameters, the same fit)."""
        ci = ci if ci is not None else self.ci95(sc)
        eff = fx.LIBRARY[effect]
        simpler = dict(eff.reduces_to)
        for name in eff.defining_params():
            lo, hi = ci[f"{effect}.{name}"]
            if lo <= 0.0 <= hi:
                if name in simpler:
                    return f"95% interval of {name} includes zero: {effect} with {name} = 0 is {simpler[name]}"
                return "95% interval of its magnitude includes zero"
        return ""
