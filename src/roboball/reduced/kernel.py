"""Compiled time loop of the reduced planar model (Numba): the same algorithm, no Python per step.

Why: the friction posterior simulates every walker's releases at every MCMC step.  The NumPy
loop :func:`roboball.reduced.integrate.rk4_stiction` pays ~15 array operations per RK4 stage in
Python, about 80 us per step for a batch of 128 rows, which made a converged Majd posterior take
half an hour.
Here each batch row runs the identical algorithm in machine code (rows in parallel threads):

* RK4 in its Nystroem form, the same stage formulas and operation order as ``rk4_stiction``;
* under Coulomb + viscous friction outside the stiff regime, the same cuts at the stiction
  band's edges (``_edge_step``, ``integrate._edge_steps``);
* the backward-Euler stiction step with the bracketed, safeguarded Newton iteration of
  ``integrate.implicit_step`` (the same ``NEWTON_MAX_IT``), taken on the same steps (stiff
  band, zero crossings that stick);
* the friction torque from the law functions of :mod:`roboball.physics.friction` themselves,
  compiled with the scalar math namespace :func:`roboball.physics.mathns.scalar`: nothing here
  re-implements a law.

Scope: friction law only (no ``extra_torque`` callable and no work record; those runs stay on the
NumPy loop).  ``tests/reduced/test_kernel.py`` checks that both loops give the same trajectories
(within 1e-9 rad; they differ only by the last bits of exp/sin between libm and NumPy).
Results do not depend on the number of threads: rows are independent.

The loop is cached on disk like the diagnosis's (roboball.reduced.jitcache): compiling it took
1.6 s of every friction fit.  The module imports Numba; roboball.reduced.planar imports it only
where the compiled loop runs.
"""
from __future__ import annotations

import inspect
import math

import numpy as np
from numba import prange

from roboball.physics import friction
from roboball.physics.mathns import scalar
from roboball.reduced.integrate import EDGE_EVENTS_MAX, NEWTON_MAX_IT
from roboball.reduced.jitcache import cached_jit

__all__ = ["supports", "integrate_rows"]

M = scalar()
BAND = friction.BAND

# the laws of the compiled loop, each with its parameters in ``friction.PARAMS[law]`` order
LAW_CODES = {"viscous": 0, "coulomb_viscous": 1, "majd": 2}
_viscous = cached_jit()(friction.viscous)
_coulomb_viscous = cached_jit()(friction.coulomb_viscous)
_majd = cached_jit()(friction.majd)


def supports(law: str, extra_torque, record_work: bool) -> bool:
    """True when the compiled loop can run this batch: a friction law alone, no work record."""
    return extra_torque is None and not record_work and law in LAW_CODES


@cached_jit(inline="always")
def _friction(law, v, p, side):
    """The torque of law `law` (LAW_CODES) with parameters p at joint rate v; `side` != 0 holds
    Coulomb + viscous friction on one branch (friction.coulomb_viscous)."""
    if law == 0:
        return _viscous(v, p[0], M)
    if law == 1:
        if side == 0.0:
            return _coulomb_viscous(v, p[0], p[1], p[2], p[3], M)
        return _coulomb_viscous(v, p[0], p[1], p[2], p[3], M, side)
    return _majd(v, p[0], p[1], p[2], p[3], p[4], M)


@cached_jit(inline="always")
def _accel(law, side, q, v, p, gG, beta, const_m, inv_m0, M0, RG):
    """The acceleration of one RK4 stage (inlined into the loop)."""
    s = math.sin(q + beta)
    tau = _friction(law, v, p, side)
    if const_m:
        return (tau - gG * s) * inv_m0
    mm = M0 - 2.0 * RG * math.cos(q + beta)
    return (tau - s * (gG + RG * v * v)) / mm


