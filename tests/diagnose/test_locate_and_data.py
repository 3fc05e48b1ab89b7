"""The numbers `roboball diagnose` reads off a recording before any model runs: the fit windows
cut from the free responses (diagnose.data) and the regimes and time windows the baseline's
residual is located in (diagnose.locate).

Synthetic signals with known answers (numpy only): a cosine's speed is above 60% of its peak
for 1 - (2/pi) asin(0.6) of the time, a damped oscillator released from rest turns at
multiples of pi/omega_d, and so on."""
import math

import numpy as np
import pandas as pd
import pytest

from roboball.diagnose.data import Prepared, Window, _end_of_free_response, _first_turning_point, pool, prepare
from roboball.diagnose.handholds import hold_releases
from roboball.diagnose.locate import classify, locate
from roboball.ingest.recording import Recording
from roboball.ingest.releases.record import Release
from roboball.testbed.synthetic import free_response, synthetic_release_log

DT = 1.0 / 64.0          # exact in binary: piece edges fall exactly on samples


def _release(t0, t_end, y_release, half, kind="steer_stand", y_rest=0.0):
    return Release(t_release_s=t0, t_end_s=t_end, i_release=-1, i_end=-1, y_release=y_release, y_rest=y_rest,
                   held_from_s=t0 - 1.0, half_period_s=half, noise=1e-4, kind=kind)


def _prepared(t, y, t0, q0, half, kind="steer_stand", noise=1e-4):
    rel = _release(t0, float(t[-1]), q0, half, kind)
    w = Window(index=0, t0=t0, t=t, y=y, q0=q0, release=rel, start="release")
    return Prepared(recording=None, kind=kind, signal="steer_angle_rad", unit="rad", windows=[w], noise=noise,
                    quantum=0.0)


# --------------------------------------------------------------------------------------
# locate: regimes
# --------------------------------------------------------------------------------------
def test_speed_regimes_are_60_and_15_percent_of_the_peak_speed():
    t = np.arange(640) * DT                          # ten periods of a 1 Hz cosine
    lab = classify(_prepared(t, np.cos(2 * np.pi * t), 0.0, 1.0, 0.5))[0]
    # |sin| > 0.6 for 1 - (2/pi) asin(0.6) = 59.0% of the time, |sin| < 0.15 for 9.6%
    assert lab["high_speed"].mean() == pytest.approx(1 - 2 / np.pi * math.asin(0.6), abs=0.015)
    assert lab["low_speed"].mean() == pytest.approx(2 / np.pi * math.asin(0.15), abs=0.015)


def _staircase():
    """A 1 Hz swing whose amplitude steps down every 3 s (1.0, 0.45, 0.25, 0.07, 0.03 of the
    release offset), then rests at 0 for 5 s."""
    levels = [1.0, 0.45, 0.25, 0.07, 0.03]
    t = np.arange(int(20.0 / DT)) * DT
    env = np.zeros_like(t)
    for i, level in enumerate(levels):
        env[(t >= 3 * i) & (t < 3 * i + 3)] = level
    return t, env * np.cos(2 * np.pi * t), levels


def test_amplitude_regimes_follow_the_documented_shares_of_the_release_amplitude():
    t, y, levels = _staircase()
    lab = classify(_prepared(t, y, 0.0, 1.0, 0.5))[0]

    def share(regime, i):           # the middle second of step i (away from the max filter's reach)
        m = (t >= 3 * i + 1) & (t < 3 * i + 2)
        return lab[regime][m].mean()

    # large_amplitude: above 50%; small_amplitude: below 20%; near_stop: below 5% but still moving
    assert [share("large_amplitude", i) for i in range(5)] == [1, 0, 0, 0, 0]
    assert [share("small_amplitude", i) for i in range(5)] == [0, 0, 0, 1, 1]
    assert [share("near_stop", i) for i in range(5)] == [0, 0, 0, 0, 1]
    assert [share("rest_offset", i) for i in range(5)] == [0, 0, 0, 0, 0]
    rest = t >= 16.0
    assert lab["rest_offset"][rest].all() and not lab["near_stop"][rest].any()


