"""Time stepping and Hermite sampling of the reduced models, batched over parameter sets.

Two integrators and two samplers live here side by side.  They are different algorithms (and
differ in floating-point detail), each tuned to its caller's accuracy needs; unifying them would
change every number downstream, so both stay:

* :func:`rk4_stiction`, RK4 (Nystroem form) with an implicit stiction step, for the planar
  models of the friction fits (:mod:`roboball.reduced.planar`; its compiled twin is
  :mod:`roboball.reduced.kernel`).  Stored q and q' are sampled by :func:`sample` at times
  shared by all rows.
* :func:`midpoint`, explicit midpoint (RK2), for the diagnosis models (:mod:`roboball.reduced.stand`,
  :mod:`roboball.reduced.shell`; the ramp's two-body model runs its own midpoint loop with a
  contact mode, :mod:`roboball.reduced.ramp`).  The diagnosis samples their outputs by cubic
  Hermite interpolation at times given per batch column
  (:func:`roboball.reduced.compiled.sample_outputs`).

RK4 with an implicit step for stiff stiction
--------------------------------------------
Measured against a 10 us reference on 8 s, 1.2 rad steer swings (see ``tests/reduced/test_planar.py``
and :func:`roboball.reduced.planar.step_error`), the candidates compare as follows:

* semi-implicit (symplectic) Euler is first order in the output: ~dt*omega/2 relative
  error, 1-3 mrad at 1 ms on these swings, and ~0.3 % energy oscillation;
* Rosenbrock/W methods (RODAS3, ROS34PW2) are L-stable but lose badly when the friction
  slope changes by orders of magnitude within a step (the Jacobian is frozen at the step
  start): 1-30 mrad errors at 2-5 ms;
* RK4 (here in its Nystroem form for q'' = a(q, q'), 4 force evaluations) reaches 4e-6 rad
  at 5 ms for Table I Majd friction and 2e-4 to 7e-4 rad for dry-friction laws whose kink at
  zero speed limits any fixed-step method to low order there.  The chosen default step
  ``planar.DEFAULT_DT`` = 2.5 ms keeps the dry-friction error near 2e-4 rad, below the 1 mrad
  quantisation of the stand logs, at half the cost of 1 ms RK2/RK4 steps.

Coulomb + viscous friction (eq. 2) jumps at its stiction band's edges |q'| = v_tol.  Outside the
stiff regime below, its steps are cut where the rate crosses an edge (placed by linear
interpolation of the rate over the trial step) and each part is an RK4 step on its side's own
smooth branch (:func:`_edge_steps`; ``friction.coulomb_viscous(side=...)``): the error against
Radau falls from 2.3e-4 to 7.1e-6 rad at 2.5 ms on a 1.2 rad Table I swing, and the trajectory
moves smoothly with the parameters, which the friction posterior's sampler needs
(``tests/reduced/test_planar.py``).

RK4 alone fails on stiff stiction (a continuous law whose slope at zero speed is huge, as
Majd's law becomes for small omega_c): once the body stops, RK4 chatters across zero speed
and the chatter makes it creep spuriously (5 mrad in 3 s at 5 ms for omega_c = 1e-5 rad/s).
Therefore a walker whose friction slope s satisfies dt * s / M > ``planar.STIFF_KAPPA``
somewhere (the stiff speed band |q'| < v_band, :func:`stiff_band`, found once per call on a
logarithmic speed grid) takes, at every step where it is inside that band or about to cross
zero speed, a fully implicit (backward) Euler step in velocity instead:

    alpha w = q'_n + dt / M (tau_o(q_n, q'_n) + tau_friction(w)),  q_{n+1} = q_n + dt w,

with gravity linearised in q (alpha = 1 - dt^2 V''/M), solved per walker by a bracketed,
safeguarded Newton iteration (:func:`implicit_step`).  It is L-stable and captures stick,
break-away and the slow creep of continuous stiction laws; it only runs on steps where some
walker needs it.

Explicit midpoint
-----------------
A fixed step, 2 ms by default (``roboball.reduced.base.DT``).  The dry-friction laws switch sign
within a step, so the method is only first order there, but at 2 ms the simulation error of a
1-rad pendulum with 0.6 N m Coulomb friction is 0.3 mrad after fitting (below the sensors' 1 mrad
quantisation), against 1.8 mrad for semi-implicit Euler.
"""
from __future__ import annotations

import inspect
from dataclasses import dataclass
from typing import Callable, Mapping, Protocol

import numpy as np

from roboball.errors import RoboballError
from roboball.physics import friction

