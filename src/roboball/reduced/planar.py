"""Fast reduced-order planar models of the stand and shell experiments, batched over parameters.

Why: identifying friction with MCMC needs the simulated swing for thousands of parameter sets.
Drake simulates one set at a time; these models integrate the same physics for a whole batch
(every emcee walker, every release, every finite-difference perturbation) in one call.  Runs
with a friction law alone go through the compiled loop of :mod:`roboball.reduced.kernel` (the
same algorithm in machine code, rows in parallel threads); runs with extra torques (diagnosis
effects, the injected shell) use the NumPy loop of :mod:`roboball.reduced.integrate`, which
pays the per-step Python overhead once per batch.  The friction torque is computed by the law functions of
:mod:`roboball.physics.friction` (the same functions the Drake diagram evaluates symbolically,
and the compiled loop compiles); nothing here re-implements a law.

Models (one generalised coordinate q, robot constants from ``configs/robot.yaml``)
-----------------------------------------------------------------------------------
All three experiments reduce to the same planar form.  With ``m_s`` and ``m_c`` the mass
moments of the swinging bodies (their centre of mass, times mass, in the two in-plane axes
of their own frame, measured from the rotation centre) the potential and mass matrix are

    V(q) = g (m_s sin q + m_c cos q) = -g G cos(q + beta),
    M(q) = M0 + 2 R (m_s sin q + m_c cos q) = M0 - 2 R G cos(q + beta),
    G = hypot(m_s, m_c),   beta = atan2(m_s, -m_c),

and Lagrange's equation with the generalised torques of friction, extra effects and an
applied term reads

    M(q) q'' + 1/2 M'(q) q'^2 + V'(q) = tau_friction(q') + tau_extra(q, q').

* ``steer_stand``: the pendulum about the steer axis (+x) with the pitch centre held.  Its
  centre of mass is (0, y_c, -d_z) in its frame, so m_s = m y_c, m_c = -m d_z, R = 0 and
  V'(q) = m g (y_c cos q + d_z sin q): exactly ``I q'' = -m g (y_c cos q + d_z sin q) + tau``
  with I = ``robot.steer_stand_terms["inertia"]`` (I_xx + m (y_c^2 + d_z^2)).  Rest at
  q = -beta = -atan(y_c / d_z) = -0.0355 rad.
* ``drive_stand``: pitch centre + pendulum (steer locked) about the drive axis with the pipe
  held: ``I q'' = -m g d sin q + tau`` with I and m g d from ``robot.drive_stand_terms``.  The
  drive joint turns the pipe about -y relative to the pitch centre, so with the pipe held
  the swinging bodies turn by +q about +y: m_s = -sum(m x) = 0, m_c = sum(m z).  Rest at 0.
* ``shell_rock``: steering locked, the rigid robot rolls without slipping on flat ground in
  the steer plane (rotation q = phi about x, centre at height R moving by -R phi).  The
  centre of mass of all links sits at (y, z) = (m_s, m_c) / m_total from the sphere's centre,
  M0 = sum(I_xx + m (y^2 + z^2)) + m_total R^2 is the roll inertia about the contact line at
  q = 0 ... exactly the exact nonlinear rolling equation
      M(phi) phi'' + 1/2 M'(phi) phi'^2 + V'(phi) = tau_app(phi, phi'),
  whose linearisation at phi = 0 is eq. 4 (M(0) = M_eq, V''(0) ~ K_eq up to the lateral
  offset).  Rest at -beta = -0.0333 rad.

Calibrated stand (the friction fits, :mod:`roboball.identify.friction.problem`): per batch row,
an ``added_inertia`` delta_i (kg m^2) adds to M0 (a geared joint's reflected rotor inertia
J N^2, which the URDF leaves out; in Drake the joint actuator's rotor inertia and gear ratio),
a ``rest_offset`` (rad) is added to the measured angle (the model starts from q0 - offset and
reports q + offset: an encoder zero, or equally a centre of mass turned about the joint axis,
since for a stand, constant inertia and friction a function of speed, the two are one motion),
and a ``release_shift`` (s) moves each release instant (:func:`simulate_segments`).

The applied/extra generalised torque is a callable ``extra_torque(q, qd, params) -> array``
(``params`` is the batch's parameter dict, so effect parameters travel with the walkers);
:func:`injected_shell` wraps eq. 9 (:func:`roboball.physics.shell.injected_torque`).

Integration: fixed-step RK4 (Nystroem form) with an implicit backward-Euler step where stiff
stiction needs it (:func:`roboball.reduced.integrate.rk4_stiction`; the module's docstring gives
the accuracy study behind ``DEFAULT_DT`` and ``STIFF_KAPPA``); runs with a friction law alone take
the compiled copy of that loop (:mod:`roboball.reduced.kernel`).  Outputs are stored at every
step with their rate and evaluated at the requested (irregular) times by cubic Hermite
interpolation (:func:`roboball.reduced.integrate.sample`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import numpy as np

from roboball.config import RobotFacts, load_robot
from roboball.errors import RoboballError, SimulationError
from roboball.kinds import MAIN_SIGNAL, OSCILLATING
from roboball.physics import shell as shell_laws
from roboball.reduced.integrate import Trajectory, friction_function, rk4_stiction, sample, stiff_band

__all__ = [
    "KINDS",
    "COORDINATE",
    "DEFAULT_DT",
    "STIFF_KAPPA",
    "PlanarModel",
    "planar_model",
    "integrate",
    "simulate_stand",
    "simulate_segments",
    "injected_shell",
    "step_error",
]

KINDS = OSCILLATING
COORDINATE = {k: MAIN_SIGNAL[k] for k in OSCILLATING}
DEFAULT_DT = 2.5e-3
STIFF_KAPPA = 2.0


# ---------------------------------------------------------------------------------------------
# Models
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PlanarModel:
    """One-coordinate planar model M(q) q'' + M'(q) q'^2 / 2 + V'(q) = tau (module docstring).

    Attributes: ``inertia0_kg_m2`` M0, ``mass_moment_kg_m`` G, ``offset_rad`` beta, ``radius_m``
    R (0 for the stands: constant inertia), ``g`` gravity, ``kind``, ``coordinate``.
    """

    kind: str
    coordinate: str
    inertia0_kg_m2: float
    mass_moment_kg_m: float
    offset_rad: float
    radius_m: float
    g: float

    @property
    def rest_angle(self) -> float:
        """Angle where V'(q) = 0 with the centre of mass straight below the rotation centre."""
        return -self.offset_rad

    @property
    def constant_inertia(self) -> bool:
        return self.radius_m == 0.0

    def inertia(self, q):
        """M(q) (kg m^2)."""
        if self.constant_inertia:
            return self.inertia0_kg_m2 + 0.0 * np.asarray(q, dtype=float)
        return self.inertia0_kg_m2 - 2.0 * self.radius_m * self.mass_moment_kg_m * np.cos(q + self.offset_rad)

    def dinertia(self, q):
        """dM/dq (kg m^2/rad)."""
        return 2.0 * self.radius_m * self.mass_moment_kg_m * np.sin(np.asarray(q, dtype=float) + self.offset_rad)

    def potential(self, q):
        """V(q) (J), zero when the centre of mass is level with the rotation centre."""
        return -self.g * self.mass_moment_kg_m * np.cos(np.asarray(q, dtype=float) + self.offset_rad)

    def gravity_torque(self, q):
        """-V'(q) (N m)."""
        return -self.g * self.mass_moment_kg_m * np.sin(np.asarray(q, dtype=float) + self.offset_rad)

    def energy(self, q, qd):
        """Mechanical energy 1/2 M(q) q'^2 + V(q) (J)."""
        return 0.5 * self.inertia(q) * np.asarray(qd, dtype=float) ** 2 + self.potential(q)

    def stiffness_at_rest(self) -> float:
        """V''(rest) (N m/rad)."""
        return self.g * self.mass_moment_kg_m

    def omega_at_rest(self) -> float:
        """Small-oscillation natural frequency about rest, sqrt(V''/M) (rad/s)."""
        return math.sqrt(self.stiffness_at_rest() / float(self.inertia(self.rest_angle)))


