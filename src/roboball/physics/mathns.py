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
