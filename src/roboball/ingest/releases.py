"""Finding the releases in a recording.

A *release* is what the experimenters did by hand in the stand and shell tests: move the
body, hold it still away from its rest position, let go.  A free oscillation follows: the
body accelerates towards rest, overshoots, and swings about rest with decaying amplitude
until it stops or a hand intervenes again.  The recordings do not mark these events, so the
tools find them themselves.

Method (all thresholds are relative to the signal's own noise level and swing size, so the
same code works for a 1-mrad-quantised pendulum log at 80 Hz and a 100 Hz shell log):

1. Drop duplicate stamps, resample onto a uniform grid (linear interpolation; gaps of a
   few samples are harmless), smooth with a Savitzky-Golay filter, and estimate the noise
   level sigma (robust MAD of the high-pass residual, floored by the quantisation step).
2. Find the turning points of the smoothed signal with a hysteresis ("zig-zag") of 5 sigma.
3. Every turning point is a candidate hold, and so is a hold inside a monotone stretch (a
   hand that catches a swing, lowers the body towards rest, holds it and lets go makes no
   turning point there: still for `min_hold_s` between clearly larger moves on both sides).
   A candidate is accepted as a release when
   - the body was held: slower than 10% of the free swing's peak speed (offset x omega)
     for at least `min_hold_s` AND for clearly longer (2.5x) than the turning point of a free
     swing of the same frequency and amplitude is (this separates a hand hold from a
     turning point of an ongoing oscillation);
   - it lies further than 20 sigma from the final rest of the motion that follows (the level
     the body settles at after its last swing, unless its swings do not swing about that
     level: then a hand's hold, and the rest is extrapolated from their decay), and its
     offset is at least 5% of the largest release in the file (a hand's tremor while it
     holds the body makes tiny "releases" of its own);
   - the body was held in place: within 5% of the offset of where it is let go;
   - the following motion crosses rest at least twice, with amplitudes not growing, its
     first half swing (from the end of the hold) lasts 0.5-2 half periods and overshoots
     rest by at least 0.4x the decay ratio of the next half swing (a free oscillation,
     not a hand lowering the body into a hand-held jiggle); or, with strong dry friction,
     it overshoots rest once by at least 10% of the offset and then stops.
   A record that starts slow and away from rest (a simulation started at the release
   state) has its release at the first sample.
4. The free response ends at the last turning point before the amplitude grows again (a
   hand), the rhythm breaks (a hold or a stop), or the swings sink into the noise, plus
   half a period; or at the end of the file.
5. The release instant is refined on the raw samples by fitting a hinge model: a (nearly)
   constant hold, continued after the release instant t_r by the onset of free motion
   y_h + v0 tau + c2 tau^2 + c3 tau^3 (tau = t - t_r): released from rest the body starts
   with zero velocity and constant acceleration, so the kink in curvature marks t_r.

Ramp recordings are different: the robot starts from rest and rolls, so the single
"release" is the start of motion of the drive rate (hinge fit of a constant followed by a
linear/quadratic rise), ending at ``ramp_exit_s`` if the recording says when the robot left
the ramp.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.ndimage import maximum_filter1d, median_filter, minimum_filter1d
from scipy.signal import savgol_filter

from roboball.errors import RoboballError
from roboball.kinds import OSCILLATING

if TYPE_CHECKING:  # pragma: no cover
    from roboball.ingest.recording import Recording

__all__ = [
    "Release",
    "PreparedSignal",
    "prepare_signal",
    "zigzag",
    "find_releases",
    "recording_releases",
    "require_releases",
]

OSCILLATING_KINDS = OSCILLATING


@dataclass
class Release:
    """One release and the free response after it.

    Times in seconds in the recording's time base; indices into the arrays given to
    :func:`find_releases` (i_release: last sample at or before the release instant;
    i_end: last sample at or before t_end_s).  y_* in the signal's unit.
    """

    t_release_s: float
    t_end_s: float
    i_release: int
    i_end: int
    y_release: float
    y_rest: float
    held_from_s: float
    half_period_s: float = float("nan")
    noise: float = float("nan")
    kind: str = ""

    def __post_init__(self):
        # JSON has no NaN: unknown numbers travel as null and come back as NaN.
        for name in ("y_release", "y_rest", "half_period_s", "noise"):
            if getattr(self, name) is None:
                setattr(self, name, float("nan"))

    def as_dict(self) -> dict:
        """Plain dict for JSON: unknown numbers (NaN) become None; Release(**d) restores them."""
        d = asdict(self)
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in d.items()}


@dataclass
class PreparedSignal:
    """A signal cleaned for event detection: raw samples without duplicate stamps (tk, yk,
    with `index` mapping back to the caller's arrays), a uniform grid (tu, yu), the
    smoothed signal ys, the noise level sigma and the quantisation step q (0 if none)."""

    tk: np.ndarray
    yk: np.ndarray
    index: np.ndarray
    tu: np.ndarray
    yu: np.ndarray
    ys: np.ndarray
    vs: np.ndarray
    dt: float
    sigma: float
    sigma_v: float
    q: float

    @property
    def hysteresis(self) -> float:
        return max(5.0 * self.sigma, 2.0 * self.q)


def _odd(n: float, minimum: int) -> int:
    n = max(int(round(n)), minimum)
    return n if n % 2 == 1 else n + 1


def _quantum(y: np.ndarray) -> float:
    """The quantisation step of a logged signal, or 0 when the values are not on a grid."""
    d = np.abs(np.diff(y))
    scale = max(float(np.max(np.abs(y))), 1e-12)
    nz = d[d > 1e-9 * scale]
    if nz.size < 10:
        return 0.0
    q = float(np.min(nz))
    if q <= 0:
        return 0.0
    # On a grid every step is (nearly) an integer multiple of q.
    ratio = nz / q
    multiples = np.unique(np.round(ratio))
    # On a grid every step is (nearly) an integer multiple of q, and a moving signal takes
    # steps of several sizes (a uniformly sampled straight line takes only one).
    if np.mean(np.abs(ratio - np.round(ratio)) < 0.05) > 0.95 and len(multiples) >= 3:
        return q
    return 0.0


def prepare_signal(t, y, grid_dt: float | None = None) -> PreparedSignal:
    """Drop non-finite samples and duplicate stamps, resample onto a uniform grid, smooth,
    and estimate the noise level (see the module docstring)."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if t.shape != y.shape or t.ndim != 1:
        raise ValueError("t and y must be 1-D arrays of equal length")
    finite = np.isfinite(t) & np.isfinite(y)
    idx = np.nonzero(finite)[0]
    tk, yk = t[idx], y[idx]
    order = np.argsort(tk, kind="stable")
    tk, yk, idx = tk[order], yk[order], idx[order]
    keep = np.ones(len(tk), dtype=bool)
    keep[1:] = np.diff(tk) > 0
    tk, yk, idx = tk[keep], yk[keep], idx[keep]
    if len(tk) < 3:
        raise ValueError("need at least 3 distinct time stamps")
    span = tk[-1] - tk[0]
    if grid_dt is None:
        grid_dt = float(np.median(np.diff(tk)))
        grid_dt = max(grid_dt, span / 200_000.0)
    n = int(math.floor(span / grid_dt)) + 1
    tu = tk[0] + grid_dt * np.arange(n)
    yu = np.interp(tu, tk, yk)
    win_s = _odd(0.06 / grid_dt, 5)
    ys = savgol_filter(yu, win_s, 2, mode="interp") if n > win_s else yu.copy()
    # Noise: robust spread of the raw samples about a local cubic fit (0.1 s windows),
    # measured on the raw samples because interpolation onto the grid averages noise away.
    win_n = _odd(0.10 / grid_dt, 7)
    if n > win_n:
        smooth = savgol_filter(yu, win_n, 3, mode="interp")
        resid = yk - np.interp(tk, tu, smooth)
        sigma = 1.4826 * float(np.median(np.abs(resid - np.median(resid))))
    else:
        sigma = float(np.std(yk))
    q = _quantum(yk)
    scale = max(float(np.ptp(yk)), 1e-12)
    sigma = max(sigma, q / math.sqrt(12.0), 1e-9 * scale)
    # Velocity: Savitzky-Golay derivative over ~0.15 s, then a running median of 0.1 s so a
    # single noisy sample cannot interrupt a hold.  The derivative's noise is that of a
    # least-squares slope over the window: sigma / (dt sqrt(sum k^2)).
    win_v = _odd(0.15 / grid_dt, 5)
    if n > win_v:
        vs = savgol_filter(yu, win_v, 2, deriv=1, delta=grid_dt, mode="interp")
        vs = median_filter(vs, size=_odd(0.10 / grid_dt, 3), mode="nearest")
    else:
        vs = np.gradient(yu, grid_dt)
    half = win_v // 2
    sigma_v = sigma / (grid_dt * math.sqrt(half * (half + 1) * (2 * half + 1) / 3.0))
    return PreparedSignal(tk=tk, yk=yk, index=idx, tu=tu, yu=yu, ys=ys, vs=vs, dt=grid_dt,
                          sigma=sigma, sigma_v=sigma_v, q=q)


def zigzag(y: np.ndarray, h: float) -> np.ndarray:
    """Indices of the alternating turning points of `y`: a maximum is confirmed when the
    signal has since fallen by more than `h`, a minimum when it has since risen by more than
    `h` (hysteresis, so noise smaller than `h` makes no turning points)."""
    y = np.asarray(y, dtype=float)
    n = len(y)
    if n == 0:
        return np.array([], dtype=int)
    ext: list[int] = []
    imax = imin = 0
    direction = 0
    for i in range(1, n):
        v = y[i]
        if direction == 0:
            if v > y[imax]:
                imax = i
            if v < y[imin]:
                imin = i
            if y[imax] - v > h:
                ext.append(imax)
                direction = -1
                imin = i
            elif v - y[imin] > h:
                ext.append(imin)
                direction = 1
                imax = i
        elif direction < 0:
            if v < y[imin]:
                imin = i
            elif v - y[imin] > h:
                ext.append(imin)
                direction = 1
                imax = i
        else:
            if v > y[imax]:
                imax = i
            elif y[imax] - v > h:
                ext.append(imax)
                direction = -1
                imin = i
    # The last excursion counts too if it left the previous turning point by more than h.
    if direction < 0 and ext and y[ext[-1]] - y[imin] > h:
        ext.append(imin)
    elif direction > 0 and ext and y[imax] - y[ext[-1]] > h:
        ext.append(imax)
    return np.asarray(ext, dtype=int)


# --------------------------------------------------------------------------------------
# Hinge fits: the precise instant where motion starts
# --------------------------------------------------------------------------------------
def _hinge_fit(t: np.ndarray, y: np.ndarray, t_lo: float, t_hi: float, powers: tuple[int, ...],
               pre_slope: bool) -> tuple[float, np.ndarray]:
    """Least-squares hinge: y = c0 [+ c1 tau] + sum_k c_k max(tau, 0)^p_k, tau = t - t_r.
    Scans t_r over [t_lo, t_hi] (fine grid, then a local parabola) and returns
    (t_r, coefficients)."""
    if len(t) < 6 or t_hi <= t_lo:
        return 0.5 * (t_lo + t_hi), np.array([float(np.mean(y)) if len(y) else 0.0])
    span = max(t[-1] - t[0], 1e-9)
    step = min(0.002, (t_hi - t_lo) / 20.0)
    grid = np.arange(t_lo, t_hi + 0.5 * step, step)
    best = (np.inf, None, None)
    sses = np.empty(len(grid))
    for g, tr in enumerate(grid):
        tau = (t - tr) / span
        taup = np.maximum(tau, 0.0)
        cols = [np.ones_like(tau)]
        if pre_slope:
            cols.append(tau)
        cols += [taup ** p for p in powers]
        A = np.column_stack(cols)
        coef, *_ = np.linalg.lstsq(A, y, rcond=None)
        r = y - A @ coef
        sse = float(r @ r)
        sses[g] = sse
        if sse < best[0]:
            best = (sse, tr, coef)
    g = int(np.argmin(sses))
    tr = best[1]
    if 0 < g < len(grid) - 1:
        s0, s1, s2 = sses[g - 1], sses[g], sses[g + 1]
        den = s0 - 2 * s1 + s2
        if den > 0:
            tr = grid[g] + 0.5 * step * (s0 - s2) / den
    return float(tr), best[2]


# --------------------------------------------------------------------------------------
# Oscillating kinds: hold, let go, free decaying oscillation
# --------------------------------------------------------------------------------------
def _rest_estimate(ext_vals: np.ndarray) -> float:
    """Rest level of a decaying oscillation from its turning points E_k.

    Successive turning points lie on opposite sides of rest R with E_{k+1} - R =
    -r (E_k - R), r being the decay ratio per half cycle (the median ratio of successive
    peak-to-peak swings), so every pair gives R = (E_{k+1} + r E_k) / (1 + r); the median
    over all pairs is robust to noise and to a changing ratio (dry friction)."""
    e = np.asarray(ext_vals, dtype=float)
    if len(e) < 2:
        return float(e[-1])
    p2p = np.abs(np.diff(e))
    if len(p2p) >= 2 and np.all(p2p[:-1] > 0):
        r = float(np.median(p2p[1:] / p2p[:-1]))
        r = min(max(r, 0.05), 1.0)
    else:
        r = 1.0
    return float(np.median((e[1:] + r * e[:-1]) / (1.0 + r)))


def _settled_level(sig: PreparedSignal, k_from: int, half_period: float, lo: float, hi: float) -> float | None:
    """Level at which the body comes to rest after grid index `k_from`: the mean of the
    first still stretch (0.5 s with a spread of at most 3 hysteresis steps, averaged over up
    to 3 s) that starts within 1.5 half periods, if that level lies in [lo, hi]; else None."""
    ys, h = sig.ys, sig.hysteresis
    settle_n = max(int(round(0.5 / sig.dt)), 1)
    tail = ys[k_from:k_from + int(1.5 * half_period / sig.dt) + 2 * settle_n + int(3.0 / sig.dt)]
    if len(tail) <= settle_n:
        return None
    half_w = settle_n // 2
    spread = (maximum_filter1d(tail, settle_n, mode="nearest")
              - minimum_filter1d(tail, settle_n, mode="nearest"))[half_w:len(tail) - half_w]
    still = np.nonzero(spread <= 3 * h)[0]
    if not still.size or still[0] * sig.dt > 1.5 * half_period:
        return None
    i0 = int(still[0])
    moving = np.nonzero(spread[i0:] > 3 * h)[0]
    i1 = i0 + (int(moving[0]) if moving.size else len(spread) - i0) + settle_n - 1
    i1 = min(i1, i0 + int(3.0 / sig.dt), len(tail))
    level = float(np.mean(tail[i0:i1]))
    return level if lo <= level <= hi else None


def _hold_around(sig: PreparedSignal, k_from: int, k_to: int, k_floor: int, v_thr: float) -> tuple[int, int]:
    """The hold that ends where the body starts its swing towards the turning point at
    `k_to`: returns grid indices (s, c) of the last stretch with |velocity| <= v_thr before
    the fastest point of that swing, searching forward from `k_from` and back to `k_floor`."""
    vs = sig.vs
    k_fast = k_from + int(np.argmax(np.abs(vs[k_from:k_to + 1])))
    slow = np.nonzero(np.abs(vs[k_from:k_fast + 1]) <= v_thr)[0]
    if not slow.size:
        return k_from, k_from  # never slow: no hold
    c = k_from + int(slow[-1])
    fast_before = np.nonzero(np.abs(vs[k_floor:c + 1]) > v_thr)[0]
    s = k_floor + (int(fast_before[-1]) + 1 if fast_before.size else 0)
    return min(s, c), c


def _velocity_threshold(sig: PreparedSignal, amplitude: float, omega: float, frac: float) -> float:
    """Speed below which the body counts as held: a fraction of the free swing's peak speed
    (amplitude * omega), but at least 4x the noise of the smoothed velocity."""
    return max(frac * abs(amplitude) * omega, 4.0 * sig.sigma_v)


def _is_hold(sig: PreparedSignal, ext: np.ndarray, m: int, omega: float, amplitude: float,
             min_hold_s: float, hold_speed: float) -> bool:
    """Is turning point m held still (slow for longer than `min_hold_s` and than the turning
    point of a free swing of `omega` and `amplitude` could be)?"""
    k_prev = ext[m - 1] if m > 0 else 0
    k_next = ext[m + 1] if m + 1 < len(ext) else len(sig.ys) - 1
    v_thr = _velocity_threshold(sig, amplitude, omega, hold_speed)
    s, c = _hold_around(sig, ext[m], k_next, k_prev, v_thr)
    return _long_enough(sig.tu[c] - sig.tu[s], v_thr, amplitude, omega, min_hold_s)


def _long_enough(held: float, v_thr: float, amplitude: float, omega: float, min_hold_s: float) -> bool:
    """A free swing of `amplitude` and `omega` is slower than v_thr for only
    2 asin(v_thr / (A omega)) / omega around a turning point; a hold must last clearly longer."""
    x = min(v_thr / max(abs(amplitude) * omega, 1e-300), 1.0)
    t_free = 2.0 * math.asin(x) / omega
    return held >= max(min_hold_s, 2.5 * t_free)


def _holds_inside_swings(sig: PreparedSignal, ext: np.ndarray, min_hold_s: float,
                         hold_speed: float) -> tuple[np.ndarray, set]:
    """`ext` with the holds that lie inside a monotone stretch added as pairs of turning points
    (the hold's first and middle still sample), and the positions in the result of those
    holds' first samples: a motion ends there, and no release starts there.  A hand that
    catches a swing near its extreme, lowers the body towards rest, holds it there and lets go
    makes no turning point at that hold: the release swing goes on the way the hand moved.
    A free swing is slow only at its turning points, so a still stretch (slower than
    `hold_speed` of the stretch's peak speed, and than 4 noise levels of the velocity, for at
    least `min_hold_s`) with fast motion on both sides, each moving the body by more than 4
    hysteresis steps, is a hold."""
    vs, dt = sig.vs, sig.dt
    n_hold = max(int(math.ceil(min_hold_s / dt)), 2)
    out: list[int] = []
    starts: set = set()
    for a, b in zip(ext[:-1], ext[1:]):
        out.append(int(a))
        if b - a < n_hold + 2:
            continue
        v = np.abs(vs[a:b + 1])
        thr = max(hold_speed * float(np.max(v)), 4.0 * sig.sigma_v)
        fast = np.nonzero(v > thr)[0]
        if fast.size < 2:
            continue
        gaps = np.diff(fast)
        g = int(np.argmax(gaps))
        if gaps[g] - 1 >= n_hold:                 # the longest still stretch, fast on both sides
            first, last_still = int(a + fast[g] + 1), int(a + fast[g + 1] - 1)
            # A hand's move into the hold and a release swing out of it: both travel clearly
            # further than the noise (a body at rest jitters through tiny monotone stretches).
            moves = (abs(sig.ys[first] - sig.ys[a]), abs(sig.ys[b] - sig.ys[last_still]))
            if min(moves) < 4.0 * sig.hysteresis:
                continue
            starts.add(len(out))
            out += [first, (first + last_still) // 2]   # a release's search for its hold starts inside it
    if len(ext):
        out.append(int(ext[-1]))
    return np.asarray(out, dtype=int), starts


def _oscillation_releases(sig: PreparedSignal, kind: str, min_hold_s: float, min_offset_sigma: float,
                          hold_speed: float, min_relative_offset: float) -> list[Release]:
    tu, ys = sig.tu, sig.ys
    h = sig.hysteresis
    ext, inner_holds = _holds_inside_swings(sig, zigzag(ys, h), min_hold_s, hold_speed)
    n_ext = len(ext)
    releases: list[Release] = []
    floor_index = 0
    j = 0
    while j < n_ext - 2:
        if j in inner_holds:
            j += 1  # the start of a hold inside a monotone stretch: a release starts at its end
            continue
        k0, k1 = ext[j], ext[j + 1]
        Y = ys[k0]
        # Follow the motion after turning point j: its turning points while the rhythm holds,
        # the amplitude does not grow, the swings stay above the noise and no new hold starts.
        vals = [Y]
        hp_list: list[float] = [tu[k1] - tu[k0]]
        vals.append(ys[k1])
        last = j + 1
        m = j + 2
        while m < n_ext:
            if m in inner_holds:
                break  # a hand stops the body on its way (a hold inside a monotone stretch)
            hp = tu[ext[m]] - tu[ext[m - 1]]
            p2p = abs(ys[ext[m]] - ys[ext[m - 1]])
            p2p_prev = abs(ys[ext[m - 1]] - ys[ext[m - 2]])
            ref = float(np.median(hp_list[1:])) if m >= j + 3 else hp
            if m >= j + 3 and (hp > 2.0 * ref or hp < 0.5 * ref):
                break  # the rhythm breaks: a stop, a hold or noise
            if m >= j + 3 and p2p > 1.25 * p2p_prev + 2 * h:
                break  # the amplitude grows: a hand moves the body
            if p2p < 1.2 * h:
                break  # the swings have sunk into the noise
            if _is_hold(sig, ext, m, omega=math.pi / ref, amplitude=0.5 * p2p,
                        min_hold_s=min_hold_s, hold_speed=hold_speed):
                break  # turning point m is held (a hand, or the body has stopped): the free
                # response ended before it
            hp_list.append(hp)
            vals.append(ys[ext[m]])
            last = m
            m += 1
        vals_a = np.asarray(vals)
        single = last == j + 1
        if single:
            # One overshoot, then the body stops (strong dry friction, as in the drive
            # stand): a release only if it settles soon after that turning point, between it
            # and the hold.
            half_period = float(hp_list[0])
            rest = _settled_level(sig, k1, half_period, min(Y, vals[1]) + h, max(Y, vals[1]) - h)
            if rest is None:
                j += 1
                continue
        else:
            half_period = float(np.median(hp_list[1:]))
            # Final rest: the settled signal after the last turning point if it settles
            # there (between its last two turning points, or at the last one if dry friction
            # stops it), else extrapolated from the decay of the turning points.
            rest = _settled_level(sig, ext[last], half_period,
                                  min(vals[-1], vals[-2]) - 3 * h, max(vals[-1], vals[-2]) + 3 * h)
            # A body comes to rest through decaying swings.  Swings that kept their size until
            # they stop were stopped by a hand (a lightly damped shell grabbed mid-swing and held
            # between its extremes): the level it is held at is not the rest of the motion.  The
            # last swing may be cut short by the grab, so the larger of the last two is compared
            # with the first full swing after the release.
            if rest is not None and last >= j + 4 and \
                    max(abs(vals[-1] - vals[-2]), abs(vals[-2] - vals[-3])) > 0.9 * abs(vals[2] - vals[1]):
                rest = None
            extrapolated = _rest_estimate(vals_a[1:]) if len(vals_a) > 3 else _rest_estimate(vals_a)
        k_last = ext[last]
        k_next = ext[last + 1] if last + 1 < n_ext else len(ys) - 1
        omega = math.pi / half_period
        # Rest levels to try, in order.  A settled level found after the last turning point
        # may be a hand's hold near rest instead (a lightly damped body grabbed mid-swing and
        # moved to its next hold before the swings decayed); then the swings themselves do not
        # swing about it (checked below), and the rest extrapolated from their decay is tried.
        rests = [rest] if single else [r_ for r_ in (rest, extrapolated) if r_ is not None]
        for rest in rests:
            offset = Y - rest
            dev = vals_a - rest
            ok = abs(offset) >= max(min_offset_sigma * sig.sigma, 4 * h)
            ok = ok and dev[1] * offset < 0 and abs(dev[1]) < 1.05 * abs(offset) + h
            if single:
                ok = ok and abs(dev[1]) >= 0.1 * abs(offset)  # a real overshoot, not a hand placing it
            else:
                ok = ok and dev[2] * offset > 0
                # The first half swing loses no more than a damped oscillation does later on: a
                # hand that lowers the body into a hand-held jiggle overshoots far less.
                ok = ok and abs(dev[1] / offset) >= 0.4 * abs(dev[2] / dev[1])
            if ok:
                break
        if ok:
            v_thr = _velocity_threshold(sig, offset, omega, hold_speed)
            s, c = _hold_around(sig, k0, k1, floor_index, v_thr)
            if single:
                # The only half period available is the first swing itself, from the hold's end.
                half_period = max(float(tu[k1] - tu[c]), 2 * sig.dt)
                omega = math.pi / half_period
                v_thr = _velocity_threshold(sig, offset, omega, hold_speed)
                s, c = _hold_around(sig, k0, k1, floor_index, v_thr)
            # Held means slow AND in place: no more than 5% of the offset (plus noise) away
            # from where it is let go (a slow hand movement is slow but not in place).
            away = np.nonzero(np.abs(ys[s:c + 1] - ys[c]) > 0.05 * abs(offset) + 3 * sig.sigma)[0]
            if away.size:
                s = s + int(away[-1]) + 1
            # From the end of the hold, the first half swing lasts about a half period.
            ok = single or 0.5 <= (tu[k1] - tu[c]) / half_period <= 2.0
            held_long = _long_enough(tu[c] - tu[s], v_thr, offset, omega, min_hold_s)
            # A record that starts at rest away from rest (a simulation started at the
            # release state, or a log started during the hold) begins with its release.
            starts_held = s == 0 and abs(sig.vs[0]) <= v_thr
            ok = ok and (held_long or starts_held)
        if not ok:
            j += 1
            continue
        # End of the free response: half a period after the last turning point, but not
        # after the signal leaves rest again for the next hand action.
        t_end = tu[k_last] + half_period
        if last + 1 < n_ext:
            tail = ys[k_last:k_next + 1]
            near = np.nonzero(np.abs(tail - rest) <= max(2 * h, 0.25 * abs(vals_a[-1] - rest)))[0]
            if near.size:
                t_end = min(t_end, float(tu[k_last + int(near[-1])]))
            t_end = max(t_end, float(tu[k_last]))
        t_end = min(t_end, float(sig.tk[-1]))
        # Refine the release instant on the raw samples: hinge between a (slowly drifting)
        # hold and the constant-acceleration onset of free motion.
        t_c = tu[c]
        Yc = ys[c]
        target = Yc - 0.2 * (Yc - rest)
        after = np.nonzero((ys[c:k1] - target) * np.sign(offset) <= 0)[0]
        t_b = tu[c + int(after[0])] if after.size else tu[k1]
        t_a = max(tu[s], t_c - 0.6)
        sel = (sig.tk >= t_a) & (sig.tk <= t_b)
        # Released from rest the body reaches v_thr after about v_thr / (omega^2 A).
        tau_exit = v_thr / (omega ** 2 * abs(offset))
        lo = max(t_a + 0.02, t_c - max(3.0 * tau_exit + 0.05, 0.1))
        hi = min(t_c + 0.05, t_b - 0.02)
        if held_long and hi - lo > 0.01:
            t_r, coef = _hinge_fit(sig.tk[sel], sig.yk[sel], lo, hi, (2,), pre_slope=True)
            if not (tu[s] - 0.1 <= t_r <= t_b):
                t_r = t_c
            y_rel = float(coef[0]) if coef is not None else float(Yc)
        else:
            t_r, y_rel = float(sig.tk[0]), float(sig.yk[0])
        if releases and releases[-1].t_end_s > tu[s]:
            releases[-1].t_end_s = float(max(releases[-1].t_release_s, tu[s]))
        releases.append(
            Release(
                t_release_s=float(t_r),
                t_end_s=float(t_end),
                i_release=-1,
                i_end=-1,
                y_release=y_rel,
                y_rest=float(rest),
                held_from_s=float(tu[s]),
                half_period_s=half_period,
                noise=sig.sigma,
                kind=kind,
            )
        )
        floor_index = int(ext[last])
        j = max(last, j + 1)
    # A hand that holds the body never holds it perfectly still: its tremor makes small
    # "releases" of its own (the shell log has several of a few mrad while held at -0.4 rad).
    # Keep only releases whose offset is a sizeable fraction of the largest one.
    if releases:
        scale = max(abs(r.y_release - r.y_rest) for r in releases)
        releases = [r for r in releases if abs(r.y_release - r.y_rest) >= min_relative_offset * scale]
    return releases


# --------------------------------------------------------------------------------------
# Ramp: start of motion
# --------------------------------------------------------------------------------------
def _ramp_release(sig: PreparedSignal, ramp_exit_s: float | None) -> list[Release]:
    tu, ys = sig.tu, sig.ys
    n0 = max(int(round(0.3 / sig.dt)), 3)
    y0 = float(np.median(ys[:n0]))
    dev = np.abs(ys - y0)
    peak = float(np.max(dev))
    thr = max(10.0 * sig.sigma, 0.05 * peak)
    if peak <= max(20.0 * sig.sigma, 2 * sig.hysteresis):
        return []
    k = int(np.nonzero(dev > thr)[0][0])
    # Rest before motion: back from k to where the signal is within 3 sigma of y0.
    quiet = np.nonzero(dev[:k] <= max(3.0 * sig.sigma, sig.q))[0]
    k_q = int(quiet[-1]) if quiet.size else 0
    t_lo = tu[k_q] - 0.2
    t_hi = tu[k]
    t_a = max(tu[0], t_lo - 0.5)
    t_b = min(tu[-1], t_hi + 0.3)
    sel = (sig.tk >= t_a) & (sig.tk <= t_b)
    t_r, coef = _hinge_fit(sig.tk[sel], sig.yk[sel], max(t_lo, t_a + 0.02), t_hi, (1, 2), pre_slope=False)
    t_end = float(sig.tk[-1]) if ramp_exit_s is None else float(min(max(ramp_exit_s, t_r), sig.tk[-1]))
    return [
        Release(
            t_release_s=float(t_r),
            t_end_s=t_end,
            i_release=-1,
            i_end=-1,
            y_release=float(coef[0]) if coef is not None else y0,
            y_rest=y0,
            held_from_s=float(tu[0]),
            noise=sig.sigma,
            kind="ramp",
        )
    ]


def find_releases(
    t,
    y,
    kind: str,
    *,
    ramp_exit_s: float | None = None,
    min_hold_s: float = 0.25,
    min_offset_sigma: float = 20.0,
    hold_speed: float = 0.1,
    min_relative_offset: float = 0.05,
) -> list[Release]:
    """Find the releases in one signal (see the module docstring for the method).

    `kind` is a recording kind: steer_stand, drive_stand, shell_rock (hand releases and
    free oscillations) or ramp (one start of motion, ending at `ramp_exit_s` if given).
    `min_hold_s`: shortest hand hold accepted; `min_offset_sigma`: smallest hold offset
    from rest, in noise levels; `hold_speed`: fastest speed that still counts as held, as a
    fraction of the free swing's peak speed (offset x omega); `min_relative_offset`:
    releases smaller than this fraction of the file's largest release are taken for hand
    tremor and dropped.  Works on irregular sampling with gaps and duplicate stamps.
    Returns the releases in time order (possibly none).
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if kind not in OSCILLATING_KINDS + ("ramp",):
        raise ValueError(f"find_releases: unknown kind {kind!r}")
    try:
        sig = prepare_signal(t, y)
    except ValueError:
        return []
    if kind == "ramp":
        releases = _ramp_release(sig, ramp_exit_s)
    else:
        releases = _oscillation_releases(sig, kind, min_hold_s, min_offset_sigma, hold_speed,
                                         min_relative_offset)
    # Indices into the caller's arrays.
    for r in releases:
        pos = int(np.searchsorted(sig.tk, r.t_release_s, side="right")) - 1
        r.i_release = int(sig.index[max(pos, 0)])
        pos = int(np.searchsorted(sig.tk, r.t_end_s, side="right")) - 1
        r.i_end = int(sig.index[max(pos, 0)])
    return releases


def recording_releases(rec: "Recording", signal: str | None = None, **kwargs) -> list[Release]:
    """:func:`find_releases` on a recording's main signal (or `signal`)."""
    name = signal or rec.main_signal()
    kwargs.setdefault("ramp_exit_s", rec.ramp_exit_s)
    return find_releases(rec.time, rec.signal(name), rec.kind, **kwargs)


def require_releases(rec: "Recording", signal: str | None = None, **kwargs) -> list[Release]:
    """Like :func:`recording_releases`, but a recording without any release is a user
    error: raises a one-line :class:`RoboballError` naming the file."""
    name = signal or rec.main_signal()
    releases = recording_releases(rec, name, **kwargs)
    if not releases:
        if rec.kind == "ramp":
            what = "no start of motion found (the drive rate never leaves its initial rest)"
        else:
            what = ("no release found (no hold away from rest followed by a free, decaying "
                    "oscillation)")
        raise RoboballError(
            f"{rec.label}: {name}: {what}; check the kind and the signal, "
            "or record a hand release (move, hold still, let go)"
        )
    return releases