def _moments(links, names, axis: str, sign: float = 1.0):
    """(m_s, m_c, inertia about the axis through the origin) of links rigidly joined."""
    m_s = m_c = inertia = 0.0
    for name in names:
        l = links[name]
        x, y, z = l.com_m
        if axis == "x":
            m_s += l.mass_kg * y
            m_c += l.mass_kg * z
            inertia += l.inertia_kg_m2[0] + l.mass_kg * (y * y + z * z)
        else:   # about y: the in-plane lateral axis is x, with the sign of the rotation sense
            m_s += sign * l.mass_kg * x
            m_c += l.mass_kg * z
            inertia += l.inertia_kg_m2[1] + l.mass_kg * (x * x + z * z)
    return m_s, m_c, inertia


def planar_model(kind: str, robot: RobotFacts | None = None) -> PlanarModel:
    """The reduced model of experiment `kind` with every constant derived from the robot facts."""
    if kind not in KINDS:
        raise RoboballError(f"reduced model: unknown kind '{kind}' (choose from {', '.join(KINDS)})")
    robot = robot if robot is not None else load_robot()
    links = robot.links
    if kind == "steer_stand":
        m_s, m_c, inertia = _moments(links, ["pendulum"], "x")
        inertia = robot.steer_stand_terms["inertia"]
        radius = 0.0
    elif kind == "drive_stand":
        # pipe held, pitch centre + pendulum turn by +q about +y (drive axis is -y, pipe fixed)
        m_s, m_c, _ = _moments(links, ["pitch_center", "pendulum"], "y", sign=-1.0)
        inertia = robot.drive_stand_terms["inertia"]
        radius = 0.0
    else:
        m_s, m_c, i_o = _moments(links, list(links), "x")
        total = sum(l.mass_kg for l in links.values())
        inertia = i_o + total * robot.radius ** 2
        radius = robot.radius
    G = math.hypot(m_s, m_c)
    beta = math.atan2(m_s, -m_c)
    return PlanarModel(kind, COORDINATE[kind], float(inertia), G, beta, float(radius), robot.g)


