"""Equivalent explanations: where another effect explains what a chosen effect explains about as
well, the data cannot tell them apart, and the diagnosis says so.

For the chosen model F and each of its effects e, every unchosen candidate u is put in e's place
(F - e + u, fitted from grid starts like any grown model, or taken from the search's fits).  An
alternative of e is a u that
- passes the keep rule against F - e, as e does (it explains that residual by itself: BIC,
  held-out gain, materiality, interval), and, if it becomes a simpler entry at a parameter's
  zero, against the model with that entry in its place (backlash of no free play is no
  alternative to a stiffness), and
- predicts held-out data about as well as F: held-out RMS within `Settings.equivalent_tol` (10%)
  of F's.  The keep rule asks an effect to lower the held-out RMS by 5%; between two fits of one
  model from different starts the held-out RMS already scatters by that much (the real steer
  log's Coulomb friction + negative stiffness: 0.0250 from one start, 0.0279 from another), so a
  swap that costs less than twice the rule's margin is not told apart by these data.
If some F - e + u passes the keep rule effect by effect, lowers F's BIC by more than `bic_min`
and does not raise its held-out error, it replaces F (as the former swap pass did: a search can
reach a set through an effect that imitates a combination), at most `MAX_SWAPS` times.

The selection (roboball.diagnose.select.Selector) is passed in; nothing here imports it.
"""
from __future__ import annotations

import math

from roboball.physics import effects as fx
from roboball.diagnose.profile import profiled_ci95
from roboball.diagnose.scored import Scored
from roboball.metrics import bic

MAX_SWAPS = 2
PER_EFFECT = 1      # alternatives cross-validated per chosen effect (the closest fit)


def equivalents(sel, final: Scored, base: Scored):
    """(the final model, possibly swapped, {effect: [alternative, ...]}) for `final`."""
    if not final.effects:
        return final, {}
    for attempt in range(MAX_SWAPS + 1):
        sel.validate([final])
        swaps = _swapped(sel, final)
        close = _closest(sel, final, swaps)
        sel.validate([sc for _, _, sc in close], references=False)
        sel.log("equivalents of " + "+".join(final.effects) + f" (rms {final.rmse:.4g}, held out {final.cv_rmse:.4g}): "
                + ", ".join(f"{e}->{u} rms {sc.rmse:.4g} held out {sc.cv_rmse:.4g}" for e, u, sc in close))
        better = _better(sel, final, close, base) if attempt < MAX_SWAPS else None
        if better is None:
            break
        sel.log(f"swap: {'+'.join(final.effects)} -> {'+'.join(better.effects)} (BIC {better.bic:.1f} vs "
                f"{final.bic:.1f}, held out {better.cv_rmse:.4g} vs {final.cv_rmse:.4g})")
        final = better
    return final, _alternatives(sel, final, close, base)


def _swapped(sel, final: Scored) -> list:
    """[(e, u, fit of F - e + u)] for every chosen e and unchosen candidate u (screened where the
    search has no fit of that set)."""
    parents = [sel.fits[final.key - {e}] for e in final.effects]
    others = [u for u in sel.model.candidates if u not in final.effects]
    only = {p.key: [u for u in others if p.key | {u} not in sel.fits] for p in parents}
    sel.grow([p for p in parents if only[p.key]], only=only)
    return [(e, u, sel.fits[(final.key - {e}) | {u}]) for e in final.effects for u in others]


def _closest(sel, final: Scored, swaps: list) -> list:
    """Per chosen effect, the `PER_EFFECT` swaps of lowest RSS that fit within the tolerance of F."""
    tol = 1.0 + sel.s.equivalent_tol
    out = []
    for e in final.effects:
        mine = sorted((x for x in swaps if x[0] == e and x[2].rmse <= tol * final.rmse), key=lambda x: x[2].full.rss)
        out += mine[:PER_EFFECT]
    return out


def bic_on(ref: Scored, sc: Scored) -> float:
    """`ref`'s BIC counted on `sc`'s samples (the keep rule's comparison)."""
    return bic(ref.full.rss, ref.full.n, ref.full.k, sc.full.n)


def _better(sel, final: Scored, close: list, base: Scored) -> Scored | None:
    """The swap of lowest BIC that passes the keep rule effect by effect, lowers F's BIC by more
    than bic_min and does not raise its held-out error (None when there is none)."""
    for e, u, alt in sorted(close, key=lambda x: x[2].bic):
        if not (alt.bic < final.bic - sel.s.bic_min and alt.cv_rmse <= final.cv_rmse):
            continue
        sel.validate([alt])
        if all(not fails for _, _, fails in sel.checks(alt, base)):
            return alt
    return None


def _alternatives(sel, final: Scored, close: list, base: Scored) -> dict:
    """{chosen effect: [{"effect", "parameters", "rmse_heldout", "ci95", "delta_bic"}]}: the swaps
    that explain e's share of the residual about as well (see the module docstring)."""
    tol = 1.0 + sel.s.equivalent_tol
    out = {}
    for e, u, alt in close:
        if alt.key - {u} != final.key - {e} or not math.isfinite(alt.cv_rmse) or alt.cv_rmse > tol * final.cv_rmse:
            continue
        ref = sel.fits[final.key - {e}]
        sel.validate([alt], only=u)
        if any(fails for _, _, fails in sel.checks(alt, base, only=u)):
            continue
        ci, _ = profiled_ci95(sel, alt)      # a rough magnitude's interval is its profile's
        names = fx.LIBRARY[u].param_names
        out.setdefault(e, []).append({
            "effect": u, "parameters": {p: alt.values[f"{u}.{p}"] for p in names},
            "ci95": {p: list(ci[f"{u}.{p}"]) for p in names}, "rmse_heldout": alt.cv_rmse,
            "rmse": alt.rmse, "delta_bic": alt.reordered(u).bic - bic_on(ref, alt),
            # the whole model F - e + u as fitted (details.json): `roboball design` simulates it
            "values": dict(alt.values), "ci95_all": {k: list(v) for k, v in ci.items()}})
    for alts in out.values():
        alts.sort(key=lambda a: a["rmse_heldout"])
    return out