@cached_jit()
def _implicit(law, q, v, p, h, slope0, gG, beta, M0, RG):
    """The backward-Euler stiction step: (q1, v1)."""
    s = math.sin(q + beta)
    c_ = math.cos(q + beta)
    mm = M0 - 2.0 * RG * c_
    tau_o = -s * (gG + RG * v * v)
    kq = -gG * c_
    hm = h / mm
    alpha = 1.0 - h * hm * kq
    c = v + hm * tau_o
    w_free = c / alpha
    f_free = _friction(law, w_free, p, 0.0)
    w_slip = (c + hm * f_free) / alpha
    sgn = 1.0 if c > 0.0 else (-1.0 if c < 0.0 else 0.0)
    lo = min(0.0, w_free)
    hi = max(0.0, w_free)
    w_stick = c / (alpha + hm * slope0)
    if sgn * w_slip > 0:
        w = w_slip
    elif sgn * v > 0 and abs(v) < abs(w_free):
        w = v
    else:
        w = w_stick
    scale = abs(c) + 1e-300
    f = _friction(law, w, p, 0.0)
    for _ in range(NEWTON_MAX_IT):      # the NumPy loop's cap, frozen into the kernel
        r = alpha * w - c - hm * f
        if abs(r) <= 1e-11 * scale + 1e-14:
            break
        if r > 0:
            hi = min(hi, w)
        if r < 0:
            lo = max(lo, w)
        dw = max(1e-7 * abs(w), 1e-13)
        dfdw = (_friction(law, w + dw, p, 0.0) - f) / dw
        rp = alpha - hm * dfdw
        w_n = w - r / (rp if rp > 0.05 * alpha else alpha)
        if not (w_n > lo and w_n < hi):
            w_n = 0.5 * (lo + hi)
        w = w_n
        f = _friction(law, w, p, 0.0)
    return q + h * w, w


@cached_jit(inline="always")
def _rk4(law, side, q, v, h, p, gG, beta, const_m, inv_m0, M0, RG):
    """One RK4 (Nystroem) step of length h: (q1, v1)."""
    h2 = h * h
    a1 = _accel(law, side, q, v, p, gG, beta, const_m, inv_m0, M0, RG)
    qh = q + (0.5 * h) * v
    v2 = v + (0.5 * h) * a1
    a2 = _accel(law, side, qh, v2, p, gG, beta, const_m, inv_m0, M0, RG)
    v3 = v + (0.5 * h) * a2
    a3 = _accel(law, side, qh + (0.25 * h2) * a1, v3, p, gG, beta, const_m, inv_m0, M0, RG)
    qf = q + h * v
    v4 = v + h * a3
    a4 = _accel(law, side, qf + (0.5 * h2) * a2, v4, p, gG, beta, const_m, inv_m0, M0, RG)
    return qf + (h2 / 6.0) * (a1 + a2 + a3), v + (h / 6.0) * (a1 + 2.0 * (a2 + a3) + a4)


@cached_jit(inline="always")
def _side(v, v_tol):
    """The branch of Coulomb + viscous friction that rate v is on (friction.coulomb_viscous)."""
    if abs(v) < v_tol:
        return BAND
    return 1.0 if v > 0.0 else -1.0


@cached_jit()
def _edge_step(q, v, h, p, gG, beta, const_m, inv_m0, M0, RG):
    """One step of length h under Coulomb + viscous friction with the band's edges located
    (at most integrate.EDGE_EVENTS_MAX, as in the NumPy loop): (q1, v1)."""
    v_tol = p[3]
    side = _side(v, v_tol)
    rest = h
    for _ in range(EDGE_EVENTS_MAX):
        q1, v1 = _rk4(1, side, q, v, rest, p, gG, beta, const_m, inv_m0, M0, RG)
        side1 = _side(v1, v_tol)
        if side1 == side:
            return q1, v1
        edge = (v_tol if v1 > 0.0 else -v_tol) if side == BAND else side * v_tol
        frac = min(max((edge - v) / (v1 - v), 0.0), 1.0)
        hs = frac * rest
        q, v = _rk4(1, side, q, v, hs, p, gG, beta, const_m, inv_m0, M0, RG)
        side = (1.0 if edge > 0.0 else -1.0) if side == BAND else BAND
        rest -= hs
        if rest <= 0.0:
            return q, v
    return _rk4(1, side, q, v, rest, p, gG, beta, const_m, inv_m0, M0, RG)


