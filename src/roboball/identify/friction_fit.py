"""Friction identification on stand logs: least squares, then emcee posteriors.

Model: one friction law on one joint (stand kinds), all releases of a recording at once.
The swing is simulated by a batched RK4 of the reduced stand model (roboball.reduced's
planar_model constants, the law from roboball.physics.friction via reduced.friction_function),
evaluating every walker and every release in one NumPy time loop.

1. Least squares (scipy) on the stacked residuals over the law parameters (log-transformed,
   so they stay positive) and each release's initial angle (a nuisance parameter).
2. emcee (vectorised, HDF5 backend: an interrupted run resumes) over the law parameters and
   the noise level noise_rad (Gaussian likelihood), with the priors of configs/priors.yaml; the
   release angles are held at their least-squares values (conditioning on them; they are
   determined to ~1e-4 rad by the data right after the release).
3. Convergence is measured: the chain runs in chunks until its length is at least
   `autocorr_multiple` integrated autocorrelation times of every parameter (emcee's estimate,
   tol=0) or `max_steps` is reached, in which case the result says converged: false.
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..atomic import write_csv_atomic, write_json_atomic
from ..errors import RoboballError
from ..physics import friction
from ..reduced import friction_function, planar_model

FIT_DT = 0.01           # RK4 step (s): omega dt = 0.057 for the 5.7 rad/s swing
SAMPLE_HZ = 40.0        # data used per release (subsampled, uniform grid)
WINDOW_S = 4.0          # at most this long after each release (most of the decay)
LOG_PARAMS = {"c", "mu_s", "mu_d", "f_w", "f_c", "sigma", "omega_c", "n"}


@dataclass
class StandData:
    kind: str
    t: list            # per release: times since release (s)
    y: list            # per release: measured angle (rad)
    y_release: np.ndarray
    source: str


def load_stand(recording: str, releases: str) -> StandData:
    from ..recording import read_recording

    rec = read_recording(recording)
    with open(releases, encoding="utf-8") as fh:
        rels = json.load(fh)["releases"]
    if rec.kind not in ("steer_stand", "drive_stand"):
        raise RoboballError(f"{recording}: kind {rec.kind}: friction is fitted on steer_stand or drive_stand logs")
    tt, yy, y0 = [], [], []
    time, sig = rec.time, rec.signal(rec.main_signal())
    for r in rels:
        t0 = r["t_release_s"]
        t1 = min(r["t_end_s"], t0 + WINDOW_S)
        grid = np.arange(0.02, t1 - t0, 1.0 / SAMPLE_HZ)
        if len(grid) < 20:
            continue
        m = (time >= t0 - 0.05) & (time <= t1 + 0.05)
        tt.append(grid)
        yy.append(np.interp(grid + t0, time[m], sig[m]))
        y0.append(r["y_release"])
    if not tt:
        raise RoboballError(f"{recording}: no release long enough to fit friction")
    return StandData(rec.kind, tt, yy, np.array(y0), Path(recording).stem)


_MODELS: dict = {}


def _model(kind):
    if kind not in _MODELS:          # robot.yaml is parsed once, not at every likelihood call
        _MODELS[kind] = planar_model(kind)
    return _MODELS[kind]


def simulate(data: StandData, law: str, params: dict, q0: np.ndarray, dt: float = FIT_DT) -> list:
    """Batched RK4: params values (P,) arrays, q0 (P, S). Returns S arrays (P, n_s)."""
    model = _model(data.kind)
    P, S = q0.shape
    rows = {k: np.repeat(np.asarray(v, float).reshape(-1), S) if np.ndim(v) else v for k, v in params.items()}
    tau = friction_function(law, rows) if law != "none" else (lambda v: 0.0 * v)
    inv_i = 1.0 / model.inertia0_kg_m2
    gG, beta = model.g * model.mass_moment_kg_m, model.offset_rad

    def acc(q, v):
        return (-gG * np.sin(q + beta) + tau(v)) * inv_i

    t_end = max(t[-1] for t in data.t)
    n = int(math.ceil(t_end / dt)) + 1
    q = q0.reshape(-1).copy()     # row = p * S + s
    v = np.zeros_like(q)
    out = np.empty((n + 1, q.size))
    out[0] = q
    h = dt
    for i in range(n):
        a1 = acc(q, v)
        v2 = v + 0.5 * h * a1
        a2 = acc(q + 0.5 * h * v, v2)
        v3 = v + 0.5 * h * a2
        a3 = acc(q + 0.5 * h * v2, v3)
        v4 = v + h * a3
        a4 = acc(q + h * v3, v4)
        q = q + h * (v + h / 6.0 * (a1 + a2 + a3))
        v = v + h / 6.0 * (a1 + 2 * a2 + 2 * a3 + a4)
        out[i + 1] = q
    tg = np.arange(n + 1) * dt
    res = []
    for s, t in enumerate(data.t):
        idx = np.arange(P) * S + s
        k = np.minimum((t / dt).astype(int), n - 1)
        w = (t - tg[k]) / dt
        res.append(out[k][:, idx].T * (1 - w) + out[k + 1][:, idx].T * w)
    return res


# ---- priors -----------------------------------------------------------------------------------
def law_params(law: str) -> list:
    return [p for p in friction.PARAMS[law] if p != "v_tol"]


def log_prior(prior: dict, names: list, theta: np.ndarray) -> np.ndarray:
    """theta: (P, k) natural-unit values; prior entries {type: uniform|loguniform|lognormal, ...}."""
    lp = np.zeros(theta.shape[0])
    for j, name in enumerate(names):
        pr = prior[name]
        x = theta[:, j]
        lo, hi = pr.get("low", -np.inf), pr.get("high", np.inf)
        inside = (x > lo) & (x < hi)
        lp = np.where(inside, lp, -np.inf)
        if pr["type"] == "loguniform":
            lp = lp - np.log(np.where(x > 0, x, 1.0))
        elif pr["type"] == "lognormal":
            lx = np.log(np.where(x > 0, x, 1.0))
            lp = lp - 0.5 * ((lx - math.log(pr["median"])) / pr["sigma_log"]) ** 2 - lx
    return lp


# ---- fit -------------------------------------------------------------------------------------------
def fit(recording: str, releases: str, joint: str, law: str, prior: dict, chain: str, walkers: int = 32,
        autocorr_multiple: float = 50.0, max_steps: int = 20000, seed: int = 0, fixed: dict | None = None) -> dict:
    import emcee
    from scipy.optimize import least_squares

    data = load_stand(recording, releases)
    fixed = dict(fixed or ({"v_tol": 0.01} if law == "coulomb_viscous" else {}))
    names = law_params(law)
    S = len(data.t)
    y_all = np.concatenate(data.y)
    start = np.array([prior[n]["start"] for n in names], float)

    def unpack(x):
        return {n: np.exp(x[:, j]) for j, n in enumerate(names)}, x[:, len(names):]

    def residuals_batch(x):
        par, q0 = unpack(x)
        sims = simulate(data, law, {**par, **fixed}, q0)
        return np.concatenate(sims, axis=1) - y_all[None, :]

    def fun(x):
        return residuals_batch(x[None, :])[0]

    def jac(x):
        h = 1e-5
        X = np.repeat(x[None, :], len(x) + 1, axis=0)
        X[1:] += np.eye(len(x)) * h
        R = residuals_batch(X)
        return ((R[1:] - R[0]) / h).T

    lo = np.concatenate([np.log([prior[n].get("low", 1e-9) if prior[n].get("low", 0) > 0 else 1e-9 for n in names]), data.y_release - 0.2])
    hi = np.concatenate([np.log([prior[n].get("high", 1e9) for n in names]), data.y_release + 0.2])
    x0 = np.clip(np.concatenate([np.log(start), data.y_release]), lo + 1e-9, hi - 1e-9)
    ls = least_squares(fun, x0, jac=jac, bounds=(lo, hi), x_scale="jac", max_nfev=200)
    q0_hat = ls.x[len(names):]
    r = ls.fun
    n_obs = r.size
    rmse = float(np.sqrt(np.mean(r ** 2)))

    # ---- emcee over (law params, sigma) with the release angles held at the LSQ values ----
    allnames = names + ["noise_rad"]
    prior_all = dict(prior)
    prior_all.setdefault("noise_rad", {"type": "loguniform", "low": 1e-4, "high": 0.2})

    def log_prob(theta):
        theta = np.atleast_2d(theta)
        lp = log_prior(prior_all, allnames, theta)
        ok = np.isfinite(lp)
        out = np.full(theta.shape[0], -np.inf)
        if ok.any():
            th = theta[ok]
            par = {n: th[:, j] for j, n in enumerate(names)}
            sims = simulate(data, law, {**par, **fixed}, np.repeat(q0_hat[None, :], th.shape[0], axis=0))
            res = np.concatenate(sims, axis=1) - y_all[None, :]
            sig = th[:, -1]
            ll = -0.5 * np.sum(res ** 2, axis=1) / sig ** 2 - n_obs * np.log(sig) - 0.5 * n_obs * math.log(2 * math.pi)
            out[ok] = np.where(np.isfinite(ll), lp[ok] + ll, -np.inf)
        return out

    ndim = len(allnames)
    walkers = max(walkers, 2 * ndim + 2)
    map_theta = np.concatenate([np.exp(ls.x[:len(names)]), [max(rmse, 2e-4)]])
    Path(chain).parent.mkdir(parents=True, exist_ok=True)
    backend = emcee.backends.HDFBackend(chain, name=f"{joint}_{law}")
    rng = np.random.default_rng(seed)
    moves = [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]
    sampler = emcee.EnsembleSampler(walkers, ndim, log_prob, vectorize=True, backend=backend, moves=moves)
    sampler._random = np.random.mtrand.RandomState(seed)
    resumed = backend.iteration > 0 and backend.shape == (walkers, ndim)
    if not resumed:
        backend.reset(walkers, ndim)
        p0 = map_theta[None, :] * (1 + 1e-3 * rng.standard_normal((walkers, ndim)))
        state = p0
    else:
        state = None
    chunk = 250
    converged = False
    tau = np.full(ndim, np.inf)
    while True:
        if state is not None or backend.iteration == 0:
            sampler.run_mcmc(state, chunk, progress=False)
            state = None
        else:
            sampler.run_mcmc(None, chunk, progress=False)
        steps = backend.iteration
        tau = backend.get_autocorr_time(tol=0, discard=steps // 4)
        if np.all(np.isfinite(tau)) and steps >= autocorr_multiple * np.max(tau) and steps >= 500:
            converged = True
            break
        if steps >= max_steps:
            break
    steps = backend.iteration
    tmax = float(np.max(tau))
    burn = int(min(steps // 2, math.ceil(2 * tmax)))
    thin = max(1, int(tmax // 2))
    flat = backend.get_chain(discard=burn, thin=thin, flat=True)
    samples = pd.DataFrame(flat, columns=allnames)
    lp_chain = backend.get_log_prob(discard=burn, flat=True)
    i_best = int(np.argmax(backend.get_log_prob(flat=True)))
    best = backend.get_chain(flat=True)[i_best]
    k = len(names) + S + 1
    sig_ml = math.sqrt(np.mean(r ** 2))
    loglik = -0.5 * n_obs * (math.log(2 * math.pi * sig_ml ** 2) + 1)
    bic = k * math.log(n_obs) - 2 * loglik
    out = {
        "recording": data.source, "joint": joint, "law": law, "fixed": fixed,
        "parameters": {n: {"median": float(np.median(samples[n])), "ci95_low": float(np.percentile(samples[n], 2.5)),
                           "ci95_high": float(np.percentile(samples[n], 97.5)), "map": float(best[j]),
                           "lsq": float(map_theta[j]), "unit": friction.UNITS.get(n, "rad")}
                       for j, n in enumerate(allnames)},
        "release_angles_rad": [float(x) for x in q0_hat],
        "fit": {"rmse_rad": rmse, "n_obs": int(n_obs), "n_params": k, "loglik": loglik, "bic": bic},
        "convergence": {"steps": int(steps), "walkers": walkers, "tau": {n: float(t) for n, t in zip(allnames, tau)},
                        "max_tau": tmax, "autocorr_multiple_required": autocorr_multiple,
                        "acceptance_fraction": float(np.mean(sampler.acceptance_fraction)),
                        "ess_min": float(walkers * (steps - burn) / tmax), "converged": bool(converged),
                        "resumed": bool(resumed), "burn": burn, "thin": thin},
        "chain": str(chain),
    }
    return out, samples


def comparison(fit_jsons: list) -> pd.DataFrame:
    rows = []
    for p in fit_jsons:
        with open(p, encoding="utf-8") as fh:
            f = json.load(fh)
        rows.append({"recording": f["recording"], "joint": f["joint"], "law": f["law"], "rmse_rad": f["fit"]["rmse_rad"],
                     "n_params": f["fit"]["n_params"], "loglik": f["fit"]["loglik"], "bic": f["fit"]["bic"]})
    df = pd.DataFrame(rows).sort_values("bic").reset_index(drop=True)
    df["delta_bic"] = df.bic - df.bic.min()
    return df