def injected_shell(k_inject, c_inject) -> Callable:
    """Eq. 9 as an extra-torque callable: tau = -c phi' - k phi (numbers or per-walker arrays).

    Strings name entries of the batch's parameter dict instead (e.g. ``injected_shell(
    "k_inject", "c_inject")`` lets the stiffness and damping be fitted per walker).
    """

    def tau(q, qd, params):
        k = params[k_inject] if isinstance(k_inject, str) else k_inject
        c = params[c_inject] if isinstance(c_inject, str) else c_inject
        return shell_laws.injected_torque(q, qd, k, c)

    return tau


# ---------------------------------------------------------------------------------------------
# Integration (dispatch to the NumPy or the compiled loop)
# ---------------------------------------------------------------------------------------------
def integrate(model: PlanarModel, law: str, params: Mapping, q0, qd0, duration: float,
              dt: float = DEFAULT_DT, extra_torque: Callable | None = None,
              record_work: bool = False, stiff_kappa: float = STIFF_KAPPA, compiled: bool = True,
              row_durations=None, added_inertia=None) -> Trajectory:
    """Integrate a batch of B initial states (q0, qd0: (B,)) for `duration` seconds.

    `params` maps parameter names to scalars or (B,) arrays (friction law parameters and any
    entries `extra_torque` reads).  Fixed-step RK4 (Nystroem form) with the implicit stiction
    step (:mod:`roboball.reduced.integrate`).  Non-finite states are left in the output (the
    caller decides; see :func:`simulate_stand`).

    With ``compiled`` (default) a run with a friction law and no extra torque or work record
    goes through the compiled loop of :mod:`roboball.reduced.kernel` (same algorithm, same
    results to ~1e-12 rad); ``compiled=False`` forces the NumPy loop.  ``row_durations`` (B,)
    lets the compiled loop stop a row early (it then holds its last state); the NumPy loop
    integrates every row for `duration` (a caller reads each row only up to its own end).
    ``added_inertia`` (a number or (B,)) adds to M0 row by row (None: the model's M0).
    """
    if not (dt > 0 and math.isfinite(dt)):
        raise RoboballError(f"reduced model: time step must be positive, got {dt}")
    q = np.array(q0, dtype=float).ravel()
    v = np.array(qd0, dtype=float).ravel() + np.zeros_like(q)
    B = q.size
    n = max(int(math.ceil(duration / dt - 1e-9)), 1)
    m0 = None if added_inertia is None else model.inertia0_kg_m2 + np.broadcast_to(
        np.asarray(added_inertia, dtype=float).ravel(), (B,))
    ffun = friction_function(law, params)
    if ffun is None:
        return rk4_stiction(model, law, params, None, q, v, n, dt, extra_torque, record_work, inertia0=m0)
    RG = model.radius_m * model.mass_moment_kg_m
    m_min = (model.inertia0_kg_m2 if m0 is None else m0) - 2.0 * RG
    band, slope0 = stiff_band(ffun, 1.0 / m_min, dt, stiff_kappa, B)
    if compiled:
        from roboball.reduced import kernel as reduced_kernel    # imports Numba (about a second): only here
    if compiled and reduced_kernel.supports(law, extra_torque, record_work):
        # the same algorithm in machine code (roboball.reduced.kernel), rows in parallel
        n_rows = None if row_durations is None else \
            np.ceil(np.asarray(row_durations, dtype=float).ravel() / dt - 1e-9).astype(np.int64)
        Qr, Vr, n_impl = reduced_kernel.integrate_rows(model, law, params, q, v, n, dt, band, slope0, n_rows, m0)
        return Trajectory(np.arange(n + 1) * dt, Qr.T, Vr.T, None, dt, n_impl)
    return rk4_stiction(model, law, params, ffun, q, v, n, dt, extra_torque, record_work, band, slope0, m0)