def test_reversal_is_8_percent_of_a_half_period_either_side_of_a_turning_point():
    t, y, _ = _staircase()
    lab = classify(_prepared(t, y, 0.0, 1.0, 0.5))[0]
    # one turning point per half period (0.5 s), flagged for +-0.04 s: 16% of the samples
    swinging = (t >= 0.25) & (t < 2.75)
    assert lab["reversal"][swinging].mean() == pytest.approx(0.16, abs=0.02)


def test_late_decay_is_the_last_third_of_the_moving_time():
    t, y, _ = _staircase()
    lab = classify(_prepared(t, y, 0.0, 1.0, 0.5))[0]
    # moving from the release (0 s) until the swing envelope (max over one period) falls below
    # 1% of the release amplitude: the last 0.03 swing ends at 15 s, + half a period
    t_b = 15.5
    late = t[lab["late_decay"]]
    assert late[-1] == pytest.approx(t_b, abs=0.05)
    assert late[0] == pytest.approx(t_b - t_b / 3.0, abs=0.05)
    assert np.all(np.diff(late) == pytest.approx(DT))          # one contiguous stretch


def test_release_and_ramp_exit_regimes_span_0_3_s():
    t = np.arange(-4, 640) * DT                    # window starts 0.0625 s before the release at 0
    y = np.cos(2 * np.pi * t)
    lab = classify(_prepared(t, y, 0.0, 1.0, 0.5))[0]
    rel = t[lab["release"]]
    assert rel[0] == -3 * DT and rel[-1] == 19 * DT          # [-0.05, 0.3): samples -3 .. 19
    ramp = np.arange(200) * DT
    lab = classify(_prepared(ramp, 2.0 * ramp, 0.0, 0.0, float("nan"), kind="ramp"))[0]
    assert int(lab["ramp_exit"].sum()) == 20                  # t > t_end - 0.3: samples 180 .. 199
    assert lab["ramp_exit"][180:].all()


def test_regime_shares_of_residual_and_samples():
    t = np.arange(-4, 640) * DT
    y = np.cos(2 * np.pi * t)
    prep = _prepared(t, y, 0.0, 1.0, 0.5)
    err = np.where((t >= -0.05) & (t < 0.3), 0.2, 0.0)      # the whole misfit in the release's 0.3 s
    loc = locate(prep, {0: y + err})
    rel = next(r for r in loc.regimes if r["regime"] == "release")
    assert rel["share_of_residual"] == pytest.approx(1.0)
    assert rel["share_of_samples"] == pytest.approx(23 / 644)
    assert rel["concentration"] == pytest.approx(644 / 23)


# --------------------------------------------------------------------------------------
# locate: time windows
# --------------------------------------------------------------------------------------
def test_located_windows_are_whole_swing_periods():
    """Pieces are one period (2 half periods = 1 s) long from the window's first sample; a
    misfit inside [2, 2.5) s is located in the piece [2, 3) s."""
    t = np.arange(640) * DT
    y = np.cos(2 * np.pi * t)
    prep = _prepared(t, y, 0.0, 1.0, 0.5)
    err = np.where((t >= 2.0) & (t < 2.5), 0.1, 0.0)
    loc = locate(prep, {0: y + err})
    assert len(loc.windows) == 1
    w = loc.windows[0]
    assert (w["start_s"], w["end_s"]) == (2.0, round(3.0 - DT, 3))
    assert w["share_of_residual"] == pytest.approx(1.0)
    assert w["signal"] == "steer_angle_rad"


def test_adjacent_located_pieces_merge_into_one_window():
    t = np.arange(640) * DT
    y = np.cos(2 * np.pi * t)
    prep = _prepared(t, y, 0.0, 1.0, 0.5)
    err = np.where(((t >= 2.0) & (t < 4.0)) | ((t >= 7.0) & (t < 8.0)), 0.1, 0.0)
    loc = locate(prep, {0: y + err})
    # three pieces of a third each (two below the 80% cover, so all three are taken); the
    # adjacent [2, 3) and [3, 4) s merge, the largest window first
    got = [(w["start_s"], w["end_s"], round(w["share_of_residual"], 6)) for w in loc.windows]
    assert got == [(2.0, round(4.0 - DT, 3), round(2 / 3, 6)), (7.0, round(8.0 - DT, 3), round(1 / 3, 6))]
    assert sum(w["share_of_residual"] for w in loc.windows) == pytest.approx(1.0)


