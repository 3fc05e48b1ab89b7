"""Math namespaces: the few functions a physics law may call.

A law written against `m.exp`, `m.abs`, `m.sign`, `m.where`, `m.tanh`, `m.sqrt` runs on NumPy
arrays (`NP`) and on Drake symbolic expressions (`roboball.sim.forces.SYM`) unchanged.
"""
from types import SimpleNamespace

import numpy as np

NP = SimpleNamespace(
    name="numpy",
    exp=np.exp,
    abs=np.abs,
    sign=np.sign,
    tanh=np.tanh,
    sqrt=np.sqrt,
    sin=np.sin,
    cos=np.cos,
    where=np.where,
    minimum=np.minimum,
    maximum=np.maximum,
)


_SCALAR = None


def scalar():
    """The namespace for compiled scalar code (Numba): the same names, on one float at a time.

    A law function passed through ``numba.njit`` with ``m=scalar()`` compiles to machine code with
    no Python per call; this is how :mod:`roboball.reduced.kernel` runs the very law functions of
    :mod:`roboball.physics.friction` inside its compiled time loop.  Built on first use (importing
    Numba takes a second); ``where`` is the scalar select, ``sign`` is 0 at 0 like ``np.sign``.
    """
    global _SCALAR
    if _SCALAR is None:
        import math
        from collections import namedtuple

        from numba import njit

        names = ("exp", "abs", "sign", "tanh", "sqrt", "sin", "cos", "where", "minimum", "maximum")
        Scalar = namedtuple("Scalar", names)
        _SCALAR = Scalar(
            exp=njit(lambda x: math.exp(x)),
            abs=njit(lambda x: abs(x)),
            sign=njit(lambda x: 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0 * x)),
            tanh=njit(lambda x: math.tanh(x)),
            sqrt=njit(lambda x: math.sqrt(x)),
            sin=njit(lambda x: math.sin(x)),
            cos=njit(lambda x: math.cos(x)),
            where=njit(lambda c, a, b: a if c else b),
            minimum=njit(lambda a, b: min(a, b)),
            maximum=njit(lambda a, b: max(a, b)),
        )
    return _SCALAR
