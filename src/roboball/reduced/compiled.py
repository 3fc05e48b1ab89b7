"""Compiled time loops of the diagnosis's stand, shell, free-steer shell and ramp models (Numba): the
same explicit midpoint steps and the same effect laws as their NumPy loops, with no Python per
step.

Why: the diagnosis simulates a few hundred parameter sets per batched call on average (a fit's
trial point and its finite differences, a fold, a grid of starts), and at that size the NumPy
loop's cost is its per-step Python and ufunc dispatch (about 30 array operations per
acceleration), not arithmetic: on the real steer log 85% of `roboball diagnose`'s time was in
`midpoint`, the effects' `add` and the laws called from it.  Here every batch row runs its own
loop in machine code (rows in parallel threads; rows are independent, so results do not depend
on the number of threads).  The per-step helpers (each effect's torque, their sum, the
accelerations) are inlined into the loops (`inline="always"`): called, each took the batch's
effect arrays and Numba counted references to them on every call, atomic operations on the
arrays' shared counters; inlined, the free-steer step costs 123 instead of 160 ns, to the bit.

Nothing here re-implements a law: the effect laws of roboball.physics.effects and the Majd law of
roboball.physics.friction are compiled as they are, with the scalar math namespace
(roboball.physics.mathns.scalar).  Each acceleration is written in the same operation order as
its NumPy twin (roboball.reduced.stand, .shell), and the effects are added in the
order ReducedModel.effect_plan gives NumPy (rows where an effect's magnitude is zero get no term:
NumPy adds a signed zero there).  The ramp model's equations (contact mode, derivative) are
not written twice at all, nor are the free-steer shell's: roboball.reduced.ramp_equations and
roboball.reduced.shell_steer_equations serve their NumPy loops and `_run_ramp`, `_run_steer`
alike, compiled here like the laws.  Where NumPy's transcendental functions are libm's (the
pipeline's pinned numerics, roboball.pipeline.numerics) the two loops agree to the bit; with
NumPy's own SIMD functions (a wide CPU, unpinned) they differ in the last bits of sin, exp and
tanh (`tests/reduced/test_compiled.py`).

The kernels are cached on disk (Numba's `cache=True`): the first run in a fresh checkout
compiles them (about 14 s), later processes load them.  The cache's folder is named by a hash of
every source the kernels are built from, so an edit of a law compiles afresh
(roboball.reduced.jitcache).
"""
from __future__ import annotations

import math

import numpy as np
from numba import prange
from numba.extending import overload

from roboball.physics import effects as fx
from roboball.physics import friction as friction_laws
from roboball.physics.mathns import scalar
from roboball.reduced import ramp_equations as req
from roboball.reduced import shell_steer_equations as seq
from roboball.reduced.jitcache import cached_jit

M = scalar()

# effect codes of the compiled dispatch (`_torque`), with each law's parameters in order
CODES = {"viscous_damping": 0, "coulomb_friction": 1, "stiction": 2, "quadratic_drag": 3,
         "linear_stiffness": 4, "cubic_stiffness": 5, "com_offset": 6, "backlash": 7, "rolling_resistance": 8}
_LOG_R, _PEAKS = fx._LOG_R, fx._PEAKS


@overload(fx.stiction_peak)
def _stiction_peak_scalar(v_s):
    """fx.stiction_peak on one width: the creep band's constant itself, else the same table."""
    def impl(v_s):
        if v_s == fx.V_STRIBECK:
            return fx.STICTION_PEAK
        return np.interp(math.log(max(v_s, fx.V_STRIBECK) / fx.V_EPS), _LOG_R, _PEAKS)
    return impl


_viscous = cached_jit()(fx.viscous_damping)
_coulomb = cached_jit()(fx.coulomb_friction)
_stiction = cached_jit()(fx.stiction)
_quadratic = cached_jit()(fx.quadratic_drag)
_linear = cached_jit()(fx.linear_stiffness)
_cubic = cached_jit()(fx.cubic_stiffness)
_offset = cached_jit()(fx.com_offset)
_backlash = cached_jit()(fx.backlash)
_rolling = cached_jit()(fx.rolling_resistance)
_majd = cached_jit()(friction_laws.majd)


