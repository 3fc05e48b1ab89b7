"""Held-out error of fitted models, many at once: each model refitted on every fold's training
data, then scored on what the fold holds out.

Folds: with two or more releases, leave one release out (fit the model on the others, then fit
only the held-out release's state with the model frozen, and score it); with a single release,
`Settings.n_blocks` contiguous time blocks, each predicted by a fit to the others.  All models'
fold fits run in the same batched Levenberg-Marquardt iterations (roboball.diagnose.fit).

A release's state (its starting angle and instant) is a nuisance of the data that hold the
release, never predicted, under one rule for both kinds of fold: the fold whose held-out samples
hold the release's start fits the state on them with the model frozen.  For a held-out release
that is the whole release; for a single release's blocks it is the first block (the model is
fitted on the later blocks with the state free, since they depend on it, then only the state is
refitted on the first block).  The other blocks' folds keep the first block in training, where
the state is fitted with the model.  Fitting the state of the first block from the later ones
alone would extrapolate it backwards through the decay: on the real shell log (zeta about 0.3)
the later blocks left the release instant anywhere within its +-0.1 s bound.

The level at which a joint comes to rest is a nuisance too (`heldout_error`): a dry-friction joint
sticks at the turning point where gravity no longer beats its breakaway, anywhere in its stick
band, and which turning point that is hangs on sub-noise detail of the last swing.  No model
predicts it from the other releases: on a Coulomb + stiction stand (blind benchmark seed 8,
steer_stand-14) one release rested for 1.3 s of its 7.3 s, and its rest level alone held 85% of
every model's held-out square, so halving the other releases' errors moved the pooled RMS by 5%.
Where the recording ends at rest, the held-out error of that stretch counts the motion about the
recorded level, not the level: a model that keeps swinging there still pays for the swing.
"""
from __future__ import annotations

import math

import numpy as np

from roboball.diagnose.fit import Problem
from roboball.diagnose.scored import Scored

REST_BAND = 3.0     # a recording at rest stays within this many noise levels of its final level
REST_MIN_S = 0.5    # ... for at least this long (shorter: the swing's last, slow turning point)
REST_LEVEL_S = 0.2  # the final level: the median of the last this many seconds


def rest_start(w, noise: float) -> int | None:
    """The first sample of the stretch at which window `w`'s recorded angle has come to rest
    for good (None if it does not end at rest, if `noise` is 0, or if `w` is an averaged trend)."""
    if w.smooth_s or not noise > 0 or w.n < 2:
        return None
    level = float(np.median(w.y[w.t >= w.t[-1] - REST_LEVEL_S]))
    away = np.nonzero(np.abs(w.y - level) > REST_BAND * noise)[0]
    i = int(away[-1]) + 1 if away.size else 0
    if i >= w.n or w.t[i] <= w.t0 or w.t[-1] - w.t[i] < REST_MIN_S:
        return None
    return i


def heldout_error(pred: np.ndarray, w, noise: float) -> np.ndarray:
    """A window's held-out error, `pred` - y, scored as the module docstring says: where the
    recording ends at rest, the stretch's mean error (the rest level's) is removed."""
    e = np.asarray(pred, dtype=float) - w.y
    i = rest_start(w, noise)
    if i is not None and np.all(np.isfinite(e[i:])):
        e = e.copy()
        e[i:] -= np.mean(e[i:])
    return e


def time_blocks(w, n_blocks: int) -> list[tuple[int, int]]:
    """The [lo, hi) sample ranges of a single window's held-out time blocks: the samples after the
    release split evenly, the first block also holding those before it."""
    after = np.nonzero(w.t >= w.t0)[0]
    edges = np.linspace(0, len(after), n_blocks + 1).astype(int)
    return [(0 if b == 0 else int(after[edges[b]]), w.n if b == n_blocks - 1 else int(after[edges[b + 1]]))
            for b in range(n_blocks)]


