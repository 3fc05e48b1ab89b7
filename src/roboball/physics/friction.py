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
* Fits sample Majd's law by its stiction peak (:data:`FIT_PARAMS`): ``h_peak``, the hump's
  torque where its sigma term sigma (e^{-x} - e^{-n x}) peaks, at x* = ln n / (n - 1), and
  ``v_peak`` = omega_c x*, that speed; with f_w, f_c and n (:func:`majd_from_peak`).  Near n = 1
  the swings see only sigma (n - 1) (at n = 1 sigma cancels exactly), so (sigma, n) lie on a
  ridge to the prior's bound that no ensemble move crosses quickly, and omega_c trades against
  n along a curve (the posterior of omega_c and log(n - 1) correlated 0.82-0.85 on the test
  bed's and the real steer logs, 0.23-0.36 for v_peak); the peak's torque and speed are what
  the swings pin (their posterior spreads 2-6% and 11%, omega_c's 25%).  At fixed (h_peak,
  v_peak) the law has a limit at n = 1: f_c (1 - e^{-x}) + e (h_peak - (1 - 1/e) f_c) x e^{-x}.
"""
from __future__ import annotations

import numpy as np

from roboball.physics.mathns import NP

LAWS = ("none", "viscous", "coulomb_viscous", "majd")

# Parameter names of each law, in a fixed order (used by fits and tables).
PARAMS = {
    "none": (),
    "viscous": ("c",),
    "coulomb_viscous": ("mu_s", "mu_d", "c", "v_tol"),
    "majd": ("f_w", "f_c", "sigma", "omega_c", "n"),
}

# The parameters a fit samples (and configs/priors.yaml gives priors for): v_tol is fixed, and
# Majd's sigma and omega_c are sampled through its stiction peak (module docstring;
# :func:`natural_params`).
FIT_PARAMS = {
    "viscous": ("c",),
    "coulomb_viscous": ("mu_s", "mu_d", "c"),
    "majd": ("f_w", "f_c", "h_peak", "v_peak", "n"),
}

UNITS = {
    "c": "N m s/rad", "mu_s": "N m", "mu_d": "N m", "v_tol": "rad/s",
    "f_w": "N m s/rad", "f_c": "N m", "sigma": "N m", "omega_c": "rad/s", "n": "1",
    "h_peak": "N m", "v_peak": "rad/s",
}


def none(v, m=NP):
    return 0.0 * v


def viscous(v, c, m=NP):
    """Viscous damping, eq. 2 with mu_s = mu_d = 0."""
    return -c * v


# `side` of coulomb_viscous: the stiction band's line (the sliding lines are +1 and -1)
BAND = 2.0


def coulomb_viscous(v, mu_s, mu_d, c, v_tol=0.01, m=NP, side=None):
    """Coulomb + viscous friction, eq. 2 (regularised stiction band |v| < v_tol).

    The torque jumps at the band's edges (mu_s against mu_d + c v_tol), and a fixed-step
    integrator that steps across a jump makes the solution jitter with the parameters.  `side`
    continues one branch past the edge, so that an integrator can locate the edge and step each
    side on its own smooth branch (roboball.reduced.kernel): BAND, the band's line at any speed;
    +1 or -1, the sliding line of that direction at any speed.  None: the law (the branch of v)."""
    if side is None:
        inside = m.abs(v) < v_tol
        direction = m.sign(v)
    else:
        inside = side == BAND
        direction = side
    return m.where(inside, -mu_s * v / v_tol, -mu_d * direction - c * v)


def majd(v, f_w, f_c, sigma, omega_c, n, m=NP):
    """Majd & Simaan continuous friction with stiction, eq. 3."""
    x = m.abs(v / omega_c)
    hump = f_c + sigma * m.exp(-x) - (sigma + f_c) * m.exp(-n * x)
    return -(f_w * v + hump * m.sign(v))


def majd_peak_x(n):
    """x* = ln n / (n - 1), where the sigma term e^{-x} - e^{-n x} peaks (x = |v| / omega_c),
    written with log1p so that it stays accurate as n -> 1 (where it tends to 1)."""
    d = np.asarray(n, dtype=float) - 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(d > 1e-8, np.log1p(d) / np.where(d > 1e-8, d, 1.0), 1.0 - 0.5 * d)


def majd_peak_factor(n):
    """The sigma term's peak, e^{-x*} - e^{-n x*} = n^{-1/(n-1)} (n - 1) / n (-> (n - 1) / e)."""
    d = np.asarray(n, dtype=float) - 1.0
    return np.exp(-majd_peak_x(n)) * d / (1.0 + d)


def majd_from_peak(f_c, h_peak, v_peak, n) -> tuple:
    """(sigma, omega_c) of Majd's law from its stiction peak (module docstring): the hump's
    torque h_peak at the sigma term's peak speed v_peak.  sigma < 0 where h_peak is below the
    Coulomb term's own rise there, f_c (1 - n^{-n/(n-1)}): no stiction peak (see :func:`admissible`)."""
    xs = majd_peak_x(n)
    sigma_peak = h_peak - f_c * (1.0 - np.exp(-np.asarray(n, dtype=float) * xs))
    with np.errstate(divide="ignore", invalid="ignore"):      # n = 1 exactly: sigma is not defined
        return sigma_peak / majd_peak_factor(n), v_peak / xs


def majd_to_peak(f_c, sigma, omega_c, n) -> tuple:
    """(h_peak, v_peak) of Majd's law with the given parameters (inverse of :func:`majd_from_peak`)."""
    xs = majd_peak_x(n)
    return f_c * (1.0 - np.exp(-np.asarray(n, dtype=float) * xs)) + sigma * majd_peak_factor(n), omega_c * xs


def natural_params(law: str, fitted: dict) -> dict:
    """The law's own parameters from the fitted ones (:data:`FIT_PARAMS`): Majd's sigma and
    omega_c from its stiction peak (unless they are given); other entries are passed through."""
    out = dict(fitted)
    if law == "majd" and "h_peak" in out and "v_peak" in out:
        sigma, omega_c = majd_from_peak(out["f_c"], out["h_peak"], out["v_peak"], out["n"])
        out.setdefault("sigma", sigma)
        out.setdefault("omega_c", omega_c)
    return out


def admissible(law: str, params: dict):
    """Where a law's parameters give friction, a torque that never pushes the joint (True, or a
    boolean array over parameter sets).  Majd's hump f_c (1 - e^{-nx}) + sigma (e^{-x} - e^{-nx})
    is >= 0 for every speed iff sigma >= -f_c n / (n - 1) (its slope at rest; the ratio of the
    two terms is largest there): sigma < 0 is a rise to f_c slower than the Coulomb term's, with
    no stiction peak, which the fits allow so that a posterior that wants a small peak does not
    pile against sigma = 0."""
    if law == "majd" and "sigma" in params:
        n = np.asarray(params["n"], dtype=float)
        with np.errstate(invalid="ignore"):                    # nan (n = 1 exactly): not admissible
            return np.asarray(params["sigma"]) * (n - 1.0) + np.asarray(params["f_c"]) * n >= 0.0
    return True


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