__all__ = ["NEWTON_MAX_IT", "PlanarEquation", "Trajectory", "friction_function", "stiff_band",
           "rk4_stiction", "implicit_step", "sample", "sample_rows", "midpoint"]

NEWTON_MAX_IT = 40          # iteration cap of the implicit step (the compiled loop freezes the same)
EDGE_EVENTS_MAX = 4         # band edges located within one step (a row that chatters on an edge
                            # finishes its step on the branch it reached)


class PlanarEquation(Protocol):
    """The coefficients of M(q) q'' + M'(q) q'^2 / 2 + V'(q) = tau that the time loops read
    (a :class:`roboball.reduced.planar.PlanarModel`)."""

    inertia0_kg_m2: float
    mass_moment_kg_m: float
    offset_rad: float
    radius_m: float
    g: float

    @property
    def constant_inertia(self) -> bool: ...


@dataclass
class Trajectory:
    """States at every step: times ``t`` (n+1,) from the start, ``q`` and ``qd`` (n+1, B);
    ``work`` (n+1, B): work done by friction + extra torque since the start (or None)."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    work: np.ndarray | None
    dt: float
    implicit_steps: int = 0      # steps with an implicit stiction step (compiled loop: most of any row)


def friction_function(law: str, params: Mapping, side=None) -> Callable | None:
    """tau(v) of law `law` from roboball.physics.friction with the given (batched) parameters
    (None for the law "none"); `side` (Coulomb + viscous only, one per row) holds each row on one
    branch of the law (friction.coulomb_viscous).

    The parameter arguments are bound once so the time loop calls the law function directly.
    """
    if law not in friction.LAWS:
        raise RoboballError(f"unknown friction law '{law}' (choose from {', '.join(friction.LAWS)})")
    if law == "none":
        return None
    missing = [k for k in friction.PARAMS[law] if k not in params and not (law == "coulomb_viscous" and k == "v_tol")]
    if missing:
        raise RoboballError(f"friction law '{law}': missing parameter(s) {', '.join(missing)}")
    fn = getattr(friction, law)
    kw = {k: params[k] for k in friction.PARAMS[law] if k in params}
    if side is not None:
        kw["side"] = side
    return lambda v: fn(v, **kw)


# ---------------------------------------------------------------------------------------------
# RK4 (Nystroem) with the implicit stiction step
# ---------------------------------------------------------------------------------------------
def stiff_band(ffun, inv_m_max, dt, kappa, batch):
    """Per walker: the largest speed below which dt * slope / M exceeds kappa (0 if nowhere),
    and the friction slope at zero speed.  Slopes by forward differences on a log grid."""
    grid = np.concatenate([[0.0], np.logspace(-10, 1.5, 70)])[:, None]
    v = grid + np.zeros((1, batch))
    dv = np.maximum(1e-7 * grid, 1e-13)
    slope = -(ffun(v + dv) - ffun(v)) / dv          # >= 0 where friction dissipates
    stiff = dt * slope * inv_m_max > kappa
    band = np.where(stiff.any(axis=0), np.max(np.where(stiff, grid * 1.5 + 1e-12, 0.0), axis=0), 0.0)
    return band, np.maximum(slope[0], 0.0)


def _acceleration(model: PlanarEquation, ffun, etor, params, m0):
    """accel(q, q') -> (acceleration, non-conservative torque) at an RK4 stage; `m0` is M0 (a
    number, or one per row)."""
    gG = model.g * model.mass_moment_kg_m
    beta = model.offset_rad
    const_m = model.constant_inertia
    inv_m0 = 1.0 / m0
    RG = model.radius_m * model.mass_moment_kg_m

    def accel(qq, vv):
        s = np.sin(qq + beta)
        tau = ffun(vv) if ffun is not None else 0.0
        if etor is not None:
            tau = tau + etor(qq, vv, params)
        if const_m:
            return (tau - gG * s) * inv_m0, tau
        m = m0 - 2.0 * RG * np.cos(qq + beta)
        return (tau - s * (gG + RG * vv * vv)) / m, tau

    return accel


def _rk4_step(accel, q, v, h, h2, record_work):
    """One RK4 (Nystroem) step: (q1, v1, stage power sum or None)."""
    a1, t1 = accel(q, v)
    qh = q + (0.5 * h) * v
    v2 = v + (0.5 * h) * a1
    a2, t2 = accel(qh, v2)
    v3 = v + (0.5 * h) * a2
    a3, t3 = accel(qh + (0.25 * h2) * a1, v3)
    qf = q + h * v
    v4 = v + h * a3
    a4, t4 = accel(qf + (0.5 * h2) * a2, v4)
    q_new = qf + (h2 / 6.0) * (a1 + a2 + a3)
    v_new = v + (h / 6.0) * (a1 + 2.0 * (a2 + a3) + a4)
    power = (t1 * v + 2.0 * (t2 * v2 + t3 * v3) + t4 * v4) if record_work else None
    return q_new, v_new, power


def _side(v, v_tol):
    """The branch of Coulomb + viscous friction each rate is on (friction.coulomb_viscous)."""
    return np.where(np.abs(v) < v_tol, friction.BAND, np.where(v > 0.0, 1.0, -1.0))


def _edge_steps(accel_on, q, v, h, v_tol, record_work):
    """One step of length h of every row under Coulomb + viscous friction with the band's edges
    located: a step that would cross an edge (where the torque jumps) is cut at the crossing,
    placed by linear interpolation of the rate, and each part is an RK4 step on its side's own
    smooth branch (`accel_on(side)`), so the trajectory moves smoothly with the parameters.  The
    compiled loop's ``_edge_step`` is the same algorithm.  Returns (q1, v1, work increment or None)."""
    side = _side(v, v_tol)
    rest = np.full(q.shape, float(h))
    q1, v1 = np.empty_like(q), np.empty_like(v)
    work = np.zeros_like(q) if record_work else None
    active = np.ones(q.shape, dtype=bool)
    for _ in range(EDGE_EVENTS_MAX):
        qt, vt, pw = _rk4_step(accel_on(side), q, v, rest, rest * rest, record_work)
        cross = active & (_side(vt, v_tol) != side)
        done = active & ~cross
        q1[done], v1[done] = qt[done], vt[done]
        if record_work:
            work[done] += (rest[done] / 6.0) * pw[done]
        if not cross.any():
            return q1, v1, work
        edge = np.where(side == friction.BAND, np.where(vt > 0.0, v_tol, -v_tol), side * v_tol)
        with np.errstate(divide="ignore", invalid="ignore"):
            frac = np.minimum(np.maximum((edge - v) / (vt - v), 0.0), 1.0)
        hs = np.where(cross, frac * rest, 0.0)
        qs, vs, ps = _rk4_step(accel_on(side), q, v, hs, hs * hs, record_work)
        q, v = np.where(cross, qs, q), np.where(cross, vs, v)
        if record_work:
            work += np.where(cross, (hs / 6.0) * ps, 0.0)
        side = np.where(cross, np.where(side == friction.BAND, np.where(edge > 0.0, 1.0, -1.0), friction.BAND), side)
        rest = np.where(cross, rest - hs, rest)
        over = cross & (rest <= 0.0)
        q1[over], v1[over] = q[over], v[over]
        active = cross & (rest > 0.0)
    qt, vt, pw = _rk4_step(accel_on(side), q, v, rest, rest * rest, record_work)
    q1[active], v1[active] = qt[active], vt[active]
    if record_work:
        work[active] += (rest[active] / 6.0) * pw[active]
    return q1, v1, work


