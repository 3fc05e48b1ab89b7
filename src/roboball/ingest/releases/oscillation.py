"""Releases of the oscillating kinds: a hand holds the body away from rest and lets go, and a
free, decaying oscillation follows (steps 3-5 of roboball.ingest.releases)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roboball.ingest.releases.hinge import hinge_fit
from roboball.ingest.releases.holds import hold_around, holds_inside_swings, is_hold, long_enough, velocity_threshold
from roboball.ingest.releases.record import Release
from roboball.ingest.releases.rest import rest_estimate, settled_level
from roboball.ingest.releases.signal import PreparedSignal, zigzag
from roboball.ingest.releases.trimmed import starts_released

__all__ = ["oscillation_releases"]


@dataclass
class _Swings:
    """The motion after the candidate hold at turning point `j` (grid index `k0`): the values of
    its turning points (`vals[0]` is the hold's level), the half periods between them
    (`half_periods[0]` from the hold's turning point to `k1`, the end of the first swing), and
    the position `last` in the turning points of the last one that belongs to the free response."""

    j: int
    k0: int
    k1: int
    vals: list
    half_periods: list
    last: int
    grown_at: int | None = None     # the turning point that ended a move larger than the swing before it

    @property
    def single(self) -> bool:
        """One overshoot, then the body stops (no second swing)."""
        return self.last == self.j + 1

    def turning(self, sig: PreparedSignal, ext: np.ndarray) -> tuple[list, list]:
        """(vals, half_periods) without a last point that is only where the record ends: a
        record cut while the body still swings ends on the way, not at a turning point, and
        that point's value and the time to it would bias the rest extrapolated from the decay
        (a nearly undamped 0.6 rad shell release logged for 1.5 swings put the rest 0.045 rad
        off, and the release's first overshoot then looked larger than its offset).  Kept when
        too few turning points would remain (hold, and two after it)."""
        if int(ext[self.last]) == len(sig.ys) - 1 and len(self.vals) >= 4 and len(self.half_periods) >= 3:
            return self.vals[:-1], self.half_periods[:-1]
        return self.vals, self.half_periods


@dataclass
class _Hold:
    """The hand's hold before a release: grid indices s (first still sample) and c (last), the
    speed that counted as still, the half period and angular frequency of the swing (re-measured
    from the hold's end when there is only one swing), and whether the hold was long enough."""

    s: int
    c: int
    v_thr: float
    half_period: float
    omega: float
    held_long: bool


def oscillation_releases(sig: PreparedSignal, kind: str, min_hold_s: float, min_offset_sigma: float,
                         hold_speed: float, min_relative_offset: float) -> list[Release]:
    """The releases of a stand or shell signal (steps 2-5 of roboball.ingest.releases).

    Args:
        sig: the prepared signal.
        kind: the recording kind, stored in each Release.
        min_hold_s, min_offset_sigma, hold_speed, min_relative_offset: as in
            :func:`roboball.ingest.releases.find.find_releases`.

    Returns:
        The releases in time order; each one's free response ends before the next one's hold.
    """
    ext, inner_holds = holds_inside_swings(sig, zigzag(sig.ys, sig.hysteresis), min_hold_s, hold_speed)
    n_ext = len(ext)
    releases: list[Release] = []
    floor_index = 0
    j = 0
    while j < n_ext - 2:
        if j in inner_holds:
            j += 1  # the start of a hold inside a monotone stretch: a release starts at its end
            continue
        sw = _follow_swings(sig, ext, inner_holds, j, min_hold_s, hold_speed)
        release = _release_of(sig, ext, sw, floor_index, kind, min_hold_s, min_offset_sigma, hold_speed)
        if release is None:
            j += 1
            continue
        if releases and releases[-1].t_end_s > release.held_from_s:
            releases[-1].t_end_s = float(max(releases[-1].t_release_s, release.held_from_s))
        releases.append(release)
        floor_index = int(ext[sw.last])
        j = max(sw.last, j + 1)
    return _without_tremor(releases, min_relative_offset)


def _follow_swings(sig: PreparedSignal, ext: np.ndarray, inner_holds: set, j: int, min_hold_s: float,
                   hold_speed: float) -> _Swings:
    """Follow the motion after turning point j: its turning points while the rhythm holds, the
    amplitude does not grow, the swings stay above the noise and no new hold starts."""
    tu, ys, h = sig.tu, sig.ys, sig.hysteresis
    n_ext = len(ext)
    k0, k1 = ext[j], ext[j + 1]
    Y = ys[k0]
    vals = [Y]
    hp_list: list[float] = [tu[k1] - tu[k0]]
    vals.append(ys[k1])
    last = j + 1
    grown_at = None
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
            grown_at = m
            break  # the amplitude grows: a hand moves the body
        if p2p < 1.2 * h:
            break  # the swings have sunk into the noise
        if is_hold(sig, ext, m, omega=math.pi / ref, amplitude=0.5 * p2p,
                   min_hold_s=min_hold_s, hold_speed=hold_speed):
            break  # turning point m is held (a hand, or the body has stopped): the free
            # response ended before it
        hp_list.append(hp)
        vals.append(ys[ext[m]])
        last = m
        m += 1
    return _Swings(j=j, k0=k0, k1=k1, vals=vals, half_periods=hp_list, last=last, grown_at=grown_at)


def _release_of(sig: PreparedSignal, ext: np.ndarray, sw: _Swings, floor_index: int, kind: str,
                min_hold_s: float, min_offset_sigma: float, hold_speed: float) -> Release | None:
    """The release at the start of `sw`, or None if its start is no hand's release: no rest to
    swing about, no swing that fits a free oscillation about it, or no hold before it.
    `floor_index`: the grid index before which the hold may not start (the previous response)."""
    if _held_first_turn(sig, ext, sw, min_hold_s, hold_speed) or _grown_unheld(sig, ext, sw, min_hold_s):
        return None
    found = _rest_candidates(sig, ext, sw)
    if found is None:
        return None
    half_period, measured, rests = found
    fitting = _first_fitting_rest(sig, sw, rests, min_offset_sigma)
    if fitting is None:
        return None
    rest, offset = fitting
    hold = _hold_before(sig, sw, offset, half_period, measured, floor_index, min_hold_s, hold_speed)
    if hold is None:
        return None
    t_end = _end_of_response(sig, ext, sw, rest, hold.half_period)
    t_r, y_rel = _release_instant(sig, sw.k1, hold, rest, offset)
    return Release(
        t_release_s=float(t_r),
        t_end_s=float(t_end),
        i_release=-1,
        i_end=-1,
        y_release=y_rel,
        y_rest=float(rest),
        held_from_s=float(sig.tu[hold.s]),
        half_period_s=hold.half_period,
        noise=sig.sigma,
        kind=kind,
    )


def _held_first_turn(sig: PreparedSignal, ext: np.ndarray, sw: _Swings, min_hold_s: float,
                     hold_speed: float) -> bool:
    """Whether the first turning point after the candidate hold is itself held, with swings after
    it: then the way to it was a hand's move (from rest to the hold it then lets go from), not a
    free half swing, which turns at once.  In a short record that holds less than one swing after
    the let-go, the hand's move from rest otherwise passed for a release and the hold it ends in
    for the rest (a first recording of a 0.05-0.3 rad shell release logged 1-2 s).  A body that
    overshoots once and is stopped there by dry friction has no swings after that turning point
    (`_Swings.single`) and is left alone."""
    if sw.single or len(sw.vals) < 3:
        return False
    amplitude = 0.5 * abs(sw.vals[2] - sw.vals[1])
    omega = math.pi / max(float(sw.half_periods[1]), 2 * sig.dt)
    return is_hold(sig, ext, sw.j + 1, omega=omega, amplitude=amplitude, min_hold_s=min_hold_s,
                   hold_speed=hold_speed)


def _grown_unheld(sig: PreparedSignal, ext: np.ndarray, sw: _Swings, min_hold_s: float) -> bool:
    """Whether the swings ended in a move larger than the swing before it (taken for a hand's)
    that is no hand's: a hand that takes a swinging body moves it into its next hold and lets go
    from there, so the body stays where the move ended (within 5% of the move and 3 noise levels,
    its tremor included) for `min_hold_s` and then swings back.  A shell creeping to rest in steps
    (the pendulum free on its joint, heavily damped: each of its swings pauses the shell) pauses
    too briefly or goes on the move's way after the pause, and its first step passed for a
    release swinging about a rest 0.3-0.5 rad from where the shell settles (the steer-setting
    closed loop's proposed recordings).  A record that ends within the move or the hold shows
    neither and is left alone."""
    m = sw.grown_at
    if m is None or m + 1 >= len(ext):
        return False
    tu, ys = sig.tu, sig.ys
    k = int(ext[m])
    move = float(ys[k] - ys[ext[m - 1]])
    away = np.nonzero(np.abs(ys[k:] - ys[k]) > _in_place(sig, move))[0]
    if away.size == 0:
        return False
    left = k + int(away[0])
    if tu[left] - tu[k] < min_hold_s:
        return True
    return bool(np.sign(ys[left] - ys[k]) == np.sign(move))


def _in_place(sig: PreparedSignal, move: float) -> float:
    """How far a held body may stray from where a hand holds it (its tremor included): 5% of the
    move into or out of the hold, and 3 noise levels."""
    return 0.05 * abs(move) + 3 * sig.sigma


def _rest_candidates(sig: PreparedSignal, ext: np.ndarray, sw: _Swings) -> tuple[float, int, list[float]] | None:
    """The swing's half period, how many half swings after the first measured it (0 for a single
    overshoot) and the rest levels to try, in order; None for a single overshoot that does not
    settle."""
    h = sig.hysteresis
    vals, Y, j, last = sw.vals, sw.vals[0], sw.j, sw.last
    if sw.single:
        # One overshoot, then the body stops (strong dry friction, as in the drive
        # stand): a release only if it settles soon after that turning point, between it
        # and the hold.
        half_period = float(sw.half_periods[0])
        rest = settled_level(sig, sw.k1, half_period, min(Y, vals[1]) + h, max(Y, vals[1]) - h)
        if rest is None:
            return None
        return half_period, 0, [rest]
    turns, half_periods = sw.turning(sig, ext)
    vals_a = np.asarray(turns)
    half_period = float(np.median(half_periods[1:]))
    # Final rest: the settled signal after the last turning point if it settles
    # there (between its last two turning points, or at the last one if dry friction
    # stops it), else extrapolated from the decay of the turning points.
    rest = settled_level(sig, ext[last], half_period,
                         min(vals[-1], vals[-2]) - 3 * h, max(vals[-1], vals[-2]) + 3 * h)
    # A body comes to rest through decaying swings.  Swings that kept their size until
    # they stop were stopped by a hand (a lightly damped shell grabbed mid-swing and held
    # between its extremes): the level it is held at is not the rest of the motion.  The
    # last swing may be cut short by the grab, so the larger of the last two is compared
    # with the first full swing after the release.
    if rest is not None and last >= j + 4 and \
            max(abs(vals[-1] - vals[-2]), abs(vals[-2] - vals[-3])) > 0.9 * abs(vals[2] - vals[1]):
        rest = None
    extrapolated = rest_estimate(vals_a[1:]) if len(vals_a) > 3 else rest_estimate(vals_a)
    # A settled level found after the last turning point may be a hand's hold near rest
    # instead (a lightly damped body grabbed mid-swing and moved to its next hold before the
    # swings decayed); then the swings themselves do not swing about it (checked by
    # _first_fitting_rest), and the rest extrapolated from their decay is tried.
    return half_period, len(half_periods) - 1, [r_ for r_ in (rest, extrapolated) if r_ is not None]


def _first_fitting_rest(sig: PreparedSignal, sw: _Swings, rests: list[float],
                        min_offset_sigma: float) -> tuple[float, float] | None:
    """The first of `rests` the swings oscillate about as a free response does, with the
    hold's offset from it; None if there is none."""
    h = sig.hysteresis
    Y, single = sw.vals[0], sw.single
    vals_a = np.asarray(sw.vals)
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
            return rest, offset
    return None


def _hold_before(sig: PreparedSignal, sw: _Swings, offset: float, half_period: float, measured: int,
                 floor_index: int, min_hold_s: float, hold_speed: float) -> _Hold | None:
    """The hand's hold that ends where the first swing starts; None if the body was not held
    (or, with two or more swings, if the first half swing is not about a half period long: the
    `measured` half swings after it gave `half_period`).  A
    record that starts with its release (held, or trimmed at the let-go: roboball.ingest.releases.trimmed)
    needs no hold before it."""
    tu, ys = sig.tu, sig.ys
    k0, k1, single = sw.k0, sw.k1, sw.single
    omega = math.pi / half_period
    v_thr = velocity_threshold(sig, offset, omega, hold_speed)
    s, c = hold_around(sig, k0, k1, floor_index, v_thr)
    if single:
        # The only half period available is the first swing itself, from the hold's end.
        half_period = max(float(tu[k1] - tu[c]), 2 * sig.dt)
        omega = math.pi / half_period
        v_thr = velocity_threshold(sig, offset, omega, hold_speed)
        s, c = hold_around(sig, k0, k1, floor_index, v_thr)
    # Held means slow AND in place: no more than 5% of the offset (plus noise) away
    # from where it is let go (a slow hand movement is slow but not in place).
    away = np.nonzero(np.abs(ys[s:c + 1] - ys[c]) > _in_place(sig, offset))[0]
    if away.size:
        s = s + int(away[-1]) + 1
    # From the end of the hold, the first half swing lasts about a half period.  Measured from
    # one half swing alone, the half period has no rhythm check but this one, and must agree
    # more closely, from a swing that is no wiggle: a hand's move into a hold whose tremor
    # wiggles once (3-5 mrad at about 2 Hz after a 0.07-0.08 rad move: 5.3-5.5% of the move), or
    # one swing cut by the end of the record, gave a first half swing of 1.48-2.0 such half
    # periods; the free releases of the campaign and the real logs give 0.76-1.29, their one
    # measured swing 34-54% of the first.
    one_swing = not single and measured < 2
    ok = single or 0.5 <= (tu[k1] - tu[c]) / half_period <= (1.5 if one_swing else 2.0)
    if one_swing:
        ok = ok and abs(sw.vals[2] - sw.vals[1]) >= 0.2 * abs(sw.vals[1] - sw.vals[0])
    held_long = long_enough(tu[c] - tu[s], v_thr, offset, omega, min_hold_s)
    # A record that starts at rest away from rest (a simulation started at the
    # release state, or a log started during the hold) begins with its release.
    starts_held = s == 0 and abs(sig.vs[0]) <= v_thr
    if ok and not (held_long or starts_held) and sw.j == 0 and starts_released(sig, k0, k1, offset, omega):
        s, starts_held = 0, True     # so does a log trimmed at (or just after) the let-go
    ok = ok and (held_long or starts_held)
    if not ok:
        return None
    return _Hold(s=s, c=c, v_thr=v_thr, half_period=half_period, omega=omega, held_long=held_long)


def _end_of_response(sig: PreparedSignal, ext: np.ndarray, sw: _Swings, rest: float, half_period: float) -> float:
    """End of the free response: half a period after the last turning point, but not
    after the signal leaves rest again for the next hand action."""
    tu, ys, h = sig.tu, sig.ys, sig.hysteresis
    last = sw.last
    k_last = ext[last]
    vals_a = np.asarray(sw.vals)
    t_end = tu[k_last] + half_period
    if last + 1 < len(ext):
        k_next = ext[last + 1]
        tail = ys[k_last:k_next + 1]
        near = np.nonzero(np.abs(tail - rest) <= max(2 * h, 0.25 * abs(vals_a[-1] - rest)))[0]
        if near.size:
            t_end = min(t_end, float(tu[k_last + int(near[-1])]))
        t_end = max(t_end, float(tu[k_last]))
    return min(t_end, float(sig.tk[-1]))


def _release_instant(sig: PreparedSignal, k1: int, hold: _Hold, rest: float, offset: float) -> tuple[float, float]:
    """Refine the release instant on the raw samples: hinge between a (slowly drifting)
    hold and the constant-acceleration onset of free motion.  Returns (t_release, y_release);
    a record that starts held (no hold long enough to fit) is released at its first sample."""
    tu, ys = sig.tu, sig.ys
    s, c, v_thr, omega = hold.s, hold.c, hold.v_thr, hold.omega
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
    if hold.held_long and hi - lo > 0.01:
        t_r, coef = hinge_fit(sig.tk[sel], sig.yk[sel], lo, hi, (2,), pre_slope=True)
        if not (tu[s] - 0.1 <= t_r <= t_b):
            t_r = t_c
        y_rel = float(coef[0]) if coef is not None else float(Yc)
    else:
        t_r, y_rel = float(sig.tk[0]), float(sig.yk[0])
    return t_r, y_rel


def _without_tremor(releases: list[Release], min_relative_offset: float) -> list[Release]:
    """A hand that holds the body never holds it perfectly still: its tremor makes small
    "releases" of its own (the shell log has several of a few mrad while held at -0.4 rad).
    Keep only releases whose offset is a sizeable fraction of the largest one."""
    if releases:
        scale = max(abs(r.y_release - r.y_rest) for r in releases)
        releases = [r for r in releases if abs(r.y_release - r.y_rest) >= min_relative_offset * scale]
    return releases