class CrossValidation:
    """Cross-validation for the selection (roboball.diagnose.select.Selector) to inherit: it needs
    `self.prep`, `self.engine`, `self.s` (Settings), `self.free_keys` and `self.log`."""

    def _folds(self):
        """[(train masks, held-out window or None, held-out masks)]."""
        wins = self.prep.windows
        if len(wins) >= 2:
            out = []
            for w in wins:
                train = {v.index: np.ones(v.n, bool) for v in wins if v.index != w.index}
                out.append((train, w.index, {w.index: np.ones(w.n, bool)}))
            return out
        w = wins[0]
        out = []
        for b, (lo, hi) in enumerate(time_blocks(w, self.s.n_blocks)):
            held = np.zeros(w.n, bool)
            held[lo:hi] = True
            # the first block holds the release's start: its state is fitted there (module docstring)
            holds_start = b == 0 and bool(self.engine.release_keys([w.index]))
            out.append(({w.index: ~held}, w.index if holds_start else None, {w.index: held}))
        return out

    def cross_validate(self, scored: list, cofit: bool = False) -> None:
        """Held-out RMSE of each scored model (batched over models and folds).  With `cofit`,
        the models' full fits are refined in the same batched iterations as the folds (which
        then start from the models' current, not final, values)."""
        if not scored:
            return
        stage1 = self._fold_problems(scored, cofit)
        c0 = self.engine.n_calls
        for p in stage1:
            p.max_iter = self.s.fold_iter if isinstance(p.tag, tuple) else self.s.fit_iter
        self.engine.fit(stage1, max_iter=self.s.fit_iter)
        self.log(f"   cv stage1: {len(stage1)} problems, {self.engine.n_calls - c0} calls")
        stage1 = [p for p in stage1 if isinstance(p.tag, tuple)]
        stage2 = self._heldout_state_problems(scored, stage1)
        c0 = self.engine.n_calls
        self.engine.fit(stage2, max_iter=self.s.state_iter)
        self.log(f"   cv stage2: {len(stage2)} problems, {self.engine.n_calls - c0} calls")
        by_tag = {p.tag: p for p in stage2}
        for sc in scored:
            self._heldout_score(sc, stage1, by_tag)

    def _fold_problems(self, scored: list, cofit: bool) -> list:
        """Stage 1: each model fitted on each fold's training data, tagged (id(model), fold)
        (preceded by the models' full fits with `cofit`), every problem unconverged."""
        stage1 = [sc.full for sc in scored] if cofit else []
        for sc in scored:
            for fi, (train, held_w, held_masks) in enumerate(self.folds):
                wins = set(train)
                p = Problem(effects=sc.effects, values=dict(sc.values),
                            free=[k for k in self.free_keys(sc.effects) if "@" not in k or int(k.split("@")[1]) in wins],
                            masks=dict(train), tag=(id(sc), fi))
                stage1.append(p)
        for p in stage1:
            p.converged = False
        return stage1

    def _heldout_state_problems(self, scored: list, stage1: list) -> list:
        """Stage 2: with a fold's model frozen, only the state of the release whose start the fold
        holds out is fitted on the held-out samples (starting from the full fit's); the folds of
        later blocks of a single release have none."""
        stage2 = []
        for p in stage1:
            sc_id, fi = p.tag
            train, held_w, held_masks = self.folds[fi]
            if held_w is None:
                continue
            sc = next(s for s in scored if id(s) == sc_id)
            v = dict(p.values)
            for k in self.engine.release_keys([held_w]):
                v[k] = sc.values[k]
            stage2.append(Problem(effects=sc.effects, values=v, free=self.engine.release_keys([held_w]),
                                  masks={held_w: held_masks[held_w]}, tag=p.tag))
        return stage2

    def _heldout_score(self, sc: Scored, stage1: list, by_tag: dict) -> None:
        """Assemble `sc`'s held-out prediction from its folds and its held-out RMSE."""
        pred = {w.index: np.full(w.n, np.nan) for w in self.prep.windows}
        for fi, (train, held_w, held_masks) in enumerate(self.folds):
            p = by_tag.get((id(sc), fi)) if held_w is not None else next(
                q for q in stage1 if q.tag == (id(sc), fi))
            for w, m in held_masks.items():
                pred[w][m] = p.pred[w][m]
        sc.cv_pred = pred
        # an angle's rest is a stick band's level; a rate at rest (a ramp's drive rate) is 0
        noise = self.prep.noise if self.prep.unit == "rad" else 0.0
        sc.cv_err = {w.index: heldout_error(pred[w.index], w, noise) for w in self.prep.windows}
        sq = [np.nansum(sc.cv_err[w.index] ** 2) for w in self.prep.windows]
        n = sum(int(np.sum(np.isfinite(sc.cv_err[w.index]))) for w in self.prep.windows)
        sc.cv_rmse = math.sqrt(sum(sq) / max(n, 1))