# ---------------------------------------------------------------------------------------------
# Public simulation API
# ---------------------------------------------------------------------------------------------
def _batch_size(params: Mapping | None, *arrays) -> int:
    sizes = {np.size(a) for a in arrays if np.ndim(a) > 0}
    if params:
        sizes |= {np.size(v) for v in params.values() if np.ndim(v) > 0}
    sizes.discard(1)
    if len(sizes) > 1:
        raise RoboballError(f"reduced model: batch arrays have different lengths {sorted(sizes)}")
    return sizes.pop() if sizes else 1


def _as_batch(params: Mapping | None, B: int) -> dict:
    out = {}
    for k, val in (params or {}).items():
        a = np.asarray(val, dtype=float)
        out[k] = a.ravel() if a.ndim > 0 and a.size > 1 else (np.full(B, float(a.ravel()[0])) if a.ndim > 0 else float(a))
    return out


def _check_finite(y: np.ndarray, kind: str, law: str, params: dict) -> None:
    bad = ~np.all(np.isfinite(y), axis=1)
    if bad.any():
        i = int(np.nonzero(bad)[0][0])
        vals = ", ".join(f"{k}={np.ravel(v)[i] if np.ndim(v) else v:.4g}" for k, v in params.items())
        raise SimulationError(f"reduced {kind} model with {law} friction diverged for batch row {i} "
                              f"({vals or 'no parameters'}); reduce dt or check the parameters")


def simulate_stand(kind: str, t_eval, theta0, theta_dot0=0.0, law: str = "none",
                   params_batch: Mapping | None = None, extra_torque: Callable | None = None,
                   dt: float = DEFAULT_DT, *, t0: float | None = None, robot: RobotFacts | None = None,
                   check_finite: bool = True, added_inertia=None, rest_offset=0.0) -> np.ndarray:
    """Simulate a batch of releases of experiment `kind`; returns q at `t_eval`, shape (B, n_t).

    The body is released at time `t0` (default ``t_eval[0]``) from angle `theta0` with rate
    `theta_dot0` (scalars or (B,) arrays; the release state of a hand-held body is rest:
    ``theta_dot0 = 0``).  `params_batch` maps friction-law (and extra-torque) parameter names
    to scalars or (B,) arrays, one entry per walker.  Times before `t0` return `theta0` (held).
    `kind` is ``steer_stand``, ``drive_stand`` or ``shell_rock`` (for the shell the friction
    law, if any, acts on the rolling rate; the shell's own terms go in `extra_torque`, e.g.
    :func:`injected_shell`).  `added_inertia` and `rest_offset` (numbers or (B,)) calibrate a
    stand (module docstring).  Raises SimulationError if the result is not finite (unless
    ``check_finite=False``, when diverged rows come back as NaN/inf).
    """
    model = planar_model(kind, robot)
    t_eval = np.asarray(t_eval, dtype=float).ravel()
    if t_eval.size == 0:
        raise RoboballError("simulate_stand: t_eval is empty")
    if not np.all(np.isfinite(t_eval)):
        raise RoboballError("simulate_stand: t_eval has non-finite times")
    t0 = float(t_eval[0]) if t0 is None else float(t0)
    B = _batch_size(params_batch, theta0, theta_dot0, added_inertia, rest_offset)
    params = _as_batch(params_batch, B)
    q0 = np.broadcast_to(np.asarray(theta0, dtype=float).ravel(), (B,)).copy() if np.size(theta0) in (1, B) else None
    if q0 is None:
        raise RoboballError(f"simulate_stand: theta0 has {np.size(theta0)} values for a batch of {B}")
    qd0 = np.broadcast_to(np.asarray(theta_dot0, dtype=float).ravel(), (B,)).copy()
    offset = np.broadcast_to(np.asarray(rest_offset, dtype=float).ravel(), (B,))[:, None]
    duration = max(float(t_eval.max()) - t0, dt)
    traj = integrate(model, law, params, q0 - offset[:, 0], qd0, duration + dt, dt, extra_torque,
                     added_inertia=added_inertia)
    y = sample(traj, t_eval - t0) + offset
    if check_finite:
        _check_finite(y, kind, law, params)
    return y