def _stiction_rows(model: PlanarEquation, law, params, etor, q, v, q_new, v_new, h, band, slope0, stiff_rows, m0):
    """Replace the RK4 step by the implicit one on the rows that need it (in place in q_new,
    v_new).  Returns None when no row was inside its stiff band or crossing zero speed, else
    (rows replaced, their torque, their new rate)."""
    in_band = np.abs(v) < band
    flag = stiff_rows & (in_band | (np.abs(v_new) < band) | (v * v_new < 0.0))
    if not flag.any():
        return None
    idx = np.nonzero(flag)[0]
    sub = {k: (val[idx] if np.ndim(val) > 0 else val) for k, val in params.items()}
    m0_rows = m0[idx] if np.ndim(m0) > 0 else m0
    qi, vi, ti = implicit_step(model, friction_function(law, sub), etor, sub, q[idx], v[idx], h, slope0[idx], m0_rows)
    # a crossing of zero speed that does not stick stays with RK4 (higher order);
    # inside the stiff band, or when the implicit step sticks, take the implicit one
    take = in_band[idx] | (np.abs(vi) < band[idx])
    rows = idx[take]
    q_new[rows] = qi[take]
    v_new[rows] = vi[take]
    return rows, ti[take], vi[take]


def rk4_stiction(model: PlanarEquation, law: str, params: Mapping, ffun, q, v, n: int, dt: float,
                 extra_torque: Callable | None = None, record_work: bool = False,
                 band=None, slope0=None, inertia0=None) -> Trajectory:
    """The NumPy time loop: n RK4 steps of the batch (q, v: (B,)) with the implicit stiction
    step on the rows whose stiff `band` (from :func:`stiff_band`; None: no stiff rows) needs it.

    Args:
        ffun: the law bound to `params` (:func:`friction_function`), or None.
        extra_torque: ``extra_torque(q, qd, params)``, added to the friction torque.
        record_work: also integrate the work of friction + extra torque.
        inertia0: M0 per row (B,), or None for the model's.
    Returns:
        The :class:`Trajectory` at every step.
    """
    B = q.size
    h, h2 = dt, dt * dt
    m0 = model.inertia0_kg_m2 if inertia0 is None else np.asarray(inertia0, dtype=float)
    accel = _acceleration(model, ffun, extra_torque, params, m0)
    # Coulomb + viscous friction outside the stiff regime: the band's edges located (_edge_steps)
    edge_rows = None
    if law == "coulomb_viscous" and ffun is not None:
        edge_rows = np.ones(B, dtype=bool) if band is None else ~(band > 0)
        edge_rows = edge_rows if edge_rows.any() else None
    if edge_rows is not None:
        v_tol = params.get("v_tol", inspect.signature(friction.coulomb_viscous).parameters["v_tol"].default)
        v_tol = np.broadcast_to(np.asarray(v_tol, dtype=float), (B,))

        def accel_on(side):
            return _acceleration(model, friction_function(law, params, side), extra_torque, params, m0)
    all_edges = edge_rows is not None and edge_rows.all()
    Q = np.empty((n + 1, B))
    V = np.empty((n + 1, B))
    W = np.zeros((n + 1, B)) if record_work else None
    Q[0], V[0] = q, v
    work = np.zeros(B)
    stiff_rows = band > 0 if band is not None and np.any(band > 0) else None
    n_impl = 0
    for i in range(n):
        if not all_edges:                     # the plain step, for the rows not on edge steps
            q_new, v_new, power = _rk4_step(accel, q, v, h, h2, record_work)
            if record_work:
                work_new = work + (h / 6.0) * power
        if edge_rows is not None:
            qe, ve, we = _edge_steps(accel_on, q, v, h, v_tol, record_work)
            q_new, v_new = (qe, ve) if all_edges else (np.where(edge_rows, qe, q_new), np.where(edge_rows, ve, v_new))
            if record_work:
                work_new = work + we if all_edges else np.where(edge_rows, work + we, work_new)
        if stiff_rows is not None:
            fixed = _stiction_rows(model, law, params, extra_torque, q, v, q_new, v_new, h, band, slope0, stiff_rows, m0)
            if fixed is not None:
                n_impl += 1
                rows, ti, vi = fixed
                if record_work:
                    work_new[rows] = work[rows] + h * ti * vi
        q, v = q_new, v_new
        Q[i + 1], V[i + 1] = q, v
        if record_work:
            work = work_new
            W[i + 1] = work
    return Trajectory(np.arange(n + 1) * dt, Q, V, W, dt, n_impl)


