"""Noise-aware roughness (docs/noise-aware-roughness.md) on every implementation: the noise PSD of known bin
errors, the resolved fraction of sparse sampling, and a fit that declines rather than report noise as roughness."""

import math

import numpy as np
import pytest

from roadpreview.config import Config
from roadpreview.reference.roughness import displacement_psd
from test_reference_known_answers import iso_profile

DS = 0.1
NOISE_DOMINATES = "noise dominates the band"


def median_variance(sigma, n):
    """Variance of a bin height from n points of spread sigma, as §1 defines it."""
    return sigma**2 if n == 1 else sigma**2 / 2 if n == 2 else math.pi / 2 * sigma**2 / n


@pytest.mark.parametrize("n", [2, 3, 12])
def test_noise_psd_of_fully_backed_bins_is_white(impl, n):
    sigma, bins = 0.004, 300
    psd = impl.noise_psd(np.full(bins, n), np.full(bins, sigma), DS)
    assert len(psd) == bins // 2 + 1
    np.testing.assert_allclose(psd[1:-1], 2 * DS * median_variance(sigma, n), rtol=1e-12)
    assert psd[0] == pytest.approx(DS * median_variance(sigma, n), rel=1e-12)  # DC and Nyquist: one-sided


def test_single_point_bins_take_the_pooled_variance(impl):
    count = np.array([3, 1, 5, 1, 2, 1] * 50)
    spread = np.where(count >= 2, np.tile([0.002, np.nan, 0.004, np.nan, 0.001, np.nan], 50), np.nan)
    pooled = (2 * 0.002**2 + 4 * 0.004**2 + 1 * 0.001**2) / 7
    variances = np.tile([median_variance(0.002, 3), pooled, median_variance(0.004, 5), pooled, 0.001**2 / 2, pooled], 50)
    window = (0.5 * (1 - np.cos(2 * np.pi * np.arange(300) / 300))) ** 2
    expected = 2 * DS * np.sum(window * variances) / np.sum(window)  # independent errors: white
    np.testing.assert_allclose(impl.noise_psd(count, spread, DS)[1:-1], expected, rtol=1e-9)


def test_a_single_point_bin_with_a_spread_keeps_its_own_variance(impl):
    # A fused map's cell knows its variance even when one point fed it: its spread is that variance's root.
    count = np.tile([3, 1], 150)
    spread = np.tile([0.004, 0.001], 150)
    variances = np.tile([median_variance(0.004, 3), 0.001**2], 150)
    window = (0.5 * (1 - np.cos(2 * np.pi * np.arange(300) / 300))) ** 2
    expected = 2 * DS * np.sum(window * variances) / np.sum(window)
    np.testing.assert_allclose(impl.noise_psd(count, spread, DS)[1:-1], expected, rtol=1e-9)
    only_singles = impl.noise_psd(np.ones(300, dtype=np.int32), np.full(300, 0.002), DS)
    np.testing.assert_allclose(only_singles[1:-1], 2 * DS * 0.002**2, rtol=1e-9)
    assert impl.noise_psd(np.ones(300, dtype=np.int32), np.full(300, np.nan), DS) is None


def test_noise_psd_of_interpolated_gaps_matches_a_monte_carlo(impl):
    # Backed bins every 1 to 6 bins, errors of known variance, linear interpolation in between: the mean
    # periodogram of 4000 draws (which includes the detrend) against the predicted noise PSD.
    rng = np.random.default_rng(5)
    gaps = rng.integers(1, 7, 60)
    backed = np.concatenate(([0], np.cumsum(gaps)))
    count = np.zeros(backed[-1] + 1, dtype=np.int32)
    count[backed] = rng.integers(2, 9, len(backed))
    spread = np.where(count >= 2, rng.uniform(0.002, 0.006, len(count)), np.nan)
    variance = np.where(count >= 3, np.pi / 2, 0.5) * spread**2 / np.where(count >= 3, count, 1)
    draws = rng.standard_normal((4000, len(backed))) * np.sqrt(variance[backed])
    profiles = np.array([np.interp(np.arange(len(count)), backed, d) for d in draws])
    mean_psd = np.mean([displacement_psd(p, DS)[1] for p in profiles], axis=0)
    predicted = impl.noise_psd(count, spread, DS)
    k = np.arange(3, len(predicted) - 1)  # the detrend only touches the lowest ordinates
    # 4000 draws: each mean ordinate has ~1.6 % scatter; the shape spans two orders of magnitude.
    np.testing.assert_allclose(mean_psd[k], predicted[k], rtol=0.08)
    assert predicted[k[-1]] < predicted[k[0]] / 5  # interpolation makes the noise red


