"""What the selection compares: its settings, and a fitted model with its held-out error and
statistics (`Scored`).  Shared by the keep rule (roboball.diagnose.keep) and the stepwise
selection (roboball.diagnose.select)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from roboball.diagnose.fit import Problem
from roboball.reduced.base import DT

STRUCTURED_RHO = 0.5      # a baseline residual this autocorrelated (lag 1) is structured, not noise


@dataclass
class Settings:
    """Iteration counts of the fits and thresholds of the keep rule and the stopping tests."""

    dt: float = DT
    screen_iter: int = 4
    fit_iter: int = 15                # full fits
    fold_iter: int = 8                # cross-validation fits (warm-started from the full fit)
    state_iter: int = 6               # held-out release-state fits
    top_k: int = 2                    # children judged (cross-validated) per round of the search
    beam_width: int = 4               # models of each size extended in the next round
    equivalent_tol: float = 0.10      # an alternative's held-out RMS within 10% of the chosen model's
    bic_min: float = 10.0
    cv_gain: float = 0.05
    decide_p: float = 0.05            # a steer setting is decided when its held-out gain is this significant
    material_noise: float = 4.0       # an effect must lower the held-out mean square by >= 4 sigma^2
    material_share: float = 0.0       # ... (and, if set, this share of the baseline's held-out mean square)
    max_effects: int = 4
    white_rho: float = 0.3
    white_factor: float = 1.5
    explained_factor: float = 3.0
    explained_ratio: float = 0.1      # augmented: residual RMS within 3 noise levels or a tenth of the baseline's
    n_blocks: int = 3

    def verdict(self, added: bool, rmse_base: float, rmse_final: float, rho1_base: float, noise: float) -> str:
        """The contract's verdict.  With effects `added`: `augmented` when the final residual RMS is
        within `explained_factor` noise levels or `explained_ratio` of the baseline's, else
        `unexplained`.  Without: `unexplained` when the baseline's residual is structured (lag-1
        autocorrelation >= :data:`STRUCTURED_RHO` and above `explained_factor` noise levels), else
        `adequate`.  Shared by every kind (roboball.diagnose.select, .coupled_report)."""
        if added:
            explained = rmse_final <= max(self.explained_factor * noise, self.explained_ratio * rmse_base)
            return "augmented" if explained else "unexplained"
        structured = rho1_base >= STRUCTURED_RHO and rmse_base > self.explained_factor * noise
        return "unexplained" if structured else "adequate"


@dataclass
class Scored:
    """A fitted model (full data) with its cross-validation and statistics."""

    effects: tuple
    full: Problem
    cv_rmse: float = math.nan
    cv_pred: dict = field(default_factory=dict)     # window -> held-out prediction (NaN where fitted)
    cv_err: dict = field(default_factory=dict)      # window -> held-out error scored (crossval.heldout_error)
    rho1: float = math.nan
    bic: float = math.nan
    delta_bic: float = math.nan
    parent: tuple | None = None                      # effects of the model it was grown from

    @property
    def key(self) -> frozenset:
        """The set of effects (the order in which they were added does not matter)."""
        return frozenset(self.effects)

    @property
    def rmse(self) -> float:
        return math.sqrt(self.full.rss / max(self.full.n, 1))

    @property
    def values(self) -> dict:
        return self.full.values

    def reordered(self, last: str) -> "Scored":
        """The same fitted model with `last` named as its most recent effect (the keep rule judges
        a model's most recent effect)."""
        return Scored(effects=tuple(e for e in self.effects if e != last) + (last,), full=self.full,
                      cv_rmse=self.cv_rmse, cv_pred=self.cv_pred, cv_err=self.cv_err, rho1=self.rho1, bic=self.bic,
                      delta_bic=self.delta_bic, parent=self.parent)