def implicit_step(model: PlanarEquation, ffun, etor, params, q, v, h, slope0, inertia0=None):
    """Backward-Euler step in velocity (gravity linearised in q); returns (q1, v1, tau(v1)).
    `inertia0`: M0 of these rows (None: the model's)."""
    s = np.sin(q + model.offset_rad)
    c_ = np.cos(q + model.offset_rad)
    gG = model.g * model.mass_moment_kg_m
    RG = model.radius_m * model.mass_moment_kg_m
    m = (model.inertia0_kg_m2 if inertia0 is None else inertia0) - 2.0 * RG * c_
    tau_o = -s * (gG + RG * v * v)
    e = 0.0
    if etor is not None:
        e = etor(q, v, params)
        tau_o = tau_o + e
    kq = -gG * c_                                   # d(-V')/dq
    hm = h / m
    alpha = 1.0 - h * hm * kq
    c = v + hm * tau_o
    w_free = c / alpha
    f_free = ffun(w_free)
    w_slip = (c + hm * f_free) / alpha
    sgn = np.sign(c)
    lo = np.minimum(0.0, w_free)
    hi = np.maximum(0.0, w_free)
    w_stick = c / (alpha + hm * slope0)
    w = np.where(sgn * w_slip > 0, w_slip, np.where((sgn * v > 0) & (np.abs(v) < np.abs(w_free)), v, w_stick))
    scale = np.abs(c) + 1e-300
    f = ffun(w)
    for _ in range(NEWTON_MAX_IT):
        r = alpha * w - c - hm * f
        done = np.abs(r) <= 1e-11 * scale + 1e-14
        if done.all():
            break
        # r is increasing in w: shrink the bracket with the sign of r
        hi = np.where(r > 0, np.minimum(hi, w), hi)
        lo = np.where(r < 0, np.maximum(lo, w), lo)
        dw = np.maximum(1e-7 * np.abs(w), 1e-13)
        dfdw = (ffun(w + dw) - f) / dw
        rp = alpha - hm * dfdw
        w_n = w - r / np.where(rp > 0.05 * alpha, rp, alpha)
        bad = ~((w_n > lo) & (w_n < hi))
        w_n = np.where(bad, 0.5 * (lo + hi), w_n)
        w = np.where(done, w, w_n)
        f = ffun(w)
    return q + h * w, w, f + e


