"""The emcee moves of a friction posterior: differential evolution while the chain adapts, then
an independence proposal fitted to the chain so far (:class:`IndependentT`) mixed with DE moves.
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


def adapted_moves(chain: np.ndarray, stage: int, schedule: Sequence[int]):
    """Moves of adaptation stage `stage` >= 1 (stage 0 is DE alone): the independence
    proposal fitted to the previous stage's samples (for stage 1, the second half of the DE
    stage, whose start is not yet in equilibrium), mixed with a few DE moves for robustness."""
    import emcee

    end = schedule[stage - 1]
    begin = end // 2 if stage == 1 else schedule[stage - 2]
    prop = IndependentT.from_chain(chain[begin:end])
    return [(emcee.moves.MHMove(prop), 0.9), (emcee.moves.DEMove(), 0.1)]
