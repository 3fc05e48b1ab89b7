"""The effect library: one generalised-force law per physical effect a baseline may leave out.

Each entry of the diagnosis vocabulary (../shared/specs/diagnosis.md) is a plain function of the
experiment coordinate `q` (rad, measured from the baseline model's rest position), its rate `qd`
(rad/s) and the effect's parameters, returning the generalised torque (N m) the effect adds on
that coordinate.  Like `roboball.physics.friction`, every law takes a math namespace `m`, so the
SAME function body is evaluated on NumPy arrays by the fast reduced models of the diagnosis
(vectorised over thousands of candidate parameter sets at once) and on Drake symbolic
expressions when the augmented model is built as a force element in the Drake diagram
(`roboball.diagnose.drake`, through `roboball.sim.forces.GeneralizedTerm`).  Nothing here
imports Drake.

The library is PySINDy-like: a list of candidate terms, each with named parameters in SI units
and physical bounds, behind one interface (`torque`, `total_torque`, `LIBRARY[name].params`)
that the diagnosis fits and scores by simulation error.

Conventions and modelling choices
---------------------------------
* Dry-friction-like laws (coulomb_friction, stiction, rolling_resistance) replace sign(qd) by
  tanh(qd / V_EPS) with V_EPS = 1 mrad/s.  A memoryless force law cannot hold a body at rest,
  it creeps at qd = V_EPS atanh(load / tau); with 1 mrad/s a pendulum stuck 20 mrad off rest
  drifts by well under a milliradian over a ten-second log, below the sensors' quantisation.
* stiction is the breakaway torque ABOVE kinetic friction: a Stribeck hump
  tau_s exp(-(qd / V_STRIBECK)^2) that acts only near zero speed, so `coulomb_friction` and
  `stiction` are separate, additive vocabulary entries (a joint may show either or both).
  The hump is V_STRIBECK = 2 V_EPS wide: it acts where the law holds the joint (the creep band),
  not during the reversals of a swing.  A real contact's breakaway needs its asperities (LuGre's
  bristles) loaded, which a reversal, a slide of a few hundredths of a milliradian, does not
  do; a hump 20 mrad/s wide acted at every reversal, delayed it, and on the blind benchmark
  made the diagnosis take stiction's phase error for a stiffness or a drag.  tau_s is the most
  the hump adds to kinetic friction (its peak, at 1.03 mrad/s): the shape exp(-x^2) tanh(2 x),
  x = qd / V_STRIBECK, peaks at STICTION_PEAK = 0.594, and the law divides by it, so tau_s is
  the breakaway excess the law can hold, comparable with a real contact's F_s - F_c.
  On a joint the width is held there (`v_s` = V_STRIBECK, roboball.reduced.base.ReducedModel.
  held_params).  A soft shell rolling down a ramp breaks away differently: it rests on the flat
  its weight presses into it and must roll off it, which resists for the first part of a radian
  of rolling, up to speeds of a few rad/s in a descent from rest; there `v_s` is fitted (the
  Stribeck velocity of the classical law), and the peak divides by its own width's value
  (`stiction_peak`, towards 1 for a wide hump).
* com_offset is a geometric change: the centre of mass sits rotated by `delta` about the
  coordinate's axis from where the model puts it.  With gravity stiffness k_g = m g d (supplied
  by the experiment) the gravity torque becomes -k_g sin(q - delta) instead of -k_g sin(q); the
  law returns the difference, so the rest angle shifts by delta and swings become asymmetric.
* backlash is free play of half-width b about the rest position: inside it no transmission
  torque acts, outside it a transmission stiffness k_b engages (a dead-zone spring).
* linear_stiffness may be negative (the body swings slower than the rigid model says: less
  restoring torque per radian than m g d, or more inertia).
* added_inertia is no torque: the coordinate's inertia M becomes M + delta_i (a geared joint's
  reflected rotor inertia J N^2: the motor's rotor turns N times faster than the joint).  Its
  law returns the inertia it adds; `total_torque` leaves it out and `total_inertia` sums it,
  and each model divides its torques by M + total_inertia.  It slows every swing by the same
  ratio sqrt(M / (M + delta_i)) whatever its amplitude, where a negative linear_stiffness slows
  large swings more than small ones (gravity's restoring torque per radian, k_g sin(q) / q,
  falls with the angle, the spring's does not), so the data tell the two apart only by how the
  period changes with amplitude.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from roboball.physics.mathns import NP

V_EPS = 1e-3          # rad/s: regularisation of sign(qd) for dry-friction-like laws
V_STRIBECK = 2 * V_EPS   # rad/s: width of the stiction (Stribeck) hump: the creep band


def _hump_peak() -> float:
    """Peak of the stiction hump's shape exp(-x^2) tanh(x V_STRIBECK / V_EPS) over x >= 0."""
    x = np.linspace(0.0, 4.0, 400001)
    return float(np.max(np.exp(-x * x) * np.tanh(x * V_STRIBECK / V_EPS)))


