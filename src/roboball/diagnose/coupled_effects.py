"""The coupled steer test diagnosed in Drake: effects per coordinate, held out by folds.

Baseline (diagnosis.md, steer_coupled): the calibrated model, i.e. the stand-fitted steer
friction (with its reflected rotor inertia) and the injected shell (eq. 6-9) at the pressure
fitted on the training data (roboball.diagnose.coupled.fit_pressure), released from the first
sample with the rates estimated there (roboball.diagnose.coupled.Repeat.release_rates).  The effect vocabulary (roboball.physics.effects) applies per degree of freedom:
`CANDIDATES` are (dof, effect) pairs, a torque on the floating base's roll (the pipe angle) or on
the steer joint, or for `added_inertia` the steer joint's rotor.

Selection is a linearised screen, then a Drake refit:
1. one finite-difference Drake run per candidate and training repeat gives the sensitivity of
   both coordinates to the candidate's parameter (a column of the Jacobian);
2. every set of at most `MAX_EFFECTS` candidates is scored by its Gauss-Newton step (bounded
   linear least squares on those columns): BIC with the effective sample count (samples over
   the residual's autocorrelation time) and, with two or more training repeats, the inner
   leave-one-out error of the linearised model; the set with the lowest inner error among those
   that lower BIC is chosen (by BIC alone with one training recording);
3. the chosen parameters are refitted with Drake (scipy least_squares, a small budget) and
   their 95 % intervals read from the Jacobian at the optimum; an effect whose interval includes
   zero is dropped and the rest refitted (`fit_chosen`).
Held-out: each fold trains on all repeats but one and predicts the one left out; a single
recording is split in time instead (trained on its first `TRAIN_SHARE`, scored on the rest).
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from roboball.physics import effects as fx
from roboball.sim.coupled import model_spec
from roboball.sim.forces import SYM, GeneralizedTerm
from roboball.diagnose.coupled import COORDS, Repeat, fit_pressure, run
from roboball.metrics import bic, residual_tau_int

CANDIDATES = (("pipe", "linear_stiffness"), ("pipe", "viscous_damping"), ("pipe", "rolling_resistance"),
              ("pipe", "com_offset"), ("steer", "viscous_damping"), ("steer", "coulomb_friction"),
              ("steer", "added_inertia"), ("steer", "linear_stiffness"), ("steer", "com_offset"))
MAX_EFFECTS = 2
TRAIN_SHARE = 2.0 / 3.0
FIT_TOL = 1e-4          # the Drake refit's relative tolerance on its cost and its step (refit)
DOF_SIGNAL = {"pipe": "pipe_angle_rad", "steer": "steer_angle_rad"}


def key(dof: str, effect: str) -> str:
    return f"{dof}.{effect}"


def _param(effect: str) -> fx.Param:
    return fx.LIBRARY[effect].params[0]


def dof_constants(robot) -> tuple[dict, dict]:
    """Per degree of freedom: the angle the effects are measured from (the model's rest: the
    locked shell's roll, the stand pendulum's angle) and the gravity stiffness k_g (N m/rad) a
    com_offset scales (the shell's K_eq of eq. 5, the pendulum's m g d)."""
    stand = robot.steer_stand_terms
    return ({"pipe": robot.shell_rest_angle, "steer": stand["rest_angle"]},
            {"pipe": {"k_g": robot.K_eq}, "steer": {"k_g": stand["mgd"]}})


def effect_spec(base, chosen: dict):
    """`base` (a coupled SimSpec) with the effects {(dof, effect): value} added: forces as one
    Drake term (the same law functions of roboball.physics.effects, on symbolic variables),
    added inertia on the steer joint's rotor."""
    from dataclasses import replace
    forces = {k: v for k, v in chosen.items() if fx.LIBRARY[k[1]].kind != "inertia"}
    inertia = sum(v for k, v in chosen.items() if fx.LIBRARY[k[1]].kind == "inertia")
    spec = replace(base, extra_terms=list(base.extra_terms), added_inertia=dict(base.added_inertia))
    if inertia:
        spec.added_inertia["steer"] = spec.added_inertia.get("steer", 0.0) + float(inertia)
    if forces:
        rest, context = dof_constants(spec.resolved_robot())

        def law(kin):
            lay, out = kin.layout, []
            for (dof, name), value in forces.items():
                params = {_param(name).name: float(value)}
                if dof == "pipe":
                    q, qd, iv = kin.pipe_angle(), kin.pipe_rate(), lay.base_v
                else:
                    q, qd, iv = kin.q[lay.joint_q["steer"]], kin.v[lay.joint_v["steer"]], lay.joint_v["steer"]
                out.append((iv, fx.torque(name, q - rest[dof], qd, params, context[dof], m=SYM)))
            return out
        spec.extra_terms.append(GeneralizedTerm(law, name="diagnosed[" + "+".join(key(*k) for k in forces) + "]"))
    return spec