def paired_heldout(a: Scored, wins_a: list, b: Scored, wins_b: list) -> dict:
    """Whether two models' held-out errors on the same samples really differ in size.

    The held-out errors are autocorrelated (a misfit lasts a swing), so the samples are not
    independent: n samples with an integrated autocorrelation time of tau samples (emcee's
    estimator, as for the friction chains; the larger of the two models' errors') hold about
    n / tau independent ones.  With that many degrees of freedom on each side, the ratio of the
    two held-out mean squares is referred to Fisher's F distribution, the classical test of two
    error variances.  A recording too short or too small to hold many independent samples
    cannot tell two models apart, whatever their RMS ratio.  (The Diebold-Mariano test of the
    squared errors' difference, tried first, called a sevenfold RMS ratio on the real shell log
    undecided: the larger error sits in a few swings, and the difference's variance is that of
    those few swings.)

    Args:
        a, b: the two models, cross-validated (their held-out errors `cv_err`).
        wins_a, wins_b: their windows (the same recording's releases, matched by index).

    Returns:
        {"n": samples compared, "tau_samples", "n_eff", "ms_ratio" (b's held-out mean square over
        a's: above 1 where a predicts better), "p_two_sided"}; NaNs when fewer than 3 samples are
        shared.
    """
    import emcee
    from scipy.special import fdtrc      # F's survival function (scipy.stats costs a second to import)

    by_index = {w.index: w for w in wins_b}
    ea_all, eb_all = [], []
    for wa in wins_a:
        wb = by_index.get(wa.index)
        if wb is None or wa.index not in a.cv_err or wb.index not in b.cv_err:
            continue
        _, ia, ib = np.intersect1d(wa.t, wb.t, assume_unique=True, return_indices=True)
        ea = a.cv_err[wa.index][ia]
        eb = b.cv_err[wb.index][ib]
        ok = np.isfinite(ea) & np.isfinite(eb)
        ea_all.append(ea[ok])
        eb_all.append(eb[ok])
    ea = np.concatenate(ea_all) if ea_all else np.zeros(0)
    eb = np.concatenate(eb_all) if eb_all else np.zeros(0)
    n = int(ea.size)
    out = {"n": n, "tau_samples": math.nan, "n_eff": math.nan, "ms_ratio": math.nan, "p_two_sided": math.nan}
    if n < 3 or not (np.any(ea) and np.any(eb)):
        return out
    tau = max(float(np.nan_to_num(emcee.autocorr.integrated_time(e, tol=0, quiet=True)[0], nan=float(n)))
              for e in (ea, eb))
    tau = min(max(tau, 1.0), float(n))
    nu = n / tau
    ratio = float(np.mean(eb ** 2) / np.mean(ea ** 2))
    p = float(min(1.0, 2.0 * fdtrc(nu, nu, max(ratio, 1.0 / ratio))))
    out.update(tau_samples=tau, n_eff=nu, ms_ratio=ratio, p_two_sided=p)
    return out
