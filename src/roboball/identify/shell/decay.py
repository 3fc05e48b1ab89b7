"""Damping ratio and frequency of each free response.

For every release the free response is fitted with the damped oscillator's solution

    y(t) = y_rest + A exp(-zeta omega_n tau) cos(omega_d tau + phase),   tau = t - t_release,
    omega_n = omega_d / sqrt(1 - zeta^2),

by nonlinear least squares directly on the irregularly sampled points (no resampling, so
gaps and jittered stamps cost nothing; duplicate stamps are dropped).  Why a fit rather
than the classic log decrement alone: it uses every sample, not a handful of peaks, so it
is far less sensitive to noise and 1-mrad quantisation, and it gives standard errors.

* Initial guesses come from the release detector (rest, amplitude, half period) refined by
  the zero crossings of the signal about rest; an FFT peak is the fallback.
* Fit window: from the release (plus a small delay that skips the hand's letting go) until
  the envelope has decayed to `stop_noise` (3) noise levels, or the free response ends
  (next hand action / motion stops); configurable.  Decided from the first-pass fit and
  fitted again.
* Standard errors: from the Jacobian at the solution, cov = s^2 (J^T J)^-1 with the residual
  variance s^2, inflated by sqrt((1 + rho1) / (1 - rho1)) for residuals with lag-1
  autocorrelation rho1 > 0 (model error such as dry friction makes residuals smooth and
  the independent-noise errors would be far too small).  omega_n's error follows by the
  delta method.
* Cross-checks: the logarithmic decrement from successive peak-to-peak swings (peaks
  refined by a local quadratic fit to the raw samples), over the whole window and over the
  first and the last cycles separately (zeta_early / zeta_late).  Viscous damping gives
  equal values; dry (Coulomb) friction makes zeta_late > zeta_early, because its amplitude
  falls linearly, not geometrically.

The model and its fit live in ``damped_sine``, the log decrement in ``log_decrement``.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from roboball.errors import RoboballError
from roboball.identify.shell.damped_sine import DampedSineFit, fit_damped_sine
from roboball.identify.shell.log_decrement import log_decrement_zeta, refine_extrema
from roboball.ingest.releases.record import Release
from roboball.ingest.releases.signal import prepare_signal, zigzag

if TYPE_CHECKING:  # pragma: no cover
    from roboball.ingest.recording import Recording

__all__ = ["DECAY_COLUMNS", "DecayResult", "extract_decay", "decay_table"]

DECAY_COLUMNS = [
    "release", "t_release_s", "t_fit_start_s", "t_fit_end_s", "kind", "pressure_kpa",
    "zeta", "zeta_se", "omega_d_rad_s", "omega_d_se_rad_s", "omega_n_rad_s", "omega_n_se_rad_s",
    "period_s", "period_early_s", "period_late_s", "amplitude0_rad", "rest_rad", "zeta_logdec", "zeta_early", "zeta_late",
    "n_cycles", "n_points", "rmse_rad", "residual_lag1", "se_inflation", "source",
]


@dataclass
class DecayResult:
    """Damping and frequency of one free response (see the module docstring).

    zeta (1), omega_d / omega_n (rad/s) with standard errors (*_se); amplitude0: envelope at
    the release instant; rest: fitted rest level; zeta_logdec / zeta_early / zeta_late:
    log-decrement cross-checks (NaN when there are too few turning points); extrema: the
    refined turning points (t, y) and periods_s the cycle lengths between them (a period
    that changes with amplitude points at nonlinear stiffness); n_cycles:
    cycles inside the fit window; rmse: residual RMS (signal unit); residual_lag1 and
    se_inflation: residual autocorrelation and the factor applied to the errors."""

    t_release_s: float
    t_fit_start_s: float
    t_fit_end_s: float
    zeta: float
    zeta_se: float
    omega_d: float
    omega_d_se: float
    omega_n: float
    omega_n_se: float
    amplitude0: float
    rest: float
    rest_se: float
    phase: float
    zeta_logdec: float
    zeta_early: float
    zeta_late: float
    n_cycles: float
    n_points: int
    rmse: float
    residual_lag1: float
    se_inflation: float
    extrema: list = field(default_factory=list)
    periods_s: list = field(default_factory=list)
    fit: DampedSineFit | None = field(default=None, repr=False)

    @property
    def period_s(self) -> float:
        """Period of the fitted damped oscillation, 2 pi / omega_d."""
        return 2 * math.pi / self.omega_d

    @property
    def period_early_s(self) -> float:
        """First full cycle between turning points of the data (NaN if fewer than 3)."""
        return float(self.periods_s[0]) if self.periods_s else float("nan")

    @property
    def period_late_s(self) -> float:
        """Last full cycle between turning points of the data (NaN if fewer than 4)."""
        return float(self.periods_s[-1]) if len(self.periods_s) >= 2 else float("nan")

    def as_dict(self) -> dict:
        d = asdict(self)
        d.pop("fit", None)
        return d

    def model(self, t) -> np.ndarray:
        """The fitted free response evaluated at times t."""
        return self.fit(t)


def _initial_guess(t: np.ndarray, y: np.ndarray, release: Release, noise: float) -> tuple[float, float, float, float]:
    """(rest, offset, zeta, omega_d) from the release and the zero crossings about rest."""
    rest = release.y_rest if np.isfinite(release.y_rest) else float(np.median(y[-max(len(y) // 5, 1):]))
    offset = release.y_release - rest
    # Zero crossings of y - rest with hysteresis: alternate sides beyond +-2 noise.
    d = y - rest
    band = max(2 * noise, 0.02 * abs(offset))
    side = 0
    crossings = []
    last_t = None
    for ti, di in zip(t, d):
        s = 1 if di > band else (-1 if di < -band else 0)
        if s == 0:
            continue
        if side != 0 and s != side:
            crossings.append(0.5 * (ti + last_t))
        side = s
        last_t = ti
    omega_d = float("nan")
    if len(crossings) >= 3:
        half = np.diff(crossings)
        omega_d = math.pi / float(np.median(half))
    elif np.isfinite(release.half_period_s) and release.half_period_s > 0:
        omega_d = math.pi / release.half_period_s
    if not np.isfinite(omega_d):
        # FFT of the uniformly resampled window.
        dt = float(np.median(np.diff(t)))
        tu = np.arange(t[0], t[-1], dt)
        yu = np.interp(tu, t, y) - rest
        spec = np.abs(np.fft.rfft(yu * np.hanning(len(yu))))
        freqs = np.fft.rfftfreq(len(yu), dt)
        k = int(np.argmax(spec[1:])) + 1
        omega_d = 2 * math.pi * freqs[k]
    # zeta from the turning points of the smoothed data (peak-to-peak log decrement).
    zeta = 0.05
    try:
        sig = prepare_signal(t, y)
        ext = zigzag(sig.ys, sig.hysteresis)
        vals = sig.ys[ext]
        if len(vals) >= 3:
            z = log_decrement_zeta(vals[: min(len(vals), 8)])
            if np.isfinite(z) and 0 < z < 0.9:
                zeta = z
    except ValueError:
        pass
    return rest, offset, zeta, omega_d


def extract_decay(
    t,
    y,
    release: Release,
    *,
    start_delay_s: float | None = None,
    stop_noise: float = 3.0,
    t_end_s: float | None = None,
    max_cycles: float | None = None,
    noise: float | None = None,
) -> DecayResult:
    """Fit the free response after `release` (see the module docstring).

    start_delay_s: skip this long after the release instant (default: 2% of the period,
    at most 0.05 s, so the hand's letting go does not bias the fit); stop_noise: the window
    ends when the fitted envelope falls below this many noise levels; t_end_s /
    max_cycles: optional further limits of the window; noise: the signal's noise level
    (default: the release detector's estimate).  Raises RoboballError if the window holds
    too little of an oscillation to fit.
    """
    t, y = _distinct_samples(t, y)
    t_rel = float(release.t_release_s)
    t_stop = float(release.t_end_s if t_end_s is None else min(t_end_s, release.t_end_s))
    if noise is None:
        noise = release.noise if np.isfinite(release.noise) and release.noise > 0 else None
    if noise is None:
        noise = prepare_signal(t, y).sigma
    win = (t >= t_rel) & (t <= t_stop)
    if win.sum() < 12:
        raise RoboballError(
            f"release at {t_rel:.3f} s: only {int(win.sum())} samples between the release and "
            f"the end of its free response ({t_stop:.3f} s); nothing to fit"
        )
    tw, yw = t[win], y[win]
    rest0, offset0, zeta0, wd0 = _initial_guess(tw, yw, release, noise)
    period0 = 2 * math.pi / wd0
    delay = min(0.02 * period0, 0.05) if start_delay_s is None else float(start_delay_s)
    zeta0 = min(max(zeta0, 1e-3), 0.9)
    # Released from rest: y(0) = rest + offset, y'(0) = 0  =>  phase = -asin(zeta).
    phase0 = -math.asin(zeta0)
    amp0 = offset0 / math.cos(phase0)
    window = _Window(t_rel=t_rel, t_stop=t_stop, delay=delay, noise=noise, stop_noise=stop_noise,
                     max_cycles=max_cycles)
    fit, m = _fit_in_window(t, y, window, (rest0, amp0, zeta0, wd0, phase0))
    tf, yf = t[m], y[m]
    return _result(t_rel, tf, fit, _turning_points(tf, yf, fit, noise))


def _distinct_samples(t, y) -> tuple[np.ndarray, np.ndarray]:
    """The finite samples in time order, the first of each duplicate stamp only."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    ok = np.isfinite(t) & np.isfinite(y)
    t, y = t[ok], y[ok]
    order = np.argsort(t, kind="stable")
    t, y = t[order], y[order]
    keep = np.ones(len(t), dtype=bool)
    keep[1:] = np.diff(t) > 0
    return t[keep], y[keep]


@dataclass(frozen=True)
class _Window:
    """Where the fit looks: from `delay` after the release instant `t_rel` to `t_stop`, ending
    earlier where the fitted envelope falls below `stop_noise` noise levels or after
    `max_cycles` cycles."""

    t_rel: float
    t_stop: float
    delay: float
    noise: float
    stop_noise: float
    max_cycles: float | None

    def end(self, amp: float, decay_rate: float, wd: float) -> float:
        """The window's end for a fit of amplitude `amp`, envelope rate `decay_rate` and
        angular frequency `wd`."""
        end = self.t_stop
        if decay_rate > 0 and abs(amp) > self.stop_noise * self.noise:
            end = min(end, self.t_rel + math.log(abs(amp) / (self.stop_noise * self.noise)) / decay_rate)
        if self.max_cycles is not None:
            end = min(end, self.t_rel + self.delay + self.max_cycles * 2 * math.pi / wd)
        return end


def _fit_in_window(t: np.ndarray, y: np.ndarray, window: _Window, p0: tuple) -> tuple[DampedSineFit, np.ndarray]:
    """Fit the damped sine from `p0`, moving the window's end to where the fit's envelope puts
    it until it settles (at most 3 passes), then once more on the final window.  Returns the
    fit and the mask of the samples it used."""
    t_rel, t_stop, delay = window.t_rel, window.t_stop, window.delay
    _, amp0, zeta0, wd0, _ = p0
    decay0 = zeta0 * wd0 / math.sqrt(1 - zeta0 ** 2)
    t_hi = window.end(amp0, decay0, wd0)
    fit = None
    for _ in range(3):
        m = (t >= t_rel + delay) & (t <= t_hi)
        if m.sum() < 12:
            m = (t >= t_rel + delay) & (t <= t_stop)
        fit = fit_damped_sine(t[m], y[m], t_rel, p0)
        new_hi = window.end(fit.value("amplitude"), fit.decay_rate, fit.omega_d)
        p0 = tuple(fit.params)
        if abs(new_hi - t_hi) < 0.25 * 2 * math.pi / fit.omega_d:
            t_hi = new_hi
            break
        t_hi = new_hi
    m = (t >= t_rel + delay) & (t <= t_hi)
    if m.sum() >= 12 and m.sum() != fit.n:
        fit = fit_damped_sine(t[m], y[m], t_rel, p0)
    return fit, m


def _turning_points(tf: np.ndarray, yf: np.ndarray, fit: DampedSineFit, noise: float) -> list[tuple[float, float]]:
    """The turning points (t, y) of the data inside the fit window: found on the smoothed
    signal (zig-zag with a noise hysteresis), refined by a local parabola through the raw
    samples; those at the window's edges, or within 10 noise levels of rest, are dropped."""
    wd = fit.omega_d
    rest_fit = fit.value("rest")
    ext: list[tuple[float, float]] = []
    try:
        sig = prepare_signal(tf, yf)
        idx = zigzag(sig.ys, max(sig.hysteresis, 5 * noise))
        guesses = sig.tu[idx]
        for g_i, tg in enumerate(guesses):
            left = guesses[g_i - 1] if g_i > 0 else -np.inf
            right = guesses[g_i + 1] if g_i + 1 < len(guesses) else np.inf
            hw = min(0.125 * 2 * math.pi / wd, 0.4 * (tg - left), 0.4 * (right - tg))
            ext += refine_extrema(tf, yf, [tg], hw)
    except ValueError:
        pass
    # Turning points at the window's edges are cut off, not turning points of the data.
    edge = 0.1 * 2 * math.pi / wd
    return [(te, ye) for te, ye in ext
            if abs(ye - rest_fit) > 10 * noise and tf[0] + edge <= te <= tf[-1] - edge]


def _result(t_rel: float, tf: np.ndarray, fit: DampedSineFit, ext: list[tuple[float, float]]) -> DecayResult:
    """The DecayResult of `fit` on the window's times `tf`, with the log-decrement
    cross-checks over all turning points `ext` and over the first and the last few."""
    wd, z = fit.omega_d, fit.zeta
    ph = fit.value("phase")
    vals = [ye for _, ye in ext]
    zeta_logdec = log_decrement_zeta(vals)
    n_e = len(vals)
    if n_e >= 4:
        k = min(5, (n_e + 1) // 2 + 1)
        zeta_early = log_decrement_zeta(vals[:k])
        zeta_late = log_decrement_zeta(vals[-k:])
    else:
        zeta_early = zeta_late = float("nan")
    times = np.array([te for te, _ in ext])
    periods = list(times[2:] - times[:-2]) if len(times) >= 3 else []
    amp = fit.value("amplitude")
    return DecayResult(
        t_release_s=t_rel,
        t_fit_start_s=float(tf[0]),
        t_fit_end_s=float(tf[-1]),
        zeta=z,
        zeta_se=fit.se("zeta"),
        omega_d=wd,
        omega_d_se=fit.se("omega_d"),
        omega_n=fit.omega_n,
        omega_n_se=fit.omega_n_se,
        amplitude0=float(abs(amp)),
        rest=fit.value("rest"),
        rest_se=fit.se("rest"),
        phase=ph,
        zeta_logdec=zeta_logdec,
        zeta_early=zeta_early,
        zeta_late=zeta_late,
        n_cycles=float((tf[-1] - tf[0]) * wd / (2 * math.pi)),
        n_points=int(fit.n),
        rmse=fit.rmse,
        residual_lag1=fit.rho1,
        se_inflation=fit.inflation,
        extrema=ext,
        periods_s=[float(x) for x in periods],
        fit=fit,
    )


def decay_table(recording: "Recording", releases: list[Release] | None = None, signal: str | None = None,
                **kwargs):
    """One row per release of `recording`: damping ratio, frequencies and cross-checks
    (columns :data:`DECAY_COLUMNS`).  Releases are found if not given; a recording without
    releases raises a one-line RoboballError naming the file."""
    import pandas as pd

    from roboball.ingest.releases.find import require_releases

    if recording.kind == "ramp":
        raise RoboballError(
            f"{recording.label}: kind: decay extraction needs a free oscillation "
            "(steer_stand, drive_stand or shell_rock), not a ramp run"
        )
    name = signal or recording.main_signal()
    if releases is None:
        releases = require_releases(recording, name)
    t = recording.time
    y = recording.signal(name)
    rows = []
    for i, rel in enumerate(releases, start=1):
        try:
            res = extract_decay(t, y, rel, **kwargs)
        except RoboballError as exc:
            raise RoboballError(f"{recording.label}: {name}: {exc}")
        rows.append({
            "release": i,
            "t_release_s": res.t_release_s,
            "t_fit_start_s": res.t_fit_start_s,
            "t_fit_end_s": res.t_fit_end_s,
            "kind": recording.kind,
            "pressure_kpa": recording.pressure_kpa if recording.pressure_kpa is not None else float("nan"),
            "zeta": res.zeta,
            "zeta_se": res.zeta_se,
            "omega_d_rad_s": res.omega_d,
            "omega_d_se_rad_s": res.omega_d_se,
            "omega_n_rad_s": res.omega_n,
            "omega_n_se_rad_s": res.omega_n_se,
            "period_s": res.period_s,
            "period_early_s": res.period_early_s,
            "period_late_s": res.period_late_s,
            "amplitude0_rad": res.amplitude0,
            "rest_rad": res.rest,
            "zeta_logdec": res.zeta_logdec,
            "zeta_early": res.zeta_early,
            "zeta_late": res.zeta_late,
            "n_cycles": res.n_cycles,
            "n_points": res.n_points,
            "rmse_rad": res.rmse,
            "residual_lag1": res.residual_lag1,
            "se_inflation": res.se_inflation,
            "source": recording.path.name if recording.path is not None else str(recording.meta.get("name", "")),
        })
    return pd.DataFrame(rows, columns=DECAY_COLUMNS)
