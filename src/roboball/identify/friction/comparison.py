"""Model comparison of friction laws fitted to the same recording: residual RMS,
log-likelihoods, BIC and WAIC, with differences to the best (lowest BIC)."""
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
    differences to the best fit of the same joint and recording."""
    rows = [_row(f if isinstance(f, Mapping) else read_json(f)) for f in fits]
    df = pd.DataFrame(rows)
    if df.empty:
        raise RoboballError("friction comparison: no fits given")
    df["delta_bic"] = df["bic"] - df.groupby(["joint", "recording"])["bic"].transform("min")
    df["delta_waic"] = df["waic"] - df.groupby(["joint", "recording"])["waic"].transform("min")
    return df.sort_values(["joint", "recording", "bic"]).reset_index(drop=True)
