"""What the diagnosis fits: the free responses of a recording, one window per release.

A recording holds hand-held phases (move, hold, let go) that no model can simulate, and free
responses after each release that the baseline must explain.  `prepare` finds the releases
(roboball.ingest.releases) and cuts one fit window per release:

* start: at the first turning point of the free swing after the release (see below), or,
  when too few swings follow to spare one, 0.05 s before the release instant found by the
  release finder (the model holds the release value until its own, fitted, release instant);
* end (stands, shell): the free response ends when a hand takes the body again or the record
  ends.  A body that has come to rest stays where it stopped: then the window runs on while
  the signal stays within a few noise levels of that rest (at most 3 s past the release
  finder's end of the response, never past the next hold) and ends 0.15 s before it leaves
  it.  A body still swinging when a hand takes it is cut at its last turning point: the hand
  may have grabbed anywhere in the half swing after it;
* ramp: from the start of motion to `ramp_exit_s` (the paper uses only data before the robot
  leaves the ramp; without the field, to the exit read from the rate's fall onto the floor,
  roboball.ingest.releases.ramp.exit_from_rate, else to the end of the record).  A soft shell
  that is not resting in its contact at the release (dropped, or pushed) bounces on the ground at ~5 Hz, and the drive rate carries that bounce: no effect
  of the vocabulary models it (and no rigid baseline can).  Before the test bed started its
  runs settled in the contact (roboball.sim.scenarios.settle_on_ground) it was 90% of the
  residual of its ramp runs and hid the effects that change the speed's trend.  The diagnosis
  therefore fits the ramp's trend: after the release the measured rate is
  averaged over +-`RAMP_SMOOTH_S` = 0.1 s (a boxcar whose first zero is at 5 Hz; the window
  shrinks symmetrically at the ends, so a linear trend passes unbiased).  Reported RMS values
  of ramp diagnoses refer to that trend.

Why the first turning point.  The let-go is the one part of a hand-made release that no model
can simulate: the hand does not open instantly at rest, it may lower the body for a while
first, accompany it into its swing, or push it off.  On the real steer-stand log the hand
lowered the pendulum slowly for 0.2 s before the first release and the first half swing then
took 0.1 s longer than a free swing from the let-go instant can (the second release's took
less): a model started at the let-go carries that phase error into every later swing, and
the phase error (0.3-0.5 rad of residual) swamps the physics being diagnosed.  The first
turning point after the release is the first state known without the hand: zero velocity at
the extremum, which a parabola through the raw samples around it locates (instant and
value).  The fit starts the model there, at rest, with the instant and value fitted as for a
release.  Only the largest half swing is given up, so the start moves there only when at
least `MIN_TURNS_AFTER` further turning points follow within the window (a body stopped by
strong dry friction after one overshoot keeps its release start).

A log trimmed at (or a few samples after) the let-go has its release at its first sample (the
release finder's), and its window is cut like any other: a trimmed log of the real shell rocking
gets the very window of the whole log.  When the window starts at that release, the fitted release
instant (up to the model's ts_bound earlier) stands for the few samples the body had already moved.

The noise level (sensor noise and quantisation) comes from the release finder's estimate.
Undamped records (the shell baseline has no dissipation at all) have holds but no decaying
oscillation, which roboball.ingest.releases does not accept; roboball.diagnose.handholds then takes the ends of
the holds as releases.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from scipy.ndimage import maximum_filter1d, minimum_filter1d

from roboball.diagnose.handholds import hold_releases
from roboball.errors import RoboballError
from roboball.ingest.recording import Recording, normalise
from roboball.ingest.releases.find import require_releases
from roboball.ingest.releases.record import Release
from roboball.ingest.releases.signal import prepare_signal, zigzag
from roboball.kinds import NOT_YET, not_yet_message

PRE_S = 0.05
RAMP_SMOOTH_S = 0.1
STILL_KEEP_S = 3.0
MIN_TURNS_AFTER = 3     # turning points that must follow the first one for the window to start there


@dataclass
class Window:
    """One release's fit window: sample times t (recording time base), values y, the nominal
    release instant t0 and the release value guess q0."""

    index: int
    t0: float
    t: np.ndarray
    y: np.ndarray
    q0: float
    release: Release
    end_reason: str = ""
    start: str = "release"          # "release" (the hand lets go) or "turning point" (first one after it)
    source: Recording | None = None  # the recording the window was cut from (pooled diagnoses)
    smooth_s: float = 0.0           # half-width of the average that made y a trend (0: y is raw)

    def observe(self, y: np.ndarray) -> np.ndarray:
        """What the fit compares with `y`: a model's prediction at the window's samples (shape
        (..., n)) seen through the same operator that made `y` from the recording.  For a ramp
        window `y` is the drive rate averaged over +-smooth_s after the release, and so is the
        prediction: a centred average of a curved trend is biased (by f'' h^2 / 6: the rising,
        flattening speed of a descent reads low just after the release), and comparing an
        averaged recording with an unaveraged model would fit that bias as physics."""
        if not self.smooth_s:
            return np.asarray(y, dtype=float)
        return apply_boxcar(self._boxcar(), y)

    def averaged_counts(self) -> np.ndarray:
        """How many recorded samples each value of `y` averages (1 where y is raw)."""
        m = np.ones(self.n)
        bounds = self._boxcar() if self.smooth_s else None
        if bounds is not None:
            idx, lo, hi = bounds
            m[idx] = hi - lo
        return m

    def _boxcar(self):
        """The averaging windows that made `y` (boxcar_bounds), computed once per window."""
        if "_bounds" not in self.__dict__:
            self._bounds = boxcar_bounds(self.t, self.t0, self.smooth_s)
        return self._bounds

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t0)

    @property
    def n(self) -> int:
        return len(self.t)


@dataclass
class Prepared:
    """A recording ready for diagnosis."""

    recording: Recording
    kind: str
    signal: str
    unit: str
    windows: list
    noise: float
    quantum: float
    notes: list = field(default_factory=list)
    sources: list = field(default_factory=list)   # every pooled recording (the first is `recording`)

    @property
    def n(self) -> int:
        return sum(w.n for w in self.windows)

    @property
    def unit_key(self) -> str:
        """The signal's unit as it stands in a key or column name ("rad", "rad_s")."""
        return self.unit.replace("/", "_")

    @property
    def fit_noise(self) -> float:
        """Noise level of the signal the fit compares with (same unit as `noise`): the sensor's
        for raw windows; for averaged windows (a ramp's trend) the sensor noise of an average,
        sigma sqrt(mean 1/m) over the samples, m of them averaged into each."""
        inv = [w.averaged_counts() for w in self.windows]
        inv = np.concatenate([1.0 / m for m in inv]) if inv else np.ones(1)
        return float(self.noise * math.sqrt(np.mean(inv)))

    @property
    def label(self) -> str:
        if len(self.sources) > 1:
            return " + ".join(r.label for r in self.sources)
        return self.recording.label

    def source_of(self, w: Window) -> Recording:
        return w.source if w.source is not None else self.recording