@dataclass
class Fold:
    """Which samples of which repeats a fold trains on and scores."""

    name: str
    train: dict                          # repeat name -> boolean mask
    test: dict


def folds_of(reps: list[Repeat]) -> list[Fold]:
    if len(reps) == 1:
        r = reps[0]
        cut = r.t <= TRAIN_SHARE * r.t[-1]
        return [Fold(f"{r.name} (last third held out)", {r.name: cut}, {r.name: ~cut})]
    out = []
    for k, r in enumerate(reps):
        train = {o.name: np.ones(len(o.t), bool) for j, o in enumerate(reps) if j != k}
        out.append(Fold(r.name, train, {r.name: np.ones(len(r.t), bool)}))
    return out


def truncated(rep: Repeat, mask: np.ndarray) -> Repeat:
    """The samples of `rep` under a leading mask (its training window)."""
    return Repeat(rep.name, rep.t[mask], rep.pipe[mask], rep.steer[mask])


def residual(preds: dict, reps: list[Repeat], masks: dict) -> np.ndarray:
    """Model minus data, both coordinates, of the masked samples of the repeats in `masks`."""
    parts = []
    for r in reps:
        if r.name in masks:
            m = masks[r.name]
            parts += [preds[r.name][c][m] - r.coord(c)[m] for c in COORDS]
    return np.concatenate(parts) if parts else np.zeros(0)


def rms_by_coord(preds: dict, reps: list[Repeat], masks: dict) -> dict:
    out = {}
    for c in COORDS:
        e = np.concatenate([preds[r.name][c][masks[r.name]] - r.coord(c)[masks[r.name]] for r in reps if r.name in masks])
        out[c] = float(np.sqrt(np.mean(e ** 2)))
    return out


def predict_all(spec, reps: list[Repeat], names=None) -> dict:
    return {r.name: run(spec, r) for r in reps if names is None or r.name in names}


def _n_eff(r: np.ndarray) -> float:
    return len(r) / residual_tau_int(r)


def _groups(reps, masks) -> np.ndarray:
    """The repeat each sample of `residual(...)` belongs to (its index in `reps`)."""
    return np.concatenate([np.full(len(COORDS) * int(masks[r.name].sum()), k)
                           for k, r in enumerate(reps) if r.name in masks])


def _bounded_step(J, r, combo):
    """A Gauss-Newton step inside each parameter's physical bounds (no negative damping)."""
    from scipy.optimize import lsq_linear
    lo = [_param(c[1]).lo for c in combo]
    hi = [_param(c[1]).hi for c in combo]
    return lsq_linear(J, -r, bounds=(lo, hi)).x


def _inner_cv(J, r0, groups, combo) -> float:
    """RMS of the linearised prediction of each training repeat from the others' step."""
    sq = 0.0
    for g in np.unique(groups):
        out = groups == g
        step = _bounded_step(J[~out], r0[~out], combo)
        e = r0[out] + J[out] @ step
        sq += float(e @ e)
    return math.sqrt(sq / len(r0))