def _per_row(value, P: int, S: int, name: str) -> np.ndarray:
    """A per-walker (P,) or per-walker-and-segment (P, S) array as rows (segment-major, P x S)."""
    a = np.asarray(value, dtype=float)
    if a.ndim == 2:
        if a.shape != (P, S):
            raise RoboballError(f"simulate_segments: {name} has shape {a.shape}, expected ({P}, {S})")
        return a.T.ravel()
    return np.tile(np.broadcast_to(a.ravel(), (P,)), S)


def simulate_segments(kind: str, segments: Sequence[tuple], q0, law: str,
                      params_batch: Mapping | None = None, extra_torque: Callable | None = None,
                      dt: float = DEFAULT_DT, *, robot: RobotFacts | None = None,
                      model: PlanarModel | None = None, check_finite: bool = False,
                      added_inertia=None, rest_offset=None, release_shift=None) -> list[np.ndarray]:
    """Simulate several releases for a batch of P parameter sets in ONE integration.

    `segments` is a list of S pairs ``(t, t_release)`` (sample times of the release's free
    response and the release instant, recording time base).  `q0` has shape (P, S) (or (S,)
    for all walkers alike): each release's initial angle per walker; each starts at rest.
    The P x S runs are integrated together (rows ordered segment-major) for the longest
    segment's duration.  The calibrated stand (module docstring): `added_inertia` and
    `rest_offset` per walker ((P,) or numbers), `release_shift` (P, S) in seconds, the body held
    at its release angle until ``t_release + shift``.  Returns S arrays of shape (P, len(t_s)).
    """
    model = model if model is not None else planar_model(kind, robot)
    S = len(segments)
    if S == 0:
        raise RoboballError("simulate_segments: no segments")
    q0 = np.asarray(q0, dtype=float)
    P = _batch_size(params_batch) if q0.ndim < 2 else q0.shape[0]
    if q0.ndim < 2:
        q0 = np.broadcast_to(q0.reshape(1, -1), (P, S))
    if q0.shape != (P, S):
        raise RoboballError(f"simulate_segments: initial angles have shape {q0.shape}, expected ({P}, {S})")
    params = _as_batch(params_batch, P)
    rows = {k: (np.tile(v, S) if np.ndim(v) > 0 else v) for k, v in params.items()}
    shift = np.zeros(P * S) if release_shift is None else _per_row(release_shift, P, S, "release_shift")
    offset = np.zeros(P * S) if rest_offset is None else _per_row(rest_offset, P, S, "rest_offset")
    extra_i = None if added_inertia is None else _per_row(added_inertia, P, S, "added_inertia")
    durations = np.repeat([float(np.max(t)) - float(tr) for t, tr in segments], P) - shift
    # each segment's rows run for their own duration (plus a step for the interpolation)
    row_d = np.maximum(durations, dt) + dt
    traj = integrate(model, law, rows, q0.T.ravel() - offset, np.zeros(P * S), max(float(durations.max()), dt) + dt,
                     dt, extra_torque, row_durations=row_d, added_inertia=extra_i)
    out = []
    for s, (t, tr) in enumerate(segments):
        sl = slice(s * P, (s + 1) * P)
        t_rel = np.asarray(t, dtype=float) - float(tr)
        times = t_rel if release_shift is None else t_rel[None, :] - shift[sl, None]
        y = sample(traj, times, sl) + offset[sl, None]
        if check_finite:
            _check_finite(y, kind, law, params)
        out.append(y)
    return out


def step_error(kind: str, law: str, params: Mapping, q0: float, duration: float,
               dt: float = DEFAULT_DT, refine: int = 8, robot: RobotFacts | None = None,
               sample_dt: float = 0.01) -> float:
    """Integration error estimate: max |q(dt) - q(dt/refine)| on a `sample_dt` grid (rad).

    Used to check that the fixed step is fine enough for a fitted parameter set (the fit
    reports it next to the noise level)."""
    t = np.arange(0.0, duration, sample_dt)
    a = simulate_stand(kind, t, q0, 0.0, law, params, dt=dt, robot=robot)
    b = simulate_stand(kind, t, q0, 0.0, law, params, dt=dt / refine, robot=robot)
    return float(np.max(np.abs(a - b)))