@cached_jit(inline="always")
def _torque(code, q, v, a, b, k_g):
    """The torque of effect `code` (CODES) with parameters (a, b) at (q, v)."""
    if code == 0:
        return _viscous(q, v, a, M)
    if code == 1:
        return _coulomb(q, v, a, M)
    if code == 2:
        return _stiction(q, v, a, b, M)
    if code == 3:
        return _quadratic(q, v, a, M)
    if code == 4:
        return _linear(q, v, a, M)
    if code == 5:
        return _cubic(q, v, a, M)
    if code == 6:
        return _offset(q, v, a, k_g, M)
    if code == 7:
        return _backlash(q, v, a, b, M)
    return _rolling(q, v, a, M)


@cached_jit(inline="always")
def _add_effects(tau, q, v, codes, par, r, k_g):
    """tau plus every effect of row r, in the plan's order; an effect whose magnitude is zero on
    the row adds nothing."""
    for e in range(codes.size):
        a = par[e, r, 0]
        if a != 0.0:
            tau += _torque(codes[e], q, v, a, par[e, r, 1], k_g)
    return tau


@cached_jit(inline="always")
def _stand_accel(q, v, r, k_g, c, inv_i, codes, par):
    tau = math.sin(q)
    tau *= -k_g
    tau -= c[r] * v
    tau = _add_effects(tau, q, v, codes, par, r, k_g)
    tau *= inv_i[r]
    return tau


@cached_jit(inline="always")
def _shell_accel(q, v, r, k_g, mrd, mrd2, m0, codes, par):
    s = math.sin(q)
    tau = v * v
    tau *= -mrd
    tau -= k_g
    tau *= s
    tau = _add_effects(tau, q, v, codes, par, r, k_g)
    den = math.cos(q)
    den *= -mrd2
    den += m0
    return tau / den


@cached_jit(parallel=True, nogil=True)
def _run_stand(q0, v0, n_steps, dt, k_g, c, inv_i, codes, par, Q, V):
    h2 = 0.5 * dt
    for r in prange(q0.size):
        q = q0[r]
        v = v0[r]
        Q[r, 0] = q
        V[r, 0] = v
        for k in range(1, n_steps + 1):
            a1 = _stand_accel(q, v, r, k_g, c, inv_i, codes, par)
            qm = q + v * h2
            vm = v + a1 * h2
            a2 = _stand_accel(qm, vm, r, k_g, c, inv_i, codes, par)
            q += vm * dt
            v += a2 * dt
            Q[r, k] = q
            V[r, k] = v


@cached_jit(parallel=True, nogil=True)
def _run_shell(q0, v0, n_steps, dt, k_g, mrd, mrd2, m0, codes, par, Q, V):
    h2 = 0.5 * dt
    for r in prange(q0.size):
        q = q0[r]
        v = v0[r]
        Q[r, 0] = q
        V[r, 0] = v
        for k in range(1, n_steps + 1):
            a1 = _shell_accel(q, v, r, k_g, mrd, mrd2, m0, codes, par)
            qm = q + v * h2
            vm = v + a1 * h2
            a2 = _shell_accel(qm, vm, r, k_g, mrd, mrd2, m0, codes, par)
            q += vm * dt
            v += a2 * dt
            Q[r, k] = q
            V[r, k] = v


_steer_terms = cached_jit()(seq.pendulum_terms)
_steer_solve = cached_jit()(seq.solve)


@cached_jit(inline="always")
def _steer_accel(ph, th, v, w, r, geo, mj, k_g, codes, par):
    """ShellSteerModel.equations' accel for row r (roboball.reduced.shell_steer_equations); geo =
    ShellSteerModel.geometry(), mj = Majd's (f_w, f_c, sigma, omega_c, n)."""
    m11, m12, f1, g_qb = _steer_terms(ph, th, v, w, geo, M)
    f2 = _majd(w, mj[0], mj[1], mj[2], mj[3], mj[4], M) - g_qb
    f1 = _add_effects(f1, ph - geo[9], v, codes, par, r, k_g)
    return _steer_solve(m11, m12, geo[6], f1, f2)


