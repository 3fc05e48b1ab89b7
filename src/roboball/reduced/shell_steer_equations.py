"""The free-steer shell model's equations (roboball.reduced.shell_steer, whose docstring derives
them), written once for both of its loops: the NumPy loop (batch arrays, m =
roboball.physics.mathns.NP) and the compiled loop (one row's floats, m =
roboball.physics.mathns.scalar(); roboball.reduced.compiled).

Each function is plain arithmetic on its arguments, so the same text gives both loops the same
operations in the same order, and under the pipeline's pinned numerics the same bits.  The steer
joint's Majd friction and the diagnosis's effects on the roll are added by the caller between the
two (the laws themselves, roboball.physics: Numba compiles a call to a law it has been handed
compiled, not one looked up in a module).

`geo` is the model's constants as ShellSteerModel.geometry returns them, (ay, az, by, bz, k11,
k12, m22, R, g, rest): each body's first moments m (c_y, c_z), the mass matrix's constant parts
(kg m^2), the rolling radius (m), gravity (m/s^2) and the pipe's rest angle (rad).
"""
from __future__ import annotations


def pendulum_terms(ph, th, v, w, geo, m):
    """(M11, M12, the pipe's generalised force before its effects, g m u_z of the pendulum) at
    the pipe angle ph, the steer joint's angle th and their rates v, w; M22 is constant, geo[6].
    m u_y and m u_z are each body's first moments turned by its angle (u = dP/da; y horizontal,
    z up), and w_y = -u_z, |u| = d fold the rest in (fewer operations: the diagnosis's inner loop)."""
    ay, az, by, bz, k11, k12, R, g = geo[0], geo[1], geo[2], geo[3], geo[4], geo[5], geo[7], geo[8]
    ca, sa = m.cos(ph), m.sin(ph)
    ab = ph + th
    cb, sb = m.cos(ab), m.sin(ab)
    pA = -(ay * sa + az * ca)
    qA = ay * ca - az * sa
    pB = -(by * sb + bz * cb)
    qB = by * cb - bz * sb
    m11 = k11 - 2.0 * R * (pA + pB)
    m12 = k12 - R * pB
    vb = v + w
    f1 = -(qA * (R * v * v + g) + qB * (R * vb * vb + g))
    return m11, m12, f1, g * qB


def solve(m11, m12, m22, f1, f2):
    """(phi'', theta'') from the symmetric 2 x 2 mass matrix and the generalised forces."""
    det = m11 * m22 - m12 * m12
    return (m22 * f1 - m12 * f2) / det, (m11 * f2 - m12 * f1) / det
