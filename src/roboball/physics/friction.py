"""Joint-friction laws of the paper (section II-B), as torques on the joint.

Each law maps joint velocity `v` (rad/s) to the torque the friction applies to the joint
(N m); the torque always opposes motion (tau * v <= 0).  Laws are vectorised over `v` and
over parameters (broadcasting), and take a math namespace `m` so the identical expression
is used by NumPy reduced models and by the Drake diagram (symbolic, no Python per step).

Notes on the paper's equations
------------------------------
* Eq. 2 prints the stiction branch as `mu_s sign(v) if v < tol`.  A force law cannot hold a
  joint at rest, so inside the band |v| < v_tol we use the regularised stiction torque
  `-mu_s v / v_tol` (at most mu_s, vanishing at rest) and outside it `-mu_d sign(v) - c v`.
* Eq. 3 is typeset as `f_w v [ ... ] sign(v)`, which is even in v and cannot be friction.
  Majd & Simaan (1995, eq. 6) write `f_w v + [f_c + sigma e^{-|v/w_c|} - (sigma + f_c)
  e^{-|n v / w_c|}] sign(v)`: viscous plus a continuous stiction hump that is zero at v = 0
  and tends to f_c.  We use that form.  With n = 1 (Table I, steer) the bracket reduces to
  f_c (1 - e^{-|v|/w_c}).
"""
from __future__ import annotations

from roboball.physics.mathns import NP

LAWS = ("none", "viscous", "coulomb_viscous", "majd")

# Parameter names of each law, in a fixed order (used by fits and tables).
PARAMS = {
    "none": (),
    "viscous": ("c",),
    "coulomb_viscous": ("mu_s", "mu_d", "c", "v_tol"),
    "majd": ("f_w", "f_c", "sigma", "omega_c", "n"),
}

UNITS = {
    "c": "N m s/rad", "mu_s": "N m", "mu_d": "N m", "v_tol": "rad/s",
    "f_w": "N m s/rad", "f_c": "N m", "sigma": "N m", "omega_c": "rad/s", "n": "1",
}


def none(v, m=NP):
    return 0.0 * v


def viscous(v, c, m=NP):
    """Viscous damping, eq. 2 with mu_s = mu_d = 0."""
    return -c * v


def coulomb_viscous(v, mu_s, mu_d, c, v_tol=0.01, m=NP):
    """Coulomb + viscous friction, eq. 2 (regularised stiction band |v| < v_tol)."""
    inside = -mu_s * v / v_tol
    outside = -mu_d * m.sign(v) - c * v
    return m.where(m.abs(v) < v_tol, inside, outside)


def majd(v, f_w, f_c, sigma, omega_c, n, m=NP):
    """Majd & Simaan continuous friction with stiction, eq. 3."""
    x = m.abs(v / omega_c)
    hump = f_c + sigma * m.exp(-x) - (sigma + f_c) * m.exp(-n * x)
    return -(f_w * v + hump * m.sign(v))


def torque(law: str, v, params: dict, m=NP):
    """Evaluate friction law `law` at velocity `v` with a parameter dict."""
    if law == "none":
        return none(v, m=m)
    fn = {"viscous": viscous, "coulomb_viscous": coulomb_viscous, "majd": majd}.get(law)
    if fn is None:
        raise ValueError(f"unknown friction law '{law}' (choose from {', '.join(LAWS)})")
    kwargs = {k: params[k] for k in PARAMS[law] if k in params}
    return fn(v, **kwargs, m=m)


def table1_params(robot, law: str, joint: str) -> dict:
    """Paper Table I parameters for `law` on `joint` ('steer' or 'drive')."""
    t = robot.friction_table1
    if law == "none":
        return {}
    if law == "majd":
        return dict(t[f"majd_{joint}"])
    return dict(t[law])