@cached_jit(parallel=True, nogil=True)
def _run_steer(q0, v0, th0, w0, n_steps, dt, geo, mj, k_g, codes, par, Q, V, TH, W):
    h2 = 0.5 * dt
    for r in prange(q0.size):
        ph, th, v, w = q0[r], th0[r], v0[r], w0[r]
        Q[r, 0] = ph
        V[r, 0] = v
        for k in range(1, n_steps + 1):
            a1, b1 = _steer_accel(ph, th, v, w, r, geo, mj, k_g, codes, par)
            vm = v + h2 * a1
            wm = w + h2 * b1
            a2, b2 = _steer_accel(ph + h2 * v, th + h2 * w, vm, wm, r, geo, mj, k_g, codes, par)
            ph += vm * dt
            th += wm * dt
            v += a2 * dt
            w += b2 * dt
            Q[r, k] = ph
            V[r, k] = v
        TH[r] = th
        W[r] = w


_ramp_terms = cached_jit()(req.terms)
_ramp_rolling = cached_jit()(req.rolling)
_ramp_sliding = cached_jit()(req.sliding)
_ramp_exceeds = cached_jit()(req.exceeds_cone)
_ramp_reversed = cached_jit()(req.slip_reversed)
_ramp_restick = cached_jit()(req.restick)


@cached_jit(inline="always")
def _ramp_deriv(th, be, vs, w, wb, sliding, direction, r, k, mj, k_g, codes, par):
    """RampModel._equations' deriv for row r in its contact mode: (s'', theta'', beta'', the
    friction rolling needs, the normal force); k = ramp_equations.constants, mj = Majd's."""
    tau_d = _majd(wb - w, mj[0], mj[1], mj[2], mj[3], mj[4], M)
    q_th = -tau_d
    q_th = _add_effects(q_th, th, w, codes, par, r, k_g)
    cba, sba, rhs_s, rhs_b = _ramp_terms(be, wb, tau_d, k, M)
    a_s, a_th, a_be, f_req, normal = _ramp_rolling(cba, sba, rhs_s, rhs_b, wb, q_th, k)
    if sliding:
        a_s, a_th, a_be = _ramp_sliding(cba, rhs_s, rhs_b, q_th, normal, direction, k, M)
    return a_s, a_th, a_be, f_req, normal


@cached_jit(parallel=True, nogil=True)
def _run_ramp(n_steps, dt, K, mj, k_g, codes, par, Y, Yd):
    """RampModel.simulate's loop, one row per thread, from rest; K (B, 11) each row's constants
    (ramp_equations.constants: a run's own ramp angle), Y, Yd (B, n + 1)."""
    h2 = 0.5 * dt
    for r in prange(Y.shape[0]):
        k = (K[r, 0], K[r, 1], K[r, 2], K[r, 3], K[r, 4], K[r, 5], K[r, 6], K[r, 7], K[r, 8], K[r, 9], K[r, 10])
        th, be, vs, w, wb = 0.0, 0.0, 0.0, 0.0, 0.0
        sliding = False
        direction = 0.0
        as1, a1, b1, f_req, normal = _ramp_deriv(th, be, vs, w, wb, sliding, direction, r, k, mj, k_g, codes, par)
        Y[r, 0] = w
        Yd[r, 0] = a1
        for step in range(1, n_steps + 1):
            # NumPy re-evaluates the first stage of every row when any row slides; a row that
            # neither slides nor starts to gets the same numbers again, so only sliding rows do
            changed = sliding
            if not sliding and _ramp_exceeds(f_req, normal, k, M):
                direction = M.sign(f_req)
                sliding = True
                changed = True
            if sliding and _ramp_reversed(vs, w, direction, k):
                vs, w = _ramp_restick(vs, w, k)
                sliding = False
            if changed:
                as1, a1, b1, f_req, normal = _ramp_deriv(th, be, vs, w, wb, sliding, direction, r, k, mj, k_g,
                                                         codes, par)
            as2, a2, b2, _f, _n = _ramp_deriv(th + h2 * w, be + h2 * wb, vs + h2 * as1, w + h2 * a1, wb + h2 * b1,
                                              sliding, direction, r, k, mj, k_g, codes, par)
            th = th + dt * (w + h2 * a1)
            be = be + dt * (wb + h2 * b1)
            vs = vs + dt * as2
            w = w + dt * a2
            wb = wb + dt * b2
            as1, a1, b1, f_req, normal = _ramp_deriv(th, be, vs, w, wb, sliding, direction, r, k, mj, k_g,
                                                     codes, par)
            Y[r, step] = w
            Yd[r, step] = a1