# --------------------------------------------------------------------------------------
# data: fit windows
# --------------------------------------------------------------------------------------
ZETA, OMEGA_N = 0.1, 4.0 * np.pi
HALF = math.pi / (OMEGA_N * math.sqrt(1.0 - ZETA ** 2))      # 0.2513 s
T_REL = 1.0


def _settle(n=1500, dt=0.01, phase=0.0, zeta=ZETA):
    """Held at 0.5 until T_REL, then the free response of a damped oscillator to rest 0."""
    t = np.arange(n) * dt + phase
    return t, np.where(t >= T_REL, free_response(np.maximum(t - T_REL, 0.0), 0.5, zeta, OMEGA_N), 0.5)


def _end(t, y, t_end, t_stop=None):
    t_stop = float(t[-1]) if t_stop is None else t_stop
    return _end_of_free_response(t, y, _release(T_REL, t_end, 0.5, HALF), t_stop, 1e-4, 0.0)


def test_a_body_left_at_rest_keeps_its_window_3_s_past_the_release_finders_end():
    t, y = _settle()
    end, reason = _end(t, y, t_end=5.0)                # at rest from ~4.7 s to the end (15 s)
    assert reason == "at rest to the end of the record"
    assert end == pytest.approx(8.0, abs=1e-9)           # the release finder's end + 3 s


def test_a_hand_moving_the_body_at_rest_ends_the_window_0_15_s_before_it_leaves_rest():
    t, y = _settle()
    t_hand = 7.0
    x = np.clip((t - t_hand) / 0.5, 0.0, 1.0)
    y = y + 0.015 * (1.0 - np.cos(np.pi * x))       # pushed by 0.03 (6% of the release amplitude) in 0.5 s
    end, reason = _end(t, y, t_end=5.0)
    assert reason == "hand moved the body at rest"
    # it leaves the band of 1% of the release amplitude (0.005) when 0.015 (1 - cos(pi x)) > 0.005,
    # i.e. 0.5 acos(2/3) / pi = 0.134 s after the hand starts; the window ends 0.15 s before that
    assert end == pytest.approx(t_hand + 0.5 * math.acos(2.0 / 3.0) / math.pi - 0.15, abs=0.02)


def test_a_turning_point_just_before_the_hand_takes_the_body_is_not_a_free_swings():
    """A hand that takes the body within a quarter of a half period after a turning point made
    that turning point: the window ends at the turning point before it."""
    t, y = _settle()
    turns = T_REL + HALF * np.arange(12)          # turning points of a release from rest
    end, reason = _end(t, y, t_end=turns[8] + 0.1 * HALF, t_stop=turns[8] + 0.1 * HALF)
    assert reason == "hand took over after the last turning point"
    assert end == pytest.approx(turns[7], abs=0.011)
    end, _ = _end(t, y, t_end=turns[8] + 0.3 * HALF, t_stop=turns[8] + 0.3 * HALF)
    assert end == pytest.approx(turns[8], abs=0.011)


@pytest.mark.parametrize("after_half, reason", [(0.6, "hand took over mid-swing"),
                                                (1.6, "hand took over after the last turning point")])
def test_a_hand_leaving_the_swing_band_within_1_2_half_periods_grabbed_mid_swing(after_half, reason):
    t, y = _settle()
    t_last = T_REL + 8 * HALF
    t_grab = t_last + after_half * HALF
    y_grab = float(np.interp(t_grab, t, y))
    x = np.clip((t - t_grab) / 0.3, 0.0, 1.0)
    y = np.where(t < t_grab, y, y_grab + (0.4 - y_grab) * 0.5 * (1.0 - np.cos(np.pi * x)))   # carried to 0.4
    end, why = _end(t, y, t_end=t_last + 0.05)
    assert why == reason
    assert end == pytest.approx(t_last, abs=0.011)