def sample(traj: Trajectory, t, rows: slice | np.ndarray | None = None) -> np.ndarray:
    """Cubic Hermite interpolation of q at times `t` (from the trajectory's start; (n_t,), or
    (B_rows, n_t) for times of each row: :func:`sample_rows`).

    Returns (B_rows, n_t).  Times before the start give the initial value (the body is held
    until released); times after the end are an error of the caller (the trajectory is
    always integrated past the last requested time).
    """
    t = np.asarray(t, dtype=float)
    if t.ndim == 2:
        return sample_rows(traj, t, rows)
    Q, Vd, k, u, dt = _cell(traj, t, rows)
    u2, u3 = u * u, u * u * u
    h00 = (2 * u3 - 3 * u2 + 1)[:, None]
    h10 = (u3 - 2 * u2 + u)[:, None] * dt
    h01 = (-2 * u3 + 3 * u2)[:, None]
    h11 = (u3 - u2)[:, None] * dt
    out = h00 * Q[k] + h10 * Vd[k] + h01 * Q[k + 1] + h11 * Vd[k + 1]
    return out.T


def _cell(traj: Trajectory, t: np.ndarray, rows) -> tuple:
    """(Q, Vd, k, u, dt): the trajectory's rows, each time's step index k and its fraction u of
    that step (times clipped to the trajectory) for :func:`sample` and :func:`sample_rows`."""
    Q = traj.q if rows is None else traj.q[:, rows]
    Vd = traj.qd if rows is None else traj.qd[:, rows]
    n = Q.shape[0] - 1
    dt = traj.dt
    tc = np.clip(t, 0.0, n * dt)
    k = np.minimum((tc / dt).astype(int), n - 1)
    return Q, Vd, k, (tc - k * dt) / dt, dt


def sample_rows(traj: Trajectory, t: np.ndarray, rows: slice | np.ndarray | None = None) -> np.ndarray:
    """:func:`sample` with times of each row, `t` (B_rows, n_t) (e.g. releases whose instant is
    fitted per walker); returns (B_rows, n_t)."""
    Q, Vd, k, u, dt = _cell(traj, t, rows)
    u2, u3 = u * u, u * u * u
    c = np.arange(Q.shape[1])[:, None]
    return ((2 * u3 - 3 * u2 + 1) * Q[k, c] + (u3 - 2 * u2 + u) * dt * Vd[k, c]
            + (-2 * u3 + 3 * u2) * Q[k + 1, c] + (u3 - u2) * dt * Vd[k + 1, c])


# ---------------------------------------------------------------------------------------------
# Explicit midpoint (the diagnosis models)
# ---------------------------------------------------------------------------------------------
def midpoint(accel, q0, v0, n_steps, dt):
    """Explicit midpoint integration of qdd = accel(q, v) for a batch; returns Q, V.
    (In-place NumPy operations: the per-step cost is Python overhead, not arithmetic.)"""
    B = q0.shape[0]
    Q = np.empty((n_steps + 1, B))
    V = np.empty((n_steps + 1, B))
    q = q0.astype(float).copy()
    v = v0.astype(float).copy()
    qm, vm, tmp = np.empty(B), np.empty(B), np.empty(B)
    Q[0], V[0] = q, v
    h2 = 0.5 * dt
    mul, add = np.multiply, np.add
    for k in range(1, n_steps + 1):
        a1 = accel(q, v)
        mul(v, h2, out=tmp)
        add(q, tmp, out=qm)
        mul(a1, h2, out=tmp)
        add(v, tmp, out=vm)
        a2 = accel(qm, vm)
        mul(vm, dt, out=tmp)
        q += tmp
        mul(a2, dt, out=tmp)
        v += tmp
        Q[k] = q
        V[k] = v
    return Q, V