def screen(base, reps, masks, log=None, preds0: dict | None = None) -> tuple[list, dict]:
    """Step 1-2 of the module docstring: the chosen candidates and the screen's table.  With two
    or more training repeats the set is chosen by its linearised inner leave-one-out error (each
    training repeat predicted from the step fitted on the others), among the sets that lower BIC;
    with one, by BIC alone.  `preds0`: the baseline's predictions of the repeats, when already run."""
    names = set(masks)
    r0 = residual(preds0 if preds0 is not None else predict_all(base, reps, names), reps, masks)
    cols = {}
    for cand in CANDIDATES:
        h = _param(cand[1]).typical
        pred = predict_all(effect_spec(base, {cand: h}), reps, names)
        cols[cand] = (residual(pred, reps, masks) - r0) / h
    groups = _groups(reps, masks)
    inner = len(np.unique(groups)) > 1
    n_eff = _n_eff(r0)
    bic0 = bic(float(r0 @ r0), len(r0), 0, n_eff)
    rms0 = math.sqrt(r0 @ r0 / len(r0))
    table, best = {}, ((), rms0 if inner else bic0)
    for k in range(1, MAX_EFFECTS + 1):
        for combo in itertools.combinations(CANDIDATES, k):
            J = np.column_stack([cols[c] for c in combo])
            step = _bounded_step(J, r0, combo)
            r1 = r0 + J @ step
            b = bic(float(r1 @ r1), len(r1), k, n_eff)
            row = {"rmse_linear": float(np.sqrt(r1 @ r1 / len(r1))), "delta_bic": float(b - bic0),
                   "step": step.tolist()}
            if inner:
                row["rmse_inner_cv"] = _inner_cv(J, r0, groups, combo)
            table["+".join(key(*c) for c in combo)] = row
            score = row["rmse_inner_cv"] if inner else b
            if score < best[1] and b < bic0:
                best = (combo, score)
    if log:
        log(f"screen: {len(table)} sets scored on {len(r0)} samples (n_eff {n_eff:.0f}); "
            f"chosen {'+'.join(key(*c) for c in best[0]) or 'nothing'}")
    return list(best[0]), table


@dataclass
class Refit:
    values: dict = field(default_factory=dict)         # (dof, effect) -> value
    ci95: dict = field(default_factory=dict)
    rmse_train: float = math.nan
    rmse_base_train: float = math.nan
    delta_bic: float = 0.0


def refit(base, chosen: list, reps, masks, start: dict | None = None, max_nfev: int = 12,
          preds0: dict | None = None) -> Refit:
    """Step 3: the chosen effects' parameters by Drake least squares on the training samples
    (`preds0`: the baseline's predictions, when already run)."""
    from scipy.optimize import least_squares
    names = set(masks)
    r0 = residual(preds0 if preds0 is not None else predict_all(base, reps, names), reps, masks)
    out = Refit(rmse_base_train=float(np.sqrt(np.mean(r0 ** 2))), rmse_train=float(np.sqrt(np.mean(r0 ** 2))))
    if not chosen:
        return out
    typ = np.array([_param(c[1]).typical for c in chosen])
    lo = np.array([_param(c[1]).lo for c in chosen]) / typ
    hi = np.array([_param(c[1]).hi for c in chosen]) / typ
    x0 = np.array([(start or {}).get(c, _param(c[1]).typical) for c in chosen]) / typ
    x0 = np.clip(x0, lo + 1e-9, hi - 1e-9)

    def f(x):
        return residual(predict_all(effect_spec(base, dict(zip(chosen, x * typ))), reps, names), reps, masks)

    # Drake's discrete steps make the cost rough at the finest scales, so SciPy's default
    # tolerances (1e-8) never stopped a fit that had converged: on the real repeats half the runs
    # were spent moving parameters in their 4th-5th digit with the cost unchanged in its 6th.
    # A step or cost change of 1e-4 relative is far inside the 95 % intervals reported.
    res = least_squares(f, x0, bounds=(lo, hi), diff_step=0.05, max_nfev=max_nfev, x_scale=1.0,
                        ftol=FIT_TOL, xtol=FIT_TOL)
    r1 = res.fun
    n_eff = _n_eff(r1)
    s2 = float(r1 @ r1) / max(len(r1) - len(chosen), 1) * residual_tau_int(r1)
    try:
        cov = np.linalg.inv(res.jac.T @ res.jac) * s2
        se = np.sqrt(np.clip(np.diag(cov), 0, None)) * typ
    except np.linalg.LinAlgError:
        se = np.full(len(chosen), np.nan)
    x = res.x * typ
    out.values = {c: float(v) for c, v in zip(chosen, x)}
    out.ci95 = {c: (float(v - 1.96 * s), float(v + 1.96 * s)) for c, v, s in zip(chosen, x, se)}
    out.rmse_train = float(np.sqrt(np.mean(r1 ** 2)))
    out.delta_bic = float(bic(float(r1 @ r1), len(r1), len(chosen), n_eff) - bic(float(r0 @ r0), len(r0), 0, n_eff))
    return out


