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
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Sequence

import numpy as np
from scipy.optimize import least_squares

from roboball.errors import RoboballError
from roboball.ingest.releases.record import Release
from roboball.ingest.releases.signal import prepare_signal, zigzag

if TYPE_CHECKING:  # pragma: no cover
    from roboball.ingest.recording import Recording

__all__ = [
    "DampedSineFit",
    "DecayResult",
    "damped_sine",
    "fit_damped_sine",
    "extract_decay",
    "decay_table",
    "log_decrement_zeta",
    "refine_extrema",
    "DECAY_COLUMNS",
]

DECAY_COLUMNS = [
    "release", "t_release_s", "t_fit_start_s", "t_fit_end_s", "kind", "pressure_kpa",
    "zeta", "zeta_se", "omega_d_rad_s", "omega_d_se_rad_s", "omega_n_rad_s", "omega_n_se_rad_s",
    "period_s", "period_early_s", "period_late_s", "amplitude0_rad", "rest_rad", "zeta_logdec", "zeta_early", "zeta_late",
    "n_cycles", "n_points", "rmse_rad", "residual_lag1", "se_inflation", "source",
]


def damped_sine(tau, rest: float, amplitude: float, zeta: float, omega_d: float, phase: float) -> np.ndarray:
    """rest + amplitude exp(-zeta omega_n tau) cos(omega_d tau + phase)."""
    tau = np.asarray(tau, dtype=float)
    decay = zeta * omega_d / math.sqrt(1.0 - zeta * zeta)
    return rest + amplitude * np.exp(-decay * tau) * np.cos(omega_d * tau + phase)


@dataclass
class DampedSineFit:
    """Least-squares fit of :func:`damped_sine`; parameter order
    (rest, amplitude, zeta, omega_d, phase).  `cov` is already inflated for residual
    autocorrelation."""

    t0: float
    params: np.ndarray
    cov: np.ndarray
    rmse: float
    n: int
    rho1: float
    inflation: float
    success: bool
    message: str = ""

    names = ("rest", "amplitude", "zeta", "omega_d", "phase")

    def __call__(self, t) -> np.ndarray:
        return damped_sine(np.asarray(t, dtype=float) - self.t0, *self.params)

    def value(self, name: str) -> float:
        return float(self.params[self.names.index(name)])

    def se(self, name: str) -> float:
        i = self.names.index(name)
        v = self.cov[i, i]
        return float(math.sqrt(v)) if np.isfinite(v) and v >= 0 else float("nan")

    @property
    def zeta(self) -> float:
        return self.value("zeta")

    @property
    def omega_d(self) -> float:
        return self.value("omega_d")

    @property
    def omega_n(self) -> float:
        z = self.zeta
        return self.omega_d / math.sqrt(1.0 - z * z)

    @property
    def omega_n_se(self) -> float:
        """Delta method: omega_n = omega_d / sqrt(1 - zeta^2)."""
        z, wd = self.zeta, self.omega_d
        g = np.zeros(5)
        g[2] = wd * z / (1.0 - z * z) ** 1.5
        g[3] = 1.0 / math.sqrt(1.0 - z * z)
        v = float(g @ self.cov @ g)
        return math.sqrt(v) if v >= 0 and np.isfinite(v) else float("nan")

    @property
    def decay_rate(self) -> float:
        """zeta omega_n (1/s): the envelope's exponential rate."""
        return self.zeta * self.omega_n

    def envelope(self, t) -> np.ndarray:
        tau = np.asarray(t, dtype=float) - self.t0
        return abs(self.value("amplitude")) * np.exp(-self.decay_rate * tau)


def _residual_lag1(r: np.ndarray) -> float:
    if len(r) < 3:
        return 0.0
    r = r - r.mean()
    den = float(r @ r)
    if den <= 0:
        return 0.0
    return float(r[:-1] @ r[1:]) / den