STICTION_PEAK = _hump_peak()   # 0.5936: the stiction law's most torque per unit tau_s


def _peak_table(n: int = 4001):
    """Peaks of exp(-x^2) tanh(r x) over x >= 0 for widths r = v_s / V_EPS from 2 to 1e5 (log
    spaced): the root of its slope, r sech^2(r x) = 2 x tanh(r x), by bisection on [0, 4]."""
    r = np.geomspace(V_STRIBECK / V_EPS, 1e5, n)
    lo, hi = np.zeros(n), np.full(n, 4.0)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        with np.errstate(over="ignore"):      # cosh overflows far past the peak: sech^2 = 0 there
            rising = r / np.cosh(r * mid) ** 2 > 2.0 * mid * np.tanh(r * mid)
        lo, hi = np.where(rising, mid, lo), np.where(rising, hi, mid)
    x = 0.5 * (lo + hi)
    return np.log(r), np.exp(-x * x) * np.tanh(r * x)


_LOG_R, _PEAKS = _peak_table()


def stiction_peak(v_s):
    """The stiction hump's most torque per unit tau_s at width v_s (rad/s; a number or an array):
    STICTION_PEAK at the creep band's width, rising towards 1 as the hump widens (tanh's corner
    then sits at speeds where exp(-x^2) is still 1).  Interpolated in log width from
    `_peak_table` (relative error below 1e-6); the creep band's value is the module constant itself, so
    the joints' laws are unchanged to the last bit."""
    v = np.asarray(v_s, dtype=float)
    peak = np.interp(np.log(np.maximum(v, V_STRIBECK) / V_EPS), _LOG_R, _PEAKS)
    peak = np.where(v == V_STRIBECK, STICTION_PEAK, peak)
    return float(peak) if peak.ndim == 0 else peak


# ---- the laws -------------------------------------------------------------------------------
def viscous_damping(q, qd, c, m=NP):
    """Torque proportional to speed: -c qd (c in N m s/rad)."""
    return -c * qd


def coulomb_friction(q, qd, tau_c, m=NP):
    """Kinetic dry friction of constant magnitude tau_c (N m) opposing motion."""
    return -tau_c * m.tanh(qd / V_EPS)


def stiction(q, qd, tau_s, v_s=V_STRIBECK, m=NP):
    """Breakaway torque above kinetic friction: up to tau_s (N m) more, fading over v_s (rad/s)."""
    x = qd / v_s
    return -(tau_s / stiction_peak(v_s)) * m.exp(-x * x) * m.tanh(qd / V_EPS)


def quadratic_drag(q, qd, c2, m=NP):
    """Drag growing with the square of speed: -c2 |qd| qd (c2 in N m s^2/rad^2)."""
    return -c2 * m.abs(qd) * qd


def linear_stiffness(q, qd, k, m=NP):
    """Extra restoring torque -k q about the rest position (k in N m/rad, may be negative)."""
    return -k * q


def cubic_stiffness(q, qd, k3, m=NP):
    """Hardening (k3 > 0) or softening (k3 < 0) restoring torque -k3 q^3 (N m/rad^3)."""
    return -k3 * q * q * q


def com_offset(q, qd, delta, k_g, m=NP):
    """Centre of mass rotated by delta (rad) about the axis: gravity torque change
    -k_g [sin(q - delta) - sin(q)] (k_g = m g d of the experiment, N m/rad)."""
    return -k_g * (m.sin(q - delta) - m.sin(q))


def backlash(q, qd, k_b, b, m=NP):
    """Free play of half-width b (rad) about rest; outside it a stiffness k_b (N m/rad) engages."""
    inside = m.minimum(m.maximum(q, -b), b)
    return -k_b * (q - inside)


def rolling_resistance(q, qd, tau_rr, m=NP):
    """A torque of magnitude tau_rr (N m) opposing rolling that does not vanish with speed."""
    return -tau_rr * m.tanh(qd / V_EPS)


def added_inertia(q, qd, delta_i, m=NP):
    """Inertia delta_i (kg m^2) added to the coordinate's: M becomes M + delta_i (no torque)."""
    return delta_i + 0.0 * qd