def fit_chosen(base, chosen: list, reps, masks, preds0: dict | None = None) -> tuple[list, Refit, list]:
    """Refit the screen's choice, then drop every effect whose 95 % interval includes zero (the
    diagnosis's keep rule: the data must tell the effect from its absence) and refit the rest
    once.  Returns (kept, their fit, dropped).  `preds0`: the baseline's predictions, when already run."""
    fit = refit(base, chosen, reps, masks, preds0=preds0)
    dropped = [c for c in chosen if fit.ci95[c][0] <= 0.0 <= fit.ci95[c][1]]
    if dropped:
        chosen = [c for c in chosen if c not in dropped]
        fit = refit(base, chosen, reps, masks, start=fit.values, preds0=preds0)
    return chosen, fit, dropped


BASELINE_MODEL = "injected"     # the shell model of the baseline (roboball.sim.coupled.MODELS)


def baseline_spec(p_kpa: float, laws, friction: dict):
    return model_spec(BASELINE_MODEL, p_kpa, laws, friction)


def held_out(reps, laws, friction, pressure=None, log=None) -> list[dict]:
    """Every fold: pressure fitted on its training repeats (or time window), screen, refit, and
    the baseline's and the augmented model's RMS per coordinate on the held-out samples.  Each
    fold's dict also holds the held-out repeats' runs of the baseline and of the diagnosed model
    (`runs`), which a caller scoring the same repeats reuses rather than runs again;
    `fold_summary` leaves them out."""
    if pressure is None:
        # one recording: its pressure from the training window only (nothing of the held-out part)
        train = reps if len(reps) > 1 else [truncated(reps[0], folds_of(reps)[0].train[reps[0].name])]
        pressure = fit_pressure(train, laws, friction)
    out, baselines = [], {}
    for fold in folds_of(reps):
        p = pressure.folds.get(fold.name, pressure.p_kpa)
        base = baseline_spec(p, laws, friction)
        if p not in baselines:          # folds at one pressure (a logged one) share the baseline's runs
            baselines[p] = predict_all(base, reps)
        preds0 = baselines[p]                   # the baseline's runs: the screen's, the refits' and the test's
        chosen, _ = screen(base, reps, fold.train, log=log, preds0=preds0)
        chosen, fit, dropped = fit_chosen(base, chosen, reps, fold.train, preds0=preds0)
        test_names = set(fold.test)
        # nothing kept: the diagnosed model is the baseline, whose runs are made
        preds1 = ({n: preds0[n] for n in test_names} if not fit.values else
                  predict_all(effect_spec(base, fit.values), reps, test_names))
        before = rms_by_coord(preds0, reps, fold.test)
        after = rms_by_coord(preds1, reps, fold.test)
        out.append({"fold": fold.name, "pressure_kpa": p, "effects": [key(*c) for c in chosen],
                    "values": {key(*c): v for c, v in fit.values.items()},
                    "ci95": {key(*c): list(v) for c, v in fit.ci95.items()},
                    "dropped": [key(*c) for c in dropped],
                    "rmse_heldout_before": before, "rmse_heldout_after": after,
                    "runs": {"baseline": {n: preds0[n] for n in test_names}, "diagnosed": preds1}})
        if log:
            log(f"fold {fold.name}: {'+'.join(out[-1]['effects']) or 'nothing'}; held out {before} -> {after}")
    return out


def fold_summary(fold: dict) -> dict:
    """A fold of `held_out` without its runs (what a JSON summary keeps)."""
    return {k: v for k, v in fold.items() if k != "runs"}