def test_first_turning_point_is_refined_between_samples():
    # samples 0.01 s apart, placed so the true turning point (pi / omega_d after the release)
    # falls half-way between two of them
    half = math.pi / (OMEGA_N * math.sqrt(1.0 - 0.05 ** 2))
    t_true = T_REL + half
    t, y = _settle(phase=(t_true - 0.005) % 0.01, zeta=0.05)
    assert np.min(np.abs(t - t_true)) == pytest.approx(0.005, abs=1e-6)
    got = _first_turning_point(t, y, _release(T_REL, float(t[-1]), 0.5, half), float(t[-1]))
    assert got is not None
    assert got[0] == pytest.approx(t_true, abs=0.002)          # the nearest sample is 0.005 s off
    assert got[1] == pytest.approx(-0.5 * math.exp(-0.05 * OMEGA_N * half), abs=2e-3)


@pytest.mark.parametrize("zeta, starts_there", [(0.4, True), (0.5, False)])
def test_the_window_starts_at_the_first_turning_point_only_when_three_more_follow(zeta, starts_there):
    """Turning points whose swing exceeds the 2% hysteresis: a damped oscillator's extremes
    fall by r = exp(-zeta pi / sqrt(1 - zeta^2)) per half swing, and the k-th is confirmed when
    r^(k-1) + r^k > 0.02.  zeta 0.4 (r 0.25): four turning points; zeta 0.5 (r 0.16): three."""
    t, y = _settle(zeta=zeta)
    half = math.pi / (OMEGA_N * math.sqrt(1.0 - zeta ** 2))
    got = _first_turning_point(t, y, _release(T_REL, float(t[-1]), 0.5, half), float(t[-1]))
    assert (got is not None) == starts_there


def test_a_window_from_the_release_starts_0_05_s_before_it():
    t, y, _ = synthetic_release_log([dict(offset=0.4, zeta=0.5, omega_n=6.0)], seed=3, rest=-0.035)
    prep = prepare(Recording(pd.DataFrame({"time_s": t, "steer_angle_rad": y}),
                             {"kind": "steer_stand", "pressure_kpa": None}))
    w = prep.windows[0]
    assert w.start == "release"
    first = int(np.searchsorted(t, w.t[0]))
    assert w.t[0] >= w.t0 - 0.05 > t[first - 1]


def test_hold_releases_need_a_hold_of_0_4_s():
    """An undamped body (no decay, so only the hold finder sees releases): moved from rest to
    0.5 in 1 s, held, let go into a 1 Hz swing about rest."""
    def log(hold_s):
        t = np.arange(0.0, 10.0, 0.01)
        y = 0.25 * (1.0 - np.cos(np.pi * t))
        held = (t >= 1.0) & (t < 1.0 + hold_s)
        y[held] = 0.5
        free = t >= 1.0 + hold_s
        y[free] = 0.5 * np.cos(2 * np.pi * (t[free] - 1.0 - hold_s))
        return t, y

    assert hold_releases(*log(0.2), "shell_rock") == []          # still for ~0.3 s in all
    rel = hold_releases(*log(0.8), "shell_rock")
    assert len(rel) == 1
    assert rel[0].t_release_s == pytest.approx(1.8, abs=0.05)
    assert rel[0].y_release == pytest.approx(0.5, abs=1e-3)
    assert rel[0].half_period_s == pytest.approx(0.5, abs=0.02)


def _moved_held_released(t, y, t_move, level, swing_s, hold_s=1.0, move_s=0.8, rest=0.0, period=1.0):
    """y with the body moved by a hand from `rest` at t_move to `level` in move_s, held hold_s,
    then let go into an undamped swing about `rest` for swing_s; where it ends the body stays."""
    t1, t2 = t_move + move_s, t_move + move_s + hold_s
    moving = (t >= t_move) & (t < t1)
    y[moving] = rest + (level - rest) * 0.5 * (1.0 - np.cos(np.pi * (t[moving] - t_move) / move_s))
    y[(t >= t1) & (t < t2)] = level
    free = t >= t2
    swing = rest + (level - rest) * np.cos(2 * np.pi * np.minimum(t[free] - t2, swing_s) / period)
    y[free] = swing
    return t2