def fit_damped_sine(t, y, t0: float, p0: Sequence[float], max_zeta: float = 0.95) -> DampedSineFit:
    """Fit rest + A exp(-zeta omega_n (t - t0)) cos(omega_d (t - t0) + phase) to (t, y)
    starting from p0 = (rest, A, zeta, omega_d, phase); analytic Jacobian, trust-region
    least squares with zeta in [0, max_zeta] and omega_d > 0."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    tau = t - t0

    def parts(p):
        rest, amp, zeta, wd, ph = p
        sq = math.sqrt(1.0 - zeta * zeta)
        sig = zeta * wd / sq
        e = np.exp(-sig * tau)
        arg = wd * tau + ph
        c, s = np.cos(arg), np.sin(arg)
        return rest, amp, zeta, wd, sq, sig, e, c, s

    def fun(p):
        rest, amp, _, _, _, _, e, c, _ = parts(p)
        return rest + amp * e * c - y

    def jac(p):
        rest, amp, zeta, wd, sq, sig, e, c, s = parts(p)
        dsig_dz = wd / sq ** 3
        dsig_dw = zeta / sq
        J = np.empty((len(tau), 5))
        J[:, 0] = 1.0
        J[:, 1] = e * c
        J[:, 2] = -amp * e * c * tau * dsig_dz
        J[:, 3] = amp * e * (-tau * dsig_dw * c - tau * s)
        J[:, 4] = -amp * e * s
        return J

    p0 = np.array(p0, dtype=float)
    p0[2] = min(max(p0[2], 1e-4), max_zeta - 1e-3)
    p0[3] = max(p0[3], 1e-3)
    lower = [-np.inf, -np.inf, 0.0, 1e-6, -np.inf]
    upper = [np.inf, np.inf, max_zeta, np.inf, np.inf]
    res = least_squares(fun, p0, jac=jac, bounds=(lower, upper), x_scale="jac", method="trf",
                        xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=2000)
    p = res.x.copy()
    # Canonical form: positive amplitude, phase in (-pi, pi].
    if p[1] < 0:
        p[1] = -p[1]
        p[4] += math.pi
    p[4] = math.atan2(math.sin(p[4]), math.cos(p[4]))
    r = fun(p)
    n = len(r)
    dof = max(n - 5, 1)
    s2 = float(r @ r) / dof
    J = jac(p)
    try:
        cov = np.linalg.inv(J.T @ J) * s2
    except np.linalg.LinAlgError:
        cov = np.full((5, 5), np.nan)
    rho = _residual_lag1(r)
    rho_c = min(max(rho, 0.0), 0.99)
    infl = math.sqrt((1.0 + rho_c) / (1.0 - rho_c))
    cov = cov * infl ** 2
    return DampedSineFit(t0=float(t0), params=p, cov=cov, rmse=float(math.sqrt(float(r @ r) / n)),
                         n=n, rho1=rho, inflation=infl, success=bool(res.success), message=str(res.message))


# --------------------------------------------------------------------------------------
# Peaks and log decrement
# --------------------------------------------------------------------------------------
def refine_extrema(t: np.ndarray, y: np.ndarray, t_guess: Sequence[float], half_width: float) -> list[tuple[float, float]]:
    """Refine turning points: fit a parabola to the raw samples within +-half_width of
    each guessed time and return its vertex (t, y); guesses without a proper vertex in the
    window are skipped."""
    out = []
    for tg in t_guess:
        m = (t >= tg - half_width) & (t <= tg + half_width)
        if m.sum() < 5:
            continue
        tt = t[m] - tg
        a, b, c = np.polyfit(tt, y[m], 2)
        if a == 0:
            continue
        tv = -b / (2 * a)
        if abs(tv) > half_width:
            continue
        out.append((float(tg + tv), float(c - b * b / (4 * a))))
    return out


def log_decrement_zeta(extrema_values: Sequence[float]) -> float:
    """Damping ratio from successive turning points by the logarithmic decrement.

    Uses peak-to-peak swings h_k = |E_{k+1} - E_k| (independent of the rest level); for a
    viscous oscillator they shrink by exp(-delta/2) per half cycle.  delta is the slope of a
    least-squares line through ln h_k, and zeta = delta / sqrt(4 pi^2 + delta^2).
    Needs at least three turning points; returns NaN otherwise."""
    e = np.asarray(extrema_values, dtype=float)
    if len(e) < 3:
        return float("nan")
    h = np.abs(np.diff(e))
    if np.any(h <= 0):
        return float("nan")
    k = np.arange(len(h))
    slope = np.polyfit(k, np.log(h), 1)[0]
    delta = -2.0 * slope
    return float(delta / math.sqrt(4 * math.pi ** 2 + delta ** 2))


# --------------------------------------------------------------------------------------
# One release
# --------------------------------------------------------------------------------------
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
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    ok = np.isfinite(t) & np.isfinite(y)
    t, y = t[ok], y[ok]
    order = np.argsort(t, kind="stable")
    t, y = t[order], y[order]
    keep = np.ones(len(t), dtype=bool)
    keep[1:] = np.diff(t) > 0
    t, y = t[keep], y[keep]

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

    def window_end(amp: float, decay_rate: float, wd: float) -> float:
        end = t_stop
        if decay_rate > 0 and abs(amp) > stop_noise * noise:
            end = min(end, t_rel + math.log(abs(amp) / (stop_noise * noise)) / decay_rate)
        if max_cycles is not None:
            end = min(end, t_rel + delay + max_cycles * 2 * math.pi / wd)
        return end

    p0 = (rest0, amp0, zeta0, wd0, phase0)
    decay0 = zeta0 * wd0 / math.sqrt(1 - zeta0 ** 2)
    t_hi = window_end(amp0, decay0, wd0)
    fit = None
    for _ in range(3):
        m = (t >= t_rel + delay) & (t <= t_hi)
        if m.sum() < 12:
            m = (t >= t_rel + delay) & (t <= t_stop)
        fit = fit_damped_sine(t[m], y[m], t_rel, p0)
        new_hi = window_end(fit.value("amplitude"), fit.decay_rate, fit.omega_d)
        p0 = tuple(fit.params)
        if abs(new_hi - t_hi) < 0.25 * 2 * math.pi / fit.omega_d:
            t_hi = new_hi
            break
        t_hi = new_hi
    m = (t >= t_rel + delay) & (t <= t_hi)
    if m.sum() >= 12 and m.sum() != fit.n:
        fit = fit_damped_sine(t[m], y[m], t_rel, p0)
    tf, yf = t[m], y[m]

    # Log-decrement cross-checks on the turning points of the data inside the window:
    # found on the smoothed signal (zig-zag with a noise hysteresis), refined by a local
    # parabola through the raw samples.
    wd, z = fit.omega_d, fit.zeta
    ph = fit.value("phase")
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
    ext = [(te, ye) for te, ye in ext
           if abs(ye - rest_fit) > 10 * noise and tf[0] + edge <= te <= tf[-1] - edge]
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
