"""The PSD normalisation against an independent implementation: scipy.signal.periodogram.

scipy's density scaling is |X|² / (fs · Σw²), doubled except at DC and Nyquist — the one-sided G_d of
docs/method.md §4 with fs = 1/ds and N·U = Σw².
"""

import numpy as np
import pytest
from scipy import signal


@pytest.mark.parametrize("count", [64, 101, 400, 1025, 3000])  # beyond 1,024 bins the C++ plans each transform
def test_psd_equals_scipy_periodogram_with_a_periodic_hann_window(impl, count):
    rng = np.random.default_rng(count)
    z = np.cumsum(rng.normal(0, 0.002, count)) + 0.01 * np.arange(count)
    ds = 0.1
    n, psd = impl.displacement_psd(z, ds)
    f, expected = signal.periodogram(z, fs=1 / ds, window="hann", detrend="linear", scaling="density")
    np.testing.assert_allclose(n, f, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(psd, expected, rtol=1e-9, atol=1e-15 * expected.max())