def _end_of_free_response(t, y, rel: Release, t_stop: float, noise: float, q: float) -> tuple[float, str]:
    """End of the free response after release `rel` (see the module docstring)."""
    sel = (t >= rel.t_release_s) & (t <= t_stop)
    if sel.sum() < 20:
        return float(min(rel.t_end_s, t_stop)), "release finder"
    sig = prepare_signal(t[sel], y[sel])
    tu, ys = sig.tu, sig.ys
    amp = abs(rel.y_release - rel.y_rest)
    ext = zigzag(ys, max(sig.hysteresis, 0.02 * amp))
    half = rel.half_period_s if np.isfinite(rel.half_period_s) else 0.5
    ext = ext[(tu[ext] > rel.t_release_s + 0.05) & (tu[ext] <= rel.t_end_s)]
    if t_stop < t[-1]:
        # A turning point where the next hold begins is the end of the hand's move into it,
        # not a free swing's: the hand grabbed the body before it.
        ext = ext[tu[ext] < t_stop - 0.25 * half]
    if len(ext) == 0:
        return float(min(rel.t_end_s, t_stop)), "release finder"
    k_last = int(ext[-1])
    k_prev = int(ext[-3]) if len(ext) >= 3 else int(np.searchsorted(tu, rel.t_release_s))
    tol = 3.0 * sig.sigma + 2.0 * sig.q
    lo, hi = float(ys[k_prev:k_last + 1].min()) - tol, float(ys[k_prev:k_last + 1].max()) + tol
    after = ys[k_last:]
    out = np.nonzero((after < lo) | (after > hi))[0]
    t_last = float(tu[k_last])
    if out.size and tu[k_last + out[0]] <= t_last + 1.2 * half:
        return t_last, "hand took over mid-swing"
    # Still? then a tighter band around the rest level.
    still_tol = max(6.0 * sig.sigma + 2.0 * sig.q, 0.01 * amp)
    n_win = max(int(round(0.5 / sig.dt)), 3)
    seg = ys[k_last:]
    if len(seg) > n_win:
        # Rolling range over n_win samples starting at each index.
        origin = -(n_win // 2)
        rng = (maximum_filter1d(seg, n_win, origin=origin) - minimum_filter1d(seg, n_win, origin=origin))[: len(seg) - n_win]
        still = np.nonzero(rng <= still_tol)[0]
        if still.size:
            k = k_last + int(still[0])
            level = float(np.median(ys[k:k + n_win]))
            swing = abs(float(ys[k_last]) - rel.y_rest)
            if abs(level - float(ys[k_last])) > 0.5 * swing and abs(level - rel.y_rest) > 0.5 * swing:
                # Still, but neither where the last swing turned (a dry-friction stop) nor near
                # rest (a damped settle): far across rest, where a hand carried and holds it.
                return t_last, "hand took over after the last turning point"
            dev = np.nonzero(np.abs(ys[k:] - level) > still_tol)[0]
            if dev.size:
                end, reason = float(tu[k + dev[0]]) - 0.15, "hand moved the body at rest"
            else:
                end, reason = float(tu[-1]), "at rest to the end of the record"
            end = min(end, rel.t_end_s + STILL_KEEP_S, t_stop)
            return max(end, t_last), reason
    if out.size or t_stop < t[-1]:
        # Still swinging when a hand took over: keep the free response up to its last turning
        # point (the hand may have grabbed anywhere in the half swing after it).
        return t_last, "hand took over after the last turning point"
    return float(min(tu[-1], t_stop)), "end of record"


def _first_turning_point(t, y, rel: Release, t_end: float) -> tuple[float, float] | None:
    """Instant and value of the first turning point of the free swing after release `rel`
    (see the module docstring), or None when fewer than MIN_TURNS_AFTER turning points follow
    it before `t_end`.

    The turning points are those of the smoothed signal with the hysteresis of
    `_end_of_free_response`; the first is refined on the raw samples by the vertex of a
    least-squares parabola through the samples within a fifth of a half period of it
    (the raw maximum of a jittery, quantised log is off by a sample or two)."""
    sel = (t >= rel.t_release_s) & (t <= t_end)
    if sel.sum() < 20:
        return None
    try:
        sig = prepare_signal(t[sel], y[sel])
    except ValueError:
        return None
    tu, ys = sig.tu, sig.ys
    amp = abs(rel.y_release - rel.y_rest)
    ext = zigzag(ys, max(sig.hysteresis, 0.02 * amp))
    ext = ext[tu[ext] > rel.t_release_s + 0.05]
    if len(ext) < 1 + MIN_TURNS_AFTER:
        return None
    k = int(ext[0])
    t_e, y_e = float(tu[k]), float(ys[k])
    # The first turning point lies on the other side of rest from the release.
    if (y_e - rel.y_rest) * (rel.y_release - rel.y_rest) >= 0:
        return None
    half = rel.half_period_s if np.isfinite(rel.half_period_s) else float(tu[int(ext[1])] - t_e)
    near = np.abs(t - t_e) <= 0.2 * half
    if near.sum() >= 5:
        tc = t[near] - t_e
        a, b, c = np.polyfit(tc, y[near], 2)
        if a * (y_e - rel.y_rest) < 0:          # curved towards rest, as a turning point is
            tv = -b / (2.0 * a)
            if abs(tv) <= 0.2 * half:
                return t_e + float(tv), float(c - b * b / (4.0 * a))
    return t_e, y_e


def boxcar_bounds(t: np.ndarray, t0: float, half_width: float):
    """The averaging windows of `smooth_after`: the indices `idx` of the samples at t >= t0 and,
    for each, the half-open range [lo, hi) of those samples (indices into t[idx]) it averages.
    None when fewer than three samples follow t0 (nothing is averaged)."""
    idx = np.nonzero(t >= t0)[0]
    if idx.size < 3:
        return None
    ta = t[idx]
    h = np.minimum(half_width, np.minimum(ta - ta[0], ta[-1] - ta))
    lo = np.searchsorted(ta, ta - h - 1e-12, side="left")
    hi = np.searchsorted(ta, ta + h + 1e-12, side="right")
    return idx, lo, hi


def apply_boxcar(bounds, y: np.ndarray) -> np.ndarray:
    """Apply the averaging windows `bounds` (boxcar_bounds) along the last axis of `y` (one
    signal, or a batch of them, shape (..., n)); samples before t0 are kept as they are."""
    out = np.array(y, dtype=float, copy=True)
    if bounds is None:
        return out
    idx, lo, hi = bounds
    ya = out[..., idx]
    c = np.concatenate([np.zeros(ya.shape[:-1] + (1,)), np.cumsum(ya, axis=-1)], axis=-1)
    out[..., idx] = (c[..., hi] - c[..., lo]) / (hi - lo)
    return out


def smooth_after(t: np.ndarray, y: np.ndarray, t0: float, half_width: float) -> np.ndarray:
    """Centred moving average of the samples at t >= t0 over +-half_width seconds (irregular
    sampling allowed); near either end the window shrinks to stay symmetric (so a linear
    trend is reproduced exactly).  Samples before t0 are returned as they are."""
    return apply_boxcar(boxcar_bounds(np.asarray(t, float), t0, half_width), y)


def _ramp_end(rec: Recording, rel: Release, t_last: float, notes: list) -> tuple[float, str]:
    """A ramp run's window end and why: the sidecar's ramp_exit_s, else the exit the release
    finder read from the rate's fall onto the floor, else the end of the record."""
    t_end = rel.t_end_s
    if rec.ramp_exit_s is not None:
        return t_end, "ramp exit"
    if t_end < t_last:
        notes.append(f"the recording gives no ramp_exit_s: the robot left the ramp at {t_end:.3f} s, where the "
                     "rate drops onto the floor (roboball.ingest.releases.ramp.exit_from_rate)")
        return t_end, "ramp exit read from the rate (no ramp_exit_s)"
    notes.append("the recording gives no ramp_exit_s and its rate shows no fall onto the floor: fitted to the end "
                 "of the record")
    return t_end, "end of record (no ramp_exit_s)"


def prepare(rec: Recording) -> Prepared:
    """Fit windows of every release in `rec` (normalised first).  A kind the diagnosis has no
    baseline for yet (roboball.kinds.NOT_YET) is a one-line RoboballError naming the file."""
    if rec.kind in NOT_YET["reduced-model diagnosis"]:
        raise RoboballError(f"{rec.label}: {not_yet_message(rec.kind, 'reduced-model diagnosis')} "
                            "(roboball.diagnose.diagnose runs it in Drake)")
    rec = normalise(rec)
    kind = rec.kind
    signal = rec.main_signal()
    t, y = rec.time, rec.signal(signal)
    notes = []
    try:
        releases = require_releases(rec, signal)
    except RoboballError:
        releases = hold_releases(t, y, kind) if kind != "ramp" else []
        if not releases:
            raise
        notes.append("the release finder found no release followed by a decaying oscillation; releases taken "
                     "as the ends of hand holds (the body does not lose amplitude)")
    unit = "rad/s" if signal.endswith("_rad_s") else "rad"
    windows = []
    noise = float(np.nanmedian([r.noise for r in releases if np.isfinite(r.noise)] or [1e-3]))
    quantum = 0.0
    try:
        quantum = prepare_signal(t, y).q
    except ValueError:
        pass
    for i, rel in enumerate(releases):
        if kind == "ramp":
            t_end, reason = _ramp_end(rec, rel, float(t[-1]), notes)
        else:
            t_stop = releases[i + 1].held_from_s if i + 1 < len(releases) else float(t[-1])
            t_end, reason = _end_of_free_response(t, y, rel, t_stop, noise, quantum)
        t0, q0, start = float(rel.t_release_s), (float(rel.y_release) if kind != "ramp" else 0.0), "release"
        sel = (t >= t0 - PRE_S) & (t <= t_end)
        if kind != "ramp":
            turn = _first_turning_point(t, y, rel, t_end)
            if turn is not None:
                t0, q0 = turn
                start = "turning point"
                sel = (t >= t0) & (t <= t_end)
        if sel.sum() < 20:
            notes.append(f"release {i + 1} at {rel.t_release_s:.2f} s: too few samples, skipped")
            continue
        w = Window(index=len(windows), t0=t0, t=t[sel], y=y[sel], q0=q0, release=rel, end_reason=reason,
                   start=start, source=rec, smooth_s=RAMP_SMOOTH_S if kind == "ramp" else 0.0)
        if w.smooth_s:
            # the trend is the recording seen through the window's own operator, the one every
            # prediction compared with it passes through (Window.observe)
            w.y = w.observe(w.y)
            notes.append(f"release {i + 1}: the drive rate after the release is averaged over +-{w.smooth_s:g} s "
                         "(the diagnosis fits the descent's trend, not a contact bounce)")
        windows.append(w)
    if not windows:
        raise RoboballError(f"{rec.label}: {signal}: no release long enough to diagnose (need 20 samples after a release)")
    return Prepared(recording=rec, kind=kind, signal=signal, unit=unit, windows=windows, noise=noise,
                    quantum=quantum, notes=notes, sources=[rec])


POOL_PRESSURE_TOL_KPA = 0.05


def same_pressure(pa: float | None, pb: float | None) -> bool:
    """Whether two recordings' pressures (kPa, None: not logged) are one experiment's: both
    unlogged, or both logged within POOL_PRESSURE_TOL_KPA."""
    return (pa is None) == (pb is None) and (pa is None or abs(pa - pb) <= POOL_PRESSURE_TOL_KPA)


def pool(preps: list) -> Prepared:
    """Several recordings of one experiment diagnosed together: every release of every recording
    is a release of the pooled fit (its own release state), so held-out validation leaves one
    release out, a whole recording's at a time.  A ramp run holds a single descent, and the
    only held-out test inside it is extrapolation across time blocks, where effects that are
    nearly collinear over one descent (a rolling damping and a rolling resistance) trade off
    and extrapolate badly; repeated runs give the held-out test the same speed range.  The
    recordings must share kind, main signal and pressure; ramp runs may differ in the ramp's
    angle (each is simulated on its own, RampModel.window_values: runs on a steeper ramp reach
    the speeds that tell a breakaway from a loss, roboball.design.ramp).  Noise level: the
    median of the recordings'."""
    preps = list(preps)
    if len(preps) == 1:
        return preps[0]
    first = preps[0]
    for p in preps[1:]:
        where = f"{p.recording.label}: cannot be pooled with {first.recording.label}"
        if p.kind != first.kind or p.signal != first.signal:
            raise RoboballError(f"{where}: kind {p.kind} ({p.signal}), not {first.kind} ({first.signal})")
        pa, pb = p.recording.pressure_kpa, first.recording.pressure_kpa
        if not same_pressure(pa, pb):
            raise RoboballError(f"{where}: pressure {pa} kPa, not {pb} kPa")
    windows, notes = [], []
    angles = sorted({p.recording.ramp_angle_deg for p in preps if p.recording.ramp_angle_deg is not None})
    if first.kind == "ramp" and len(angles) > 1:
        notes.append(f"runs on ramps of {', '.join(f'{a:g}' for a in angles)} deg: each simulated on its own ramp")
    for p in preps:
        for w in p.windows:
            windows.append(replace(w, index=len(windows), source=p.recording))
        notes += [f"{p.recording.label}: {n}" for n in dict.fromkeys(p.notes)]
    return Prepared(recording=first.recording, kind=first.kind, signal=first.signal, unit=first.unit,
                    windows=windows, noise=float(np.median([p.noise for p in preps])),
                    quantum=max(p.quantum for p in preps), notes=notes,
                    sources=[p.recording for p in preps])


def read(path, kind: str | None = None, pressure_kpa: float | None = None) -> Recording:
    """Read a recording (or one of the authors' native logs) with the shared validation."""
    from roboball.ingest.importers import read_any
    path = Path(path)
    if not path.exists():
        raise RoboballError(f"{path}: file not found")
    return read_any(path, kind=kind, pressure_kpa=pressure_kpa)
