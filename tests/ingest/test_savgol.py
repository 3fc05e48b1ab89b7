"""roboball.ingest.releases.signal.savgol_filter stands in for scipy.signal.savgol_filter (whose
import costs the ingest and diagnosis jobs about 0.7 s of CPU each): it must give the same bits."""
import numpy as np
import pytest
import scipy.signal

from roboball.ingest.releases.signal import savgol_filter


def test_the_same_bits_as_scipy_over_windows_orders_derivatives_and_steps():
    rng = np.random.default_rng(7)
    cases = 0
    for _ in range(120):
        n = int(rng.integers(9, 2500))
        x = np.cumsum(rng.normal(size=n)) * rng.uniform(1e-4, 1.0)
        window = min(int(rng.integers(3, 121)) | 1, n - (1 - n % 2))
        for order in range(min(4, window)):
            for deriv in range(3):
                delta = float(rng.choice([1.0, 0.01, 0.0123]))
                want = scipy.signal.savgol_filter(x, window, order, deriv=deriv, delta=delta)
                assert np.array_equal(savgol_filter(x, window, order, deriv=deriv, delta=delta), want), \
                    (n, window, order, deriv, delta)
                cases += 1
    assert cases > 1000


def test_the_window_the_ingest_uses_on_a_short_signal():
    x = np.sin(np.linspace(0.0, 3.0, 7))
    assert np.array_equal(savgol_filter(x, 7, 2), scipy.signal.savgol_filter(x, 7, 2))


@pytest.mark.parametrize("window, order", [(4, 2), (5, 5), (9, 2)])
def test_a_window_it_cannot_take_is_refused(window, order):
    with pytest.raises(ValueError, match="savgol_filter"):
        savgol_filter(np.zeros(8), window, order)