@cached_jit(parallel=True)
def _run(law, P, q0, v0, band, slope0, h, nrow, gG, beta, const_m, M0s, RG, Q, V, n_impl):
    """Every row's RK4 loop with the implicit step (or, Coulomb + viscous friction on a row
    outside the stiff regime, the band's edges located), rows in parallel."""
    for r in prange(q0.size):
        M0 = M0s[r]                 # the row's inertia (a calibrated stand adds to it)
        inv_m0 = 1.0 / M0
        p = P[r]
        q = q0[r]
        v = v0[r]
        b = band[r]
        stiff = b > 0.0
        edges = law == 1 and not stiff
        Q[r, 0] = q
        V[r, 0] = v
        k = 0
        n_r = nrow[r]
        for i in range(n_r):
            if edges:
                q_new, v_new = _edge_step(q, v, h, p, gG, beta, const_m, inv_m0, M0, RG)
            else:
                q_new, v_new = _rk4(law, 0.0, q, v, h, p, gG, beta, const_m, inv_m0, M0, RG)
            if stiff:
                in_band = abs(v) < b
                if in_band or abs(v_new) < b or v * v_new < 0.0:
                    k += 1
                    qi, vi = _implicit(law, q, v, p, h, slope0[r], gG, beta, M0, RG)
                    # as integrate.rk4_stiction: a crossing that does not stick stays with RK4
                    if in_band or abs(vi) < b:
                        q_new = qi
                        v_new = vi
            q = q_new
            v = v_new
            Q[r, i + 1] = q
            V[r, i + 1] = v
        for i in range(n_r + 1, Q.shape[1]):     # a row that stops early holds its last state
            Q[r, i] = q
            V[r, i] = v
        n_impl[r] = k


def integrate_rows(model, law: str, params: dict, q0: np.ndarray, v0: np.ndarray, n: int, dt: float,
                   band: np.ndarray, slope0: np.ndarray, n_rows: np.ndarray | None = None, inertia0=None):
    """Integrate B rows for n steps (or row r for ``n_rows[r] <= n`` steps, holding its last
    state after); returns (Q, V) of shape (B, n + 1) and the most implicit steps of any row.
    `inertia0`: M0 per row (B,) (None: the model's)."""
    B = q0.size
    M0 = np.broadcast_to(np.asarray(model.inertia0_kg_m2 if inertia0 is None else inertia0, dtype=float), (B,))
    names = friction.PARAMS[law]
    law_args = inspect.signature(getattr(friction, law)).parameters    # a missing v_tol: the law's default
    P = np.empty((B, len(names)))
    for j, name in enumerate(names):
        P[:, j] = params[name] if name in params else law_args[name].default
    Q = np.empty((B, n + 1))
    V = np.empty((B, n + 1))
    n_impl = np.zeros(B, dtype=np.int64)
    nrow = np.full(B, int(n), dtype=np.int64) if n_rows is None else np.minimum(np.asarray(n_rows, dtype=np.int64), n)
    _run(LAW_CODES[law], P, np.ascontiguousarray(q0, dtype=float), np.ascontiguousarray(v0, dtype=float),
        np.ascontiguousarray(band, dtype=float), np.ascontiguousarray(slope0, dtype=float),
        float(dt), nrow, float(model.g * model.mass_moment_kg_m), float(model.offset_rad),
        bool(model.constant_inertia), np.ascontiguousarray(M0),
        float(model.radius_m * model.mass_moment_kg_m), Q, V, n_impl)
    return Q, V, int(n_impl.max()) if B else 0