def ramp_run(model, P: dict, active: list, B: int, n_steps: int, dt: float, k: tuple):
    """roboball.reduced.ramp.RampModel.simulate compiled: (drive rate, its derivative), (n + 1, B)
    each; `k` the rows' constants (RampModel.row_constants: floats, or (B,) arrays)."""
    codes, par = effect_arrays(model, P, active, B)
    Y, Yd = _outputs(B, n_steps)
    K = np.ascontiguousarray(np.column_stack([np.broadcast_to(np.asarray(x, dtype=float), (B,)) for x in k]))
    _run_ramp(int(n_steps), float(dt), K, model.majd_args(), float(model.context["k_g"]),
              codes, par, Y, Yd)
    return Y.T, Yd.T


def effect_arrays(model, P: dict, active: list, B: int):
    """The active force effects of a batch as the kernels take them: codes (E,) in the order
    model.effect_plan adds them, and parameters (E, B, 2) (magnitude, second parameter; a
    magnitude of zero leaves the row without the effect)."""
    plan = model.effect_plan(P, active)
    codes = np.array([CODES[name] for name, _ in plan], dtype=np.int64)
    par = np.zeros((len(plan), B, 2))
    for e, (name, _) in enumerate(plan):
        eff = fx.LIBRARY[name]
        for j, p in enumerate(eff.params):
            key = f"{name}.{p.name}"
            par[e, :, j] = np.asarray(P[key], dtype=float) if key in P else p.default
    return codes, par


class Stepper:
    """A batch simulated a stretch at a time: `advance(n)` runs every row n steps on from where
    the last stretch ended (the first from the start) and returns (Q, V), (n + 1, B) each, the
    stretch's first step included; `keep(rows)` drops the other rows from later stretches.  The
    rows' steps are the whole run's, to the bit: a stretch starts from the state the last one
    ended in (roboball.diagnose.fit.Engine's bounded grids stop simulating hopeless starts)."""

    def __init__(self, run, state: list, per_row: list, fixed: tuple, offset: float = 0.0):
        """`run(*state, n_steps, *per_row, *fixed) -> (Q, V, new state)` (row-major (B, n + 1)
        outputs); `per_row`: (array, axis of its rows)."""
        self._run, self.state, self.per_row, self.fixed, self.offset = run, list(state), list(per_row), fixed, offset

    def advance(self, n_steps: int):
        Q, V, self.state = self._run(self.state, int(n_steps), [a for a, _ in self.per_row], self.fixed)
        out = Q.T
        if self.offset:
            out = out + self.offset
        return out, V.T

    def keep(self, rows) -> None:
        rows = np.asarray(rows, dtype=np.int64)
        self.state = [x[rows] for x in self.state]
        self.per_row = [(np.ascontiguousarray(np.take(a, rows, axis=ax)), ax) for a, ax in self.per_row]


def _stand_run(state, n, rows, fixed):
    q0, v0 = state
    c, inv_i, par = rows
    k_g, dt, codes = fixed
    Q, V = _outputs(q0.size, n)
    _run_stand(q0, v0, n, dt, k_g, c, inv_i, codes, par, Q, V)
    return Q, V, [Q[:, -1].copy(), V[:, -1].copy()]


def _shell_run(state, n, rows, fixed):
    q0, v0 = state
    (par,) = rows
    k_g, mrd, mrd2, m0, dt, codes = fixed
    Q, V = _outputs(q0.size, n)
    _run_shell(q0, v0, n, dt, k_g, mrd, mrd2, m0, codes, par, Q, V)
    return Q, V, [Q[:, -1].copy(), V[:, -1].copy()]


