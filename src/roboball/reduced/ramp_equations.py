"""The planar ramp model's equations (roboball.reduced.ramp, whose docstring derives them), written
once for both of its loops: the NumPy loop (batch arrays, m = roboball.physics.mathns.NP) and the
compiled loop (one row's floats, m = roboball.physics.mathns.scalar(); roboball.reduced.compiled).

Each function is plain arithmetic on its arguments, so the same text gives both loops the same
operations in the same order, and under the pipeline's pinned numerics the same bits.  Choosing
per row between rolling and sliding (np.where on a batch, `if` on a row) is the caller's, and so
is the drive joint's Majd friction (roboball.physics.friction.majd, the law itself, on q_d' =
beta' - theta'): Numba compiles a call to a law it has been handed compiled, not one looked up
in a module.

`k` is the model's constants as `constants` returns them (SI units throughout: kg, m, s, rad).
"""
from __future__ import annotations

import math


def constants(model, alpha=None) -> tuple:
    """(M, m_p z_c, I_p + m_p z_c^2, M R^2 + I_s, M g sin(alpha), M g cos(alpha), m_p g z_c, R,
    alpha, mu, I_s) of a RampModel, as floats; on the ramp of angle `alpha` (rad) if given, else
    the model's."""
    M = model.m_s + model.m_p
    mz = model.m_p * model.z_c
    R, g = model.radius, model.g
    a = model.alpha if alpha is None else float(alpha)
    return (float(M), float(mz), float(model.i_p + model.m_p * model.z_c ** 2),
            float(M * R * R + model.i_s), float(M * g * math.sin(a)), float(M * g * math.cos(a)),
            float(model.m_p * g * model.z_c), float(R), float(a), float(model.mu), float(model.i_s))


def terms(be, wb, tau_d, k, m):
    """The terms both contact modes share: cos and sin(beta - alpha), and the right-hand sides of
    the slope's and the pendulum's equations."""
    mz, a, g_s, mgz = k[1], k[8], k[4], k[6]
    cba = m.cos(be - a)
    sba = m.sin(be - a)
    rhs_s = g_s + mz * sba * wb * wb
    rhs_b = mgz * m.sin(be) + tau_d
    return cba, sba, rhs_s, rhs_b


def rolling(cba, sba, rhs_s, rhs_b, wb, q_th, k):
    """Rolling (s'' = R theta''): (s'', theta'', beta'', the friction force rolling needs, the
    normal force), with q_th the generalised force on theta (drive friction and effects)."""
    mz, m22, m11, n0, R, i_s = k[1], k[2], k[3], k[5], k[7], k[10]
    m12 = mz * R * cba
    det = m11 * m22 - m12 * m12
    f1 = R * rhs_s + q_th
    th_r = (m22 * f1 - m12 * rhs_b) / det
    be_r = (m11 * rhs_b - m12 * f1) / det
    f_req = (q_th - i_s * th_r) / R
    normal = n0 + mz * (-sba * be_r - cba * wb * wb)
    return R * th_r, th_r, be_r, f_req, normal


def sliding(cba, rhs_s, rhs_b, q_th, normal, direction, k, m):
    """Sliding, the friction force mu N in `direction` (+1 up the slope): (s'', theta'', beta'')."""
    M, mz, m22, R, mu, i_s = k[0], k[1], k[2], k[7], k[9], k[10]
    f = mu * m.maximum(normal, 0.0) * direction
    mc = mz * cba
    det_s = M * m22 - mc * mc
    s_sl = (m22 * (rhs_s + f) - mc * rhs_b) / det_s
    be_sl = (M * rhs_b - mc * (rhs_s + f)) / det_s
    th_sl = (q_th - R * f) / i_s
    return s_sl, th_sl, be_sl


def exceeds_cone(f_req, normal, k, m):
    """Whether rolling needs more friction than Coulomb's cone gives (mu N): a rolling shell
    starts to slide, with friction in the direction m.sign(f_req)."""
    return m.abs(f_req) > k[9] * m.maximum(normal, 0.0)


def slip_reversed(vs, w, direction, k):
    """Whether a sliding shell's slip velocity s' - R theta' has turned so that friction would
    now push it on: the shell sticks again."""
    return (vs - k[7] * w) * direction > 0


def restick(vs, w, k):
    """Plastic re-stick: the common rolling speed from the shell's momentum about the contact,
    as (s', theta')."""
    M, R, i_s = k[0], k[7], k[10]
    w_new = (M * R * vs + i_s * w) / (M * R * R + i_s)
    return R * w_new, w_new