def test_a_short_record_s_rest_before_the_hands_move_is_no_release_and_gives_the_rest():
    """1 s at rest (-0.03), moved to +0.14 and held, let go for 2 s of a 2.8 s swing (one turning
    point), as a short first recording of a shell is: the median of so short a record lies off
    rest, so the stillness at rest once passed for a hold released at 1 s, and the release's rest
    came from the swing's median (-0.07 for -0.03)."""
    t = np.arange(0.0, 4.8, 0.01)
    y = np.full_like(t, -0.03)
    t_go = _moved_held_released(t, y, 1.0, 0.14, 2.0, rest=-0.03, period=2.8)
    y += 4e-4 * np.random.default_rng(1).standard_normal(len(t))
    rel = hold_releases(t, y, "shell_rock")
    assert len(rel) == 1
    assert rel[0].t_release_s == pytest.approx(t_go, abs=0.03)
    assert rel[0].y_rest == pytest.approx(-0.03, abs=2e-3)


def test_a_body_that_creeps_to_rest_and_is_moved_on_keeps_its_release():
    """Held at 0.3, let go into an overdamped creep to rest, still there 1 s, then moved by the
    hand straight to -0.3 and held: the way from 0.3 to -0.3 is one-way but pauses at rest, so
    the first hold is a release, not the start of a hand's move."""
    t = np.arange(0.0, 12.0, 0.01)
    y = np.zeros_like(t)
    y[t < 1.0] = 0.3
    creep = (t >= 1.0) & (t < 3.0)
    y[creep] = 0.3 * np.exp(-4.0 * (t[creep] - 1.0))
    y[(t >= 3.0) & (t < 4.0)] = 0.0
    _moved_held_released(t, y, 4.0, -0.3, 6.0)
    rel = hold_releases(t, y, "steer_stand")
    assert [r.t_release_s for r in rel] == [pytest.approx(1.0, abs=0.1), pytest.approx(5.8, abs=0.1)]


def test_pooled_recordings_keep_the_coarsest_quantum_and_the_median_noise():
    def prep(label, noise, quantum):
        rec = Recording(pd.DataFrame({"time_s": [0.0, 1.0], "steer_angle_rad": [0.0, 0.0]}),
                        {"kind": "steer_stand", "pressure_kpa": None, "label": label})
        return Prepared(recording=rec, kind="steer_stand", signal="steer_angle_rad", unit="rad", windows=[],
                        noise=noise, quantum=quantum, sources=[rec])

    p = pool([prep("a", 1e-3, 0.002), prep("b", 4e-3, 0.0), prep("c", 2e-3, 0.001)])
    assert p.quantum == 0.002
    assert p.noise == pytest.approx(2e-3)


def test_fit_noise_is_the_sensor_noise_of_what_the_fit_compares():
    """Raw windows: the sensor's noise.  An averaged (ramp) window: each value averages m samples,
    whose independent noise leaves sigma^2 / m; fit_noise is sigma sqrt(mean 1/m).  At 64 Hz a
    +-0.1 s boxcar holds 13 samples inside the window and shrinks to 1 at its two ends (and the
    samples before the release stay raw)."""
    t = np.arange(200) * DT
    raw = _prepared(t, np.zeros_like(t), 0.0, 0.0, 0.5, noise=0.015)
    assert raw.fit_noise == 0.015 and np.all(raw.windows[0].averaged_counts() == 1)
    w = Window(index=0, t0=t[5], t=t, y=np.zeros_like(t), q0=0.0, release=raw.windows[0].release, smooth_s=0.1)
    m = w.averaged_counts()
    assert np.all(m[:6] == 1) and m[-1] == 1 and np.all(m[20:-20] == 13)
    assert list(m[5:12]) == [1, 3, 5, 7, 9, 11, 13]              # symmetric windows at the start
    ramp = Prepared(recording=None, kind="ramp", signal="drive_rate_rad_s", unit="rad/s", windows=[w],
                    noise=0.015, quantum=0.0)
    assert ramp.fit_noise == pytest.approx(0.015 * math.sqrt(np.mean(1.0 / m)))
    assert 0.015 / math.sqrt(13) < ramp.fit_noise < 0.015 / 2
    # observe() averages a prediction with the same windows (a constant passes, a ramp's curvature does not)
    y = np.where(t >= t[5], (t - t[5]) ** 2, 0.0)
    seen = w.observe(y)
    assert np.allclose(w.observe(np.ones_like(t)), 1.0)
    inner = slice(30, -30)
    assert np.allclose(seen[inner] - y[inner], np.mean((np.arange(-6, 7) * DT) ** 2))   # f'' h^2/6-type bias


