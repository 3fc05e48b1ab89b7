"""The emcee moves of a friction posterior: differential evolution while the chain adapts, then
an independence proposal fitted to the chain so far (:class:`IndependentT`; :class:`BoxedT`
where some parameters are weakly identified) mixed with DE moves.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np


def default_moves(n_walkers: int, ndim: int):
    """Moves of the first adaptation stage (differential evolution, plus a KDE proposal when
    the ensemble is large)."""
    import emcee

    if n_walkers >= 8 * ndim:
        # many walkers: a KDE of the other half-ensemble is a near-independent proposal for a
        # unimodal posterior; DE moves keep it robust on curved (weakly identified) ridges
        return [(emcee.moves.KDEMove(), 0.5), (emcee.moves.DEMove(), 0.4), (emcee.moves.DESnookerMove(), 0.1)]
    return [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]


class IndependentT:
    """Independence proposal for emcee's ``MHMove``: a multivariate Student t (``df``) with the
    mean and ``scale``^2 x covariance of given samples, and the Metropolis-Hastings correction
    log g(x) - log g(x') that makes a proposal independent of the current state exact.

    Fitted once to the adaptation phase of the chain and then frozen, so the chain after it is
    a fixed-kernel (valid) MCMC chain.  Heavier tails than a Gaussian (df = 6) keep the chain
    from sticking where the posterior is wider than the fit; proposals outside the prior
    support are rejected by the posterior itself."""

    def __init__(self, mean: np.ndarray, cov: np.ndarray, df: float = 6.0, scale: float = 1.2):
        self.mean = np.asarray(mean, dtype=float)
        d = self.mean.size
        cov = 0.5 * (cov + cov.T) * scale ** 2
        w, V = np.linalg.eigh(cov)
        w = np.clip(w, max(float(w.max()), 1e-300) * 1e-12, None)
        self.L = V * np.sqrt(w)                 # cov = L L^T
        self.Linv = (V / np.sqrt(w)).T          # whitening
        self.df, self.d = float(df), d

    @classmethod
    def from_chain(cls, chain: np.ndarray, **kw) -> "IndependentT":
        X = chain.reshape(-1, chain.shape[-1])
        return cls(X.mean(axis=0), np.cov(X.T).reshape(X.shape[1], X.shape[1]), **kw)

    def log_density(self, x: np.ndarray) -> np.ndarray:
        z = (x - self.mean) @ self.Linv.T
        return -0.5 * (self.df + self.d) * np.log1p(np.sum(z * z, axis=1) / self.df)

    def __call__(self, coords: np.ndarray, random) -> tuple[np.ndarray, np.ndarray]:
        n = coords.shape[0]
        z = random.randn(n, self.d) @ self.L.T
        w = random.chisquare(self.df, n) / self.df
        q = self.mean + z / np.sqrt(w)[:, None]
        return q, self.log_density(coords) - self.log_density(q)


class BoxedT:
    """Independence proposal for emcee's ``MHMove``: :class:`IndependentT` over most coordinates
    and uniform over a box on the others (``boxes``: coordinate -> (low, high)), with the exact
    Metropolis-Hastings correction.

    For the weakly identified parameters, whose posterior is about as wide as their prior and
    flat over much of it (the real steer log's mu_s and Majd's f_c, from their lower bound up to
    what the swings allow).  A t matched to such a box under-proposes its ends, and a walker that
    reaches one sticks there (the real log's Coulomb + viscous chain: a log-weight spread of 12
    at the 99th percentile, stays of 300 steps, 15 autocorrelation times in 3000 steps); drawn
    uniformly over the box the same coordinates give a spread of 1.6.  A walker outside the box
    leaves it by the DE moves mixed in (:func:`adapted_moves`).  The other coordinates are drawn
    from a t centred on their linear regression on the boxed ones (:meth:`_centre`)."""

    def __init__(self, X: np.ndarray, boxes: dict, **kw):
        X = np.asarray(X, dtype=float)
        self.boxed = sorted(boxes)
        self.rest = [j for j in range(X.shape[1]) if j not in boxes]
        self.low = np.array([boxes[j][0] for j in self.boxed])
        self.high = np.array([boxes[j][1] for j in self.boxed])
        # The other coordinates follow the boxed ones (a lower stiction level, a higher kinetic
        # one): their t is centred on the samples' linear regression on the boxed coordinates,
        # with the regression's residual covariance, so that a uniform draw of the boxed ones
        # gets the others where the posterior puts them for it.
        Z = np.column_stack([np.ones(len(X)), X[:, self.boxed]])
        Y = X[:, self.rest]
        self.B, *_ = np.linalg.lstsq(Z, Y, rcond=None)
        R = Y - Z @ self.B
        self.t = IndependentT(np.zeros(Y.shape[1]), np.cov(R.T).reshape(Y.shape[1], Y.shape[1]), **kw)

    def _centre(self, x: np.ndarray) -> np.ndarray:
        return np.column_stack([np.ones(len(x)), x[:, self.boxed]]) @ self.B

    def log_density(self, x: np.ndarray) -> np.ndarray:
        inside = np.all((x[:, self.boxed] >= self.low) & (x[:, self.boxed] <= self.high), axis=1)
        return np.where(inside, self.t.log_density(x[:, self.rest] - self._centre(x)), -np.inf)

    def __call__(self, coords: np.ndarray, random) -> tuple[np.ndarray, np.ndarray]:
        q = np.empty_like(coords)
        q[:, self.boxed] = self.low + (self.high - self.low) * random.rand(coords.shape[0], len(self.boxed))
        q[:, self.rest] = self._centre(q) + self.t(coords[:, self.rest], random)[0]
        with np.errstate(invalid="ignore"):        # -inf - -inf: a walker outside the box stays
            return q, np.nan_to_num(self.log_density(coords) - self.log_density(q), nan=-np.inf)


WEAK_SHARE = 0.15        # posterior 95% width / prior 95% width above which a coordinate is boxed
BOX_PAD = 0.2           # the box: the samples' range widened by this share on each side


def weak_boxes(X: np.ndarray, priors: Sequence) -> dict:
    """Boxes of the coordinates (those with a prior, in order) whose samples X spread over more
    than :data:`WEAK_SHARE` of their prior: the prior's support where it is bounded (else the
    samples' range padded by :data:`BOX_PAD`).  Not the samples' range alone: on the real steer
    log the Coulomb + viscous mu_s samples of the adaptation reached up to 0.07 N m at some seeds
    (box padded to 0.07) where the posterior runs to 0.4, and walkers past the box stuck."""
    boxes = {}
    for j, p in enumerate(priors):
        a, b = p.interval95_u()
        lo, hi = np.percentile(X[:, j], [2.5, 97.5])
        if b > a and (hi - lo) / (b - a) > WEAK_SHARE:
            span = X[:, j].max() - X[:, j].min()
            lo_, hi_ = X[:, j].min() - BOX_PAD * span, X[:, j].max() + BOX_PAD * span
            # over the whole prior where it is bounded: the adaptation's walkers have not yet
            # reached the far end of a plateau they are still spreading over
            boxes[j] = (p.u_low if np.isfinite(p.u_low) else lo_, p.u_high if np.isfinite(p.u_high) else hi_)
    return boxes


def adapted_moves(chain: np.ndarray, stage: int, schedule: Sequence[int], priors: Sequence = ()):
    """Moves of adaptation stage `stage` >= 1 (stage 0 is DE alone): the independence
    proposal fitted to the previous stage's samples (for stage 1, the second half of the DE
    stage, whose start is not yet in equilibrium), mixed with a few DE moves for robustness.
    The coordinates with `priors` (the law's and the stand's) that those samples spread over
    much of their prior are drawn uniformly over a box (:class:`BoxedT`)."""
    import emcee

    end = schedule[stage - 1]
    begin = end // 2 if stage == 1 else schedule[stage - 2]
    X = chain[begin:end].reshape(-1, chain.shape[-1])
    boxes = weak_boxes(X, priors)
    prop = BoxedT(X, boxes) if boxes else IndependentT.from_chain(chain[begin:end])
    return [(emcee.moves.MHMove(prop), 0.9), (emcee.moves.DEMove(), 0.1)]