# ---- metadata -------------------------------------------------------------------------------
@dataclass(frozen=True)
class Param:
    """One parameter of an effect: SI unit, physical bounds, a typical magnitude (used to
    scale the fit), and the starting values tried before a fit: `grid` = (from, to, n) in
    units of `typical`, log-spaced, mirrored to negative values when `signed`.  The grid is
    dense (ratio about 1.3) because simulation-error costs of dry friction and backlash have
    narrow basins: the number of swings before a stop is discrete."""

    name: str
    unit: str
    lo: float
    hi: float
    typical: float
    grid: tuple = (0.02, 30.0, 28)
    signed: bool = False
    default: float = 0.0     # its value where it is not fitted: 0 for a magnitude (no effect)

    @property
    def optional(self) -> bool:
        """Whether a law may be called without it (a width that has a value of its own)."""
        return self.default != 0.0

    def grid_values(self) -> list:
        a, b, n = self.grid
        pos = [self.typical * x for x in np.geomspace(a, b, int(n))]
        vals = pos + ([-x for x in pos] if self.signed else [])
        return [float(min(max(x, self.lo), self.hi)) for x in vals]


@dataclass(frozen=True)
class Effect:
    """A vocabulary entry: its law, parameters, the experiment constants it needs
    (`context`, e.g. k_g), whether it is a force or a geometric change, and the signature it
    leaves in a free response (used in the report's explanation)."""

    name: str
    law: Callable
    params: tuple
    kind: str = "force"
    context: tuple = ()
    explains: str = ""
    description: str = ""
    reduces_to: tuple = ()      # ((param, simpler effect), ...): at param = 0 this effect IS that one
    # ((param, simpler effects), ...): as param grows without bound this effect IS any of those
    # (a breakaway that never fades is a constant dry torque); judged like reduces_to where the
    # model fits that param
    widens_to: tuple = ()
    mechanism: tuple = ()       # ((sign of the magnitude, what it stands for physically), ...)

    def defining_params(self) -> tuple:
        """The parameters that must differ from zero for the effect to be itself: its
        magnitude (the first parameter), and each parameter at whose zero it becomes a simpler
        vocabulary entry (backlash with no free play is linear stiffness)."""
        return (self.params[0].name,) + tuple(p for p, _ in self.reduces_to if p != self.params[0].name)

    @property
    def param_names(self) -> tuple:
        return tuple(p.name for p in self.params)

    def units(self) -> dict:
        return {p.name: p.unit for p in self.params}

    def mechanism_for(self, params: dict) -> str:
        """The physical mechanism the effect stands for at these parameter values (the sign of
        its magnitude picks one where the two signs mean different things)."""
        x = params.get(self.params[0].name, 0.0)
        for sign, text in self.mechanism:
            if sign == 0 or (sign > 0) == (x >= 0):
                return text
        return ""


def _e(name, law, params, explains, kind="force", context=(), reduces_to=(), mechanism=(), widens_to=()):
    return Effect(name=name, law=law, params=tuple(params), kind=kind, context=tuple(context),
                  explains=explains, description=(law.__doc__ or "").split("\n")[0], reduces_to=tuple(reduces_to),
                  mechanism=tuple(mechanism), widens_to=tuple(widens_to))