def test_a_hand_s_tremor_does_not_hide_a_small_release_s_hold():
    """1 s at rest (-0.033), moved by 0.08 rad and held 1.2 s with the test bed's hand tremor (1.5
    mrad at about 2 Hz), let go into less than one slow swing, through the test bed's sensors: the
    tremor is faster than 5% of so small a record's peak speed and split the hold into stretches
    under 0.4 s, so the stillness at rest passed for the hold and the hand's move for the release
    (the steer-setting closed loop's first recordings, docs/diagnosis.md)."""
    import pandas as pd

    from roboball.testbed.physics import load_truth
    from roboball.testbed.sensors import hand_phase, measure

    truth, rate = load_truth(), 1000.0
    rng = np.random.default_rng(5)
    hand, held = hand_phase(-0.033, -0.113, {"move_s": [0.8, 0.8], "hold_s": [1.2, 1.2], "tremor_rad": 0.0015},
                            rng, rate)
    t_free = np.arange(1, 2001) / rate
    free = -0.033 + (held + 0.033) * np.cos(2.1 * t_free)          # a slow half swing and a bit
    y = np.r_[np.full(1000, -0.033), hand, free]
    dense = pd.DataFrame({"time_s": np.arange(len(y)) / rate, "pipe_angle_rad": y,
                          "pipe_rate_rad_s": np.gradient(y) * rate})
    rec = measure(dense, truth["sensors"], rng)
    t_go = (1000 + len(hand) - 1) / rate
    rel = hold_releases(rec.time_s.to_numpy(), rec.pipe_angle_rad.to_numpy(), "shell_rock")
    assert len(rel) == 1
    assert rel[0].t_release_s == pytest.approx(t_go, abs=0.05)
    assert rel[0].y_release == pytest.approx(-0.113, abs=3e-3)


@pytest.mark.parametrize("case, draw", [(19, 3), (36, 0), (40, 1)])
def test_a_tremor_of_a_tenth_of_a_small_move_is_still_the_hand_s_hold(tmp_path, case, draw):
    """The steer-setting closed loop's case 19 (its fourth draw: the test bed's shell with the
    pendulum free, 1 s at rest at -0.033, moved 0.057 rad and held 1.2 s, then 2 s after the
    let-go as the pendulum creeps back): the hold's tremor strays 3-4 mrad from its level, past 5%
    of so small a record's range, so the hold was never joined; the stillness at rest passed for
    the hold, and the diagnosis fitted the tremor as the free response (and decided 'locked',
    p = 0.01, for a free pendulum).  Joined across a tremor of a tenth of the range, the hold ends
    at the let-go and the rest is where the body sat.  Cases 36 and 40 (moved 0.095 and 0.097 rad,
    held locked): the tremor's excursions from the hold lasted up to 0.5 s, and joined across
    0.2 s the hold broke in two; its first part was taken for the hold and the release came
    0.5 s early, or the stillness at rest for a hold with a rest 0.09 rad off."""
    from conftest import closed_loop_recording

    c, path = closed_loop_recording(tmp_path, case, draw)
    d = pd.read_csv(path)
    t, y = d.time_s.to_numpy(), d.pipe_angle_rad.to_numpy()
    sat = float(np.median(y[t < 0.9]))
    moved = t[np.nonzero(np.abs(y - sat) > 0.5 * abs(c["release"]))[0][0]]
    held = np.nonzero(np.abs(y - sat - c["release"]) < 0.1 * abs(c["release"]))[0]
    rel = hold_releases(t, y, "shell_rock")
    assert len(rel) == 1
    assert rel[0].t_release_s > moved + 1.0             # after the hand's move and its hold
    assert rel[0].t_release_s == pytest.approx(t[held[-1]], abs=0.3)
    assert rel[0].y_rest == pytest.approx(sat, abs=2e-3)


