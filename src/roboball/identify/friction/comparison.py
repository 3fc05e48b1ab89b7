"""Model comparison of friction laws fitted to the same recording: residual RMS,
log-likelihoods, BIC and WAIC, with differences to the best (lowest BIC), and the law it
recommends.

Only a converged chain is recommended: an unconverged chain's posterior (and so its WAIC, its
intervals and the fit it stands for) is not the one its law gives, so it is flagged
(``converged`` False) and left out of the recommendation, whatever its BIC.
"""
from __future__ import annotations

from typing import Mapping, Sequence

import pandas as pd

from roboball.errors import RoboballError
from roboball.identify.friction.results import read_json


def _row(f: Mapping) -> dict:
    try:
        st = f["fit"]
        return {"joint": f["joint"], "law": f["law"], "recording": f.get("recording", ""),
                "n_params": st["n_params"], "n_obs": st["n_obs"], "rmse_rad": st["rmse_rad"],
                "loglik_map": st.get("loglik_map", float("nan")),
                "loglik": st.get("loglik_max"), "bic": st["bic"],
                "waic": st.get("waic", float("nan")),
                "converged": bool(f.get("convergence", {}).get("converged", False))}
    except KeyError as exc:
        raise RoboballError(f"friction comparison: a fit result lacks field {exc}")


def comparison(fits: Sequence) -> pd.DataFrame:
    """Model-comparison table of fits to the same data (fit JSON paths or result dicts), one row
    per fit, sorted by joint, recording and BIC; ``delta_bic`` and ``delta_waic`` are the
    differences to the best fit of the same joint and recording, ``recommended`` marks the
    converged fit of lowest BIC in each (none when no chain converged)."""
    rows = [_row(f if isinstance(f, Mapping) else read_json(f)) for f in fits]
    df = pd.DataFrame(rows)
    if df.empty:
        raise RoboballError("friction comparison: no fits given")
    df["delta_bic"] = df["bic"] - df.groupby(["joint", "recording"])["bic"].transform("min")
    df["delta_waic"] = df["waic"] - df.groupby(["joint", "recording"])["waic"].transform("min")
    df = df.sort_values(["joint", "recording", "bic"]).reset_index(drop=True)
    df["recommended"] = False
    best = df[df["converged"]].groupby(["joint", "recording"]).head(1).index
    df.loc[best, "recommended"] = True
    return df


def recommendation(table: pd.DataFrame) -> tuple[pd.Series | None, str]:
    """The recommended row of one recording's comparison table (a ``comparison`` CSV read back;
    tables without ``converged`` count every fit as converged) and why: the margin in BIC to the
    next converged law, and any law of lower BIC left out because its chain did not converge
    (e.g. ``"by dBIC = 27.8 (majd, of lower BIC, left out: its chain did not converge)"``).  (None, what went wrong) when no chain converged."""
    t = table.sort_values("bic").reset_index(drop=True)
    ok = t["converged"].astype(bool) if "converged" in t else pd.Series(True, index=t.index)
    good, bad = t[ok], t[~ok]
    if good.empty:
        return None, "no recommendation: no chain converged (" + ", ".join(bad["law"]) + ")"
    best = good.iloc[0]
    why = [f"by dBIC = {good.iloc[1].bic - best.bic:.1f}"] if len(good) > 1 else []
    lower = bad[bad["bic"] < best.bic]
    if not lower.empty:
        why.append("(" + ", ".join(lower["law"]) + ", of lower BIC, left out: " +
                   ("its chain" if len(lower) == 1 else "their chains") + " did not converge)")
    return best, " ".join(why)