@pytest.mark.parametrize("gap", [1, 3, 5])
def test_resolved_fraction_of_regular_sampling_is_the_interpolation_loss(impl, gap):
    bins = 60 * gap + 1  # starts and ends on a backed bin
    count = np.zeros(bins, dtype=np.int32)
    count[::gap] = 4
    n = np.arange(bins // 2 + 1) / (bins * DS)
    phi = impl.resolved_fraction(count, DS, n)
    g = gap * DS
    expected = np.where(n * g <= 0.5, np.sinc(n * g) ** 4, 0.0)
    np.testing.assert_allclose(phi, expected, atol=2e-3)  # the last bin (spacing ds) weighs ~nothing


def noisy_profile(gd_n0, sigma, seed, count=400, points=4):
    """An ISO 8608 profile whose bins each hold `points` points with spread sigma (bin error of that variance)."""
    rng = np.random.default_rng(seed + 1000)
    z = iso_profile(gd_n0, seed, count=count) + rng.normal(0, math.sqrt(median_variance(sigma, points)), count)
    return z, np.full(count, points), np.full(count, sigma)


@pytest.mark.parametrize("seed", range(5))
def test_pure_noise_is_declined_not_classified(impl, seed):
    z, count, spread = noisy_profile(0.0, 0.005, seed)
    result = impl.analyze_roughness(z, DS, Config(), count=count, spread=spread)
    assert result.iso_class is None and result.reason == NOISE_DOMINATES and result.band_limit == "noise"
    assert result.noise_floor == pytest.approx(2 * DS * median_variance(0.005, 4), rel=1e-9)
    plain = impl.analyze_roughness(z, DS, Config())
    assert plain.iso_class not in (None, "A")  # without the noise model the noise reads as a rough road


def test_noise_far_below_class_a_still_gives_class_a(impl):
    z, count, spread = noisy_profile(0.0, 1e-5, 0)
    result = impl.analyze_roughness(z, DS, Config(), count=count, spread=spread)
    assert result.iso_class == "A" and result.reason is None and result.band_limit == "noise"
    assert result.gd_n0 < 32e-6 and result.confidence > 0.99


def test_noise_aware_fit_recovers_the_class_that_noise_hides(impl):
    # Class B under 3.5 mm bin noise: the noise PSD equals the road's near 0.5 cycles/m. Without the noise model
    # every seed reads two or more classes too rough; with it, the class is right in at least 9 of 10.
    right, plain_classes = 0, []
    for seed in range(10):
        z, count, spread = noisy_profile(64e-6, 0.0035 * math.sqrt(2), seed, points=4)
        aware = impl.analyze_roughness(z, DS, Config(), count=count, spread=spread)
        right += aware.iso_class == "B"
        plain_classes.append(impl.analyze_roughness(z, DS, Config()).iso_class)
    assert right >= 9
    assert all(c in "DEFGH" for c in plain_classes)


def test_confidence_is_calibrated(impl):
    # Roads drawn log-uniformly across classes B–E, 15 m stretches with noise: the mean confidence must match the
    # share of right classes (300 cases: the share has a standard error of ~0.03).
    rng = np.random.default_rng(11)
    confidence, right = [], []
    for seed in range(300):
        gd = math.exp(rng.uniform(math.log(32e-6), math.log(8192e-6)))
        z, count, spread = noisy_profile(gd, 0.002, seed, count=150)
        result = impl.analyze_roughness(z, DS, Config(), count=count, spread=spread)
        if result.iso_class is None:
            continue
        truth = "ABCDEFGH"[int(np.searchsorted(32e-6 * 4.0 ** np.arange(7), gd, side="right"))]
        confidence.append(result.confidence)
        right.append(result.iso_class == truth)
    assert len(right) > 250
    assert np.mean(confidence) == pytest.approx(np.mean(right), abs=0.08)
    assert 0.4 < np.mean(right) < 0.95  # the test is not trivially certain


def test_noise_floor_unknown_without_bins_of_two_points(impl):
    z = iso_profile(256e-6, 0, count=200)
    result = impl.analyze_roughness(z, DS, Config(), count=np.ones(200, np.int32), spread=np.full(200, np.nan))
    assert result.iso_class is None and result.reason == "noise floor unknown" and result.noise_psd is None
    assert result.backed_fraction == 1.0


def test_sparse_sampling_limits_the_band(impl):
    z = iso_profile(1024e-6, 2, count=401)
    count = np.zeros(401, np.int32)
    count[::5] = 6  # points every 0.5 m, linear in between
    z = np.interp(np.arange(401), np.flatnonzero(count), z[count > 0])
    result = impl.analyze_roughness(z, DS, Config(), count=count, spread=np.where(count > 0, 1e-4, np.nan))
    assert result.band_limit == "sampling" and result.backed_fraction == pytest.approx(81 / 401)
    n_hi = result.band[1]
    assert np.sinc(n_hi * 0.5) ** 4 >= 0.5 > np.sinc((n_hi + 1 / 40.1) * 0.5) ** 4  # where Φ drops below ½
    assert result.iso_class == "D"
    assert impl.analyze_roughness(z, DS, Config()).iso_class in "ABC"  # the interpolation smooths it away
    # The noise floor is the noise's mean over the band the fit used, not over the requested one: gaps redden the
    # noise (more at low n), so the mean up to 4 cycles/m would read it ~2× lower.
    n, noise = np.asarray(result.n), np.asarray(result.noise_psd)
    in_band = (n >= result.band[0] * (1 - 1e-9)) & (n <= n_hi * (1 + 1e-9))
    assert result.noise_floor == pytest.approx(noise[in_band].mean(), rel=1e-12)
    requested = (n >= result.band[0] * (1 - 1e-9)) & (n <= 4.0 * (1 + 1e-9))
    assert result.noise_floor > 1.5 * noise[requested].mean()


def test_profile_noise_floor_of_a_flat_noisy_road(impl):
    # End to end: points on a flat road with 3 mm Gaussian height noise; the profile's spreads measure it.
    rng = np.random.default_rng(3)
    x, y = rng.uniform(0, 42, 60000), rng.uniform(0.5, 1.1, 60000)
    points = np.column_stack([x, y, rng.normal(0, 0.003, len(x))])
    cfg = Config(profile={"level": False})
    path = impl.plan_path(10.0, 0.0, cfg)
    profile = impl.wheel_profile(points, None, path, "left", 10.0, 0.0, cfg)
    count = np.asarray(profile.count)
    assert count.min() >= 3
    window = (0.5 * (1 - np.cos(2 * np.pi * np.arange(400) / 400))) ** 2
    expected = 2 * DS * np.sum(window * math.pi / 2 * 0.003**2 / count) / np.sum(window)
    assert profile.roughness.noise_floor == pytest.approx(expected, rel=0.05)
    np.testing.assert_allclose(np.nanmedian(profile.spread), 0.003, rtol=0.05)
    assert profile.roughness.iso_class == "A"  # 1.5 mm of bin noise hides nothing rougher than class A