LIBRARY: dict[str, Effect] = {e.name: e for e in (
    _e("viscous_damping", viscous_damping,
       [Param("c", "N m s/rad", 0.0, 50.0, 1.0)],
       "amplitude decays exponentially (constant damping ratio)",
       mechanism=((0, "a loss proportional to speed: lubricated bearing or seal, air drag at low speed, a soft shell's material damping"),)),
    _e("coulomb_friction", coulomb_friction,
       [Param("tau_c", "N m", 0.0, 10.0, 0.3)],
       "amplitude falls linearly; swings stop off rest",
       mechanism=((0, "dry (Coulomb) friction in the joint's bearings, seals or gearbox"),)),
    _e("stiction", stiction,
       # typical size of the peak (0.18 N m): the law's output of the former amplitude
       # parametrisation (0.3), so the fits start from the same grid; bound 20 N m as rolling
       # resistance's (a soft shell resting on its flat at low pressure breaks away at up to 10)
       [Param("tau_s", "N m", 0.0, 20.0, 0.3 * STICTION_PEAK),
        # the width over which the breakaway fades: held at the creep band on a joint
        # (ReducedModel.held_params), fitted on a rolling shell, whose breakaway (rolling off the
        # flat it rests on) lasts the first part of a radian of rolling, well into the motion
        Param("v_s", "rad/s", V_STRIBECK, 10.0, 1.0, grid=(0.1, 5.0, 8), default=V_STRIBECK)],
       "swings stop earlier and further from rest than kinetic friction alone allows",
       widens_to=(("v_s", ("rolling_resistance", "coulomb_friction")),),
       mechanism=((0, "static friction above kinetic friction (breakaway) in the bearings or gearbox"),)),
    _e("quadratic_drag", quadratic_drag,
       [Param("c2", "N m s^2/rad^2", 0.0, 20.0, 0.2)],
       "large swings damp faster than small ones (decay rate grows with amplitude)",
       mechanism=((0, "aerodynamic or fluid drag growing with the square of speed"),)),
    _e("linear_stiffness", linear_stiffness,
       [Param("k", "N m/rad", -60.0, 200.0, 3.0, grid=(0.02, 10.0, 18), signed=True)],
       "swing frequency differs from the model's at every amplitude",
       mechanism=((1, "an extra restoring torque: a spring, cable or shell stiffness, or more gravity torque m g d than the facts say"),
                  (-1, "a softer restoring torque than the facts say (centre of mass nearer the axis: smaller m g d), or a destabilising spring"))),
    _e("cubic_stiffness", cubic_stiffness,
       [Param("k3", "N m/rad^3", -200.0, 500.0, 5.0, grid=(0.05, 30.0, 18), signed=True)],
       "swing frequency changes with amplitude",
       mechanism=((1, "a hardening spring (stiffer at large angles: a stop, a stretched cable, a shell flattening)"),
                  (-1, "a softening restoring torque (weaker at large angles)"))),
    _e("com_offset", com_offset,
       [Param("delta", "rad", -0.5, 0.5, 0.03, grid=(0.1, 5.0, 14), signed=True)],
       "rest angle shifted; swings asymmetric about the model's rest", kind="geometric",
       context=("k_g",),
       mechanism=((0, "the centre of mass sits off where the facts put it (mass distribution, a cable or battery moved)"),)),
    _e("backlash", backlash,
       [Param("k_b", "N m/rad", 0.0, 200.0, 5.0, grid=(0.1, 10.0, 9)),
        Param("b", "rad", 0.0, 1.0, 0.15, grid=(0.2, 4.0, 8))],
       "free play about rest: small swings at the rigid frequency, large swings stiffer",
       reduces_to=(("b", "linear_stiffness"),),
       mechanism=((0, "free play (backlash) in a gear or coupling, with a compliant transmission beyond it"),)),
    _e("rolling_resistance", rolling_resistance,
       [Param("tau_rr", "N m", 0.0, 20.0, 1.0)],
       "a constant torque opposes rolling: linear amplitude loss, stops off rest, lower top speed",
       mechanism=((0, "rolling resistance: the soft shell's hysteresis as it flattens on the ground, or dry friction in the rolling"),)),
    _e("added_inertia", added_inertia,
       [Param("delta_i", "kg m^2", 0.0, 2.0, 0.05)],
       "every swing slower by the same ratio, at every amplitude", kind="inertia",
       mechanism=((0, "reflected rotor inertia of a geared joint (the motor's rotor inertia J times the gear ratio squared, "
                      "J N^2), or more inertia than the facts give"),)),
)}

VOCABULARY = tuple(LIBRARY)


def get(name: str) -> Effect:
    """The vocabulary entry `name` (ValueError naming the vocabulary otherwise)."""
    try:
        return LIBRARY[name]
    except KeyError:
        raise ValueError(f"unknown effect '{name}' (vocabulary: {', '.join(VOCABULARY)})")


def torque(name: str, q, qd, params: dict, context: dict | None = None, m=NP):
    """Generalised torque of effect `name` at (q, qd) with a parameter dict; `context` holds
    the experiment constants the effect needs (k_g for com_offset).  For an inertia effect this
    is the inertia it adds (kg m^2), not a torque: `total_torque` leaves those out."""
    eff = get(name)
    missing = [p.name for p in eff.params if p.name not in params and not p.optional]
    if missing:
        raise ValueError(f"effect '{name}' lacks parameter(s) {', '.join(missing)}")
    kwargs = {p: params[p] for p in eff.param_names if p in params}     # else the law's default
    for key in eff.context:
        if context is None or key not in context:
            raise ValueError(f"effect '{name}' needs the experiment constant '{key}'")
        kwargs[key] = context[key]
    return eff.law(q, qd, **kwargs, m=m)


def total_torque(effects: dict, q, qd, context: dict | None = None, m=NP):
    """Sum of several effects' torques: `effects` maps effect name -> parameter dict (inertia
    effects add no torque and are left out)."""
    total = 0.0 * qd
    for name, params in effects.items():
        if get(name).kind != "inertia":
            total = total + torque(name, q, qd, params, context, m=m)
    return total


def total_inertia(effects: dict, q=0.0, qd=0.0, m=NP):
    """Inertia (kg m^2) the inertia effects among `effects` add to the coordinate's."""
    total = 0.0 * qd
    for name, params in effects.items():
        if get(name).kind == "inertia":
            total = total + torque(name, q, qd, params, m=m)
    return total


@dataclass
class EffectSet:
    """A chosen set of effects with their parameter values (what a diagnosis adds)."""

    values: dict = field(default_factory=dict)    # name -> {param: value}

    def torque(self, q, qd, context=None, m=NP):
        return total_torque(self.values, q, qd, context, m=m)

    @property
    def names(self) -> list:
        return list(self.values)