def _steer_run(state, n, rows, fixed):
    q0, v0, th0, w0 = state
    (par,) = rows
    geo, mj, k_g, dt, codes = fixed
    B = q0.size
    Q, V = _outputs(B, n)
    TH, W = np.empty(B), np.empty(B)
    _run_steer(q0, v0, th0, w0, n, dt, geo, mj, k_g, codes, par, Q, V, TH, W)
    return Q, V, [Q[:, -1].copy(), V[:, -1].copy(), TH, W]


def _rows(x, B: int) -> np.ndarray:
    return np.ascontiguousarray(np.broadcast_to(np.asarray(x, dtype=float), (B,)))


def stand_stepper(model, q0, c, inv_i, codes, par, dt: float) -> Stepper:
    """roboball.reduced.stand's loop as a Stepper (q0 from the rest; outputs with the rest added)."""
    B = q0.size
    return Stepper(_stand_run, [_rows(q0, B), np.zeros(B)], [(_rows(c, B), 0), (_rows(inv_i, B), 0), (par, 1)],
                   (float(model.k_g), float(dt), codes), offset=float(model.rest))


def shell_stepper(model, q0, k_g, mrd, mrd2, m0, codes, par, dt: float) -> Stepper:
    """roboball.reduced.shell's loop as a Stepper (q0 from the rest; outputs with the rest added)."""
    B = q0.size
    return Stepper(_shell_run, [_rows(q0, B), np.zeros(B)], [(par, 1)],
                   (float(k_g), float(mrd), float(mrd2), float(m0), float(dt), codes), offset=float(model.rest))


def steer_stepper(model, q0, th0, w0, codes, par, dt: float) -> Stepper:
    """roboball.reduced.shell_steer's loop as a Stepper (pipe angle and rate)."""
    B = q0.size
    geo = tuple(float(x) for x in model.geometry())
    mj = tuple(float(x) for x in model.majd_args())
    return Stepper(_steer_run, [_rows(q0, B), np.zeros(B), _rows(th0, B), _rows(w0, B)], [(par, 1)],
                   (geo, mj, float(model.k_g), float(dt), codes))


def _outputs(B: int, n_steps: int):
    """Row-major (B, n + 1) arrays for the kernels, returned to the caller as (n + 1, B) views."""
    return np.empty((B, n_steps + 1)), np.empty((B, n_steps + 1))


@cached_jit(inline="always")
def hermite_at(Y, Yd, i, c, s, dt):
    """Batch column c's output at the fraction s of step i: the cubic Hermite interpolant of its
    steps' values Y and rates Yd ((n + 1, B)).  The one sample of the diagnosis's outputs (its
    fits' here, its bounded grids' in roboball.diagnose.bounded), inlined where it is used."""
    y0 = Y[i, c]
    y1 = Y[i + 1, c]
    d0 = Yd[i, c] * dt
    d1 = Yd[i + 1, c] * dt
    s2 = s * s
    s3 = s * s * s
    return (2 * s3 - 3 * s2 + 1) * y0 + (s3 - 2 * s2 + s) * d0 + (-2 * s3 + 3 * s2) * y1 + (s3 - s2) * d1


@cached_jit()
def sample_outputs(Y, Yd, dt, tau, cols):
    """The batch's outputs Y and rates Yd ((n + 1, B), the steps) at times `tau` ((n_b, n_s), s
    from the start of batch column cols[j]; a time before 0 takes the initial value): Y by
    `hermite_at`, the rate linearly between steps and 0 before the start; (y, yd), (n_b, n_s)
    each.  Compiled: as NumPy gathers they ran in one thread beside the parallel steps."""
    n = Y.shape[0] - 1
    y = np.empty(tau.shape)
    yd = np.empty(tau.shape)
    for j in range(tau.shape[0]):
        c = cols[j]
        for k in range(tau.shape[1]):
            x = min(max(tau[j, k] / dt, 0.0), n - 1e-9)
            i = int(math.floor(x))
            s = x - i
            y[j, k] = hermite_at(Y, Yd, i, c, s, dt)
            yd[j, k] = 0.0 if tau[j, k] < 0 else (1 - s) * Yd[i, c] + s * Yd[i + 1, c]
    return y, yd