def test_a_sample_on_the_level_is_no_crossing_of_it():
    """The median of an odd number of samples is one of them: np.sign gave 0 there, and one pass
    through the level counted twice (a 0.6 rad release with one swing in its window then read as
    1.5 swings, its rest the swing's median, 0.19 rad, for -0.033)."""
    from roboball.diagnose.handholds import _crossings

    t = np.arange(7.0)
    assert _crossings(t, np.array([-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0]), 0.5).tolist() == [4.0]
    assert _crossings(t, np.array([-3.0, 0.2, -0.2, 0.2, 1.0, -2.0, -3.0]), 0.5).tolist() == [4.0, 5.0]
    assert _crossings(t, np.zeros(7), 0.5).tolist() == []


@pytest.mark.parametrize("case, draw, release, settle_s, stream", [(3, 1, 0.6, 4.47, 2), (25, 0, 0.45, 4.977, 2)])
def test_a_shell_creeping_to_rest_in_steps_keeps_the_hand_s_hold_as_its_release(tmp_path, case, draw, release,
                                                                                settle_s, stream):
    """The steer-setting closed loop's proposed recordings with the pendulum free and heavily
    damped (the test bed's shell moved 0.45-0.6 rad, held 1.2-1.4 s, let go for 4.5-5 s): the
    shell creeps back in steps, pausing 0.3-0.5 s at each of the pendulum's swings.  Each pause
    passed for a hold the hand's hold went straight into, so the hand's hold was taken for the
    start of a move and the last pause for the release.  The release is the end of the hand's
    hold, its window the whole creep, its rest where the shell sat before the hand took it."""
    from conftest import closed_loop_recording

    d = pd.read_csv(closed_loop_recording(tmp_path, case, draw, [release], settle_s, "designed", stream)[1])
    t, y = d.time_s.to_numpy(), d.pipe_angle_rad.to_numpy()
    sat = float(np.median(y[t < 0.9]))
    held = np.nonzero(np.abs(y - sat - release) < 0.02)[0]          # the hand's hold
    rel = hold_releases(t, y, "shell_rock")
    assert len(rel) == 1
    assert rel[0].t_release_s == pytest.approx(t[held[-1]], abs=0.3)
    assert rel[0].t_end_s > t[-1] - 0.1
    assert rel[0].y_rest == pytest.approx(sat, abs=2e-3)


def test_a_ramp_run_without_ramp_exit_s_ends_where_its_rate_falls_onto_the_floor(tmp_path):
    """A campaign run renamed with its sidecar's ramp_exit_s left out: the window ends within 20 ms
    of the exit the field gave, and the notes say the exit was read from the rate."""
    import json
    import shutil

    from conftest import REPO
    from roboball.diagnose.data import read

    src = REPO / "raw_data" / "ramp" / "ramp_20.7kpa_r1.csv"
    meta = json.loads(src.with_suffix(".json").read_text())
    exit_s = meta.pop("ramp_exit_s")
    shutil.copy(src, tmp_path / "descent.csv")
    (tmp_path / "descent.json").write_text(json.dumps(meta))
    prep = prepare(read(tmp_path / "descent.csv"))
    (w,) = prep.windows
    assert abs(w.t[-1] - exit_s) < 0.02 and w.end_reason == "ramp exit read from the rate (no ramp_exit_s)"
    assert any("left the ramp at" in n for n in prep.notes)
    with_field = prepare(read(src)).windows[0]
    assert with_field.end_reason == "ramp exit" and abs(with_field.t[-1] - exit_s) < 0.011
