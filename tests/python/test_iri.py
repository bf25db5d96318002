"""International Roughness Index (docs/method.md §6) on every implementation: analytic inputs, the golden car's
frequency response, and a real profile against the reference values of Šroubek & Šorel's program."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from paths import DATA
from roadpreview.config import Config

PROFILES = DATA / "profiles" / "sroubek_iri"
SPEED_MPS = 80 / 3.6
K1, K2, C, MU = 653.0, 63.3, 6.0, 0.15  # ASTM E1926 golden car


def golden_car_response(wavelength_m):
    """|H| of the continuous golden car from input slope to (sprung − unsprung) slope at this wavelength."""
    a = np.array([[0, 1, 0, 0], [-K2, -C, K2, C], [0, 0, 0, 1], [K2 / MU, C / MU, -(K1 + K2) / MU, -C / MU]])
    b = np.array([0, 0, 0, K1 / MU])
    omega = 2 * math.pi * SPEED_MPS / wavelength_m
    x = np.linalg.solve(1j * omega * np.eye(4) - a, b)
    return abs(x[0] - x[2])


def test_flat_and_inclined_profiles_have_no_roughness(impl):
    s = np.arange(500) * 0.1
    for z in (np.zeros(500), 0.03 * s - 1.0):  # a grade is not roughness: the car starts on its slope
        assert np.max(np.abs(impl.rectified_slope(z, 0.1))) < 1e-12
        assert impl.profile_iri(z, 0.1, Config()).value == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("wavelength", [1.23, 2.47, 5.11, 15.3])  # not commensurate with 0.1 m
def test_sine_gives_the_quarter_car_response(impl, wavelength):
    # Steady state: (sprung − unsprung slope) = |H|·U·cos(ωt + φ), whose mean absolute value is (2/π)|H|U. U is the
    # slope amplitude the car is driven with: the 250 mm moving average (3 samples of 0.1 m, the difference over
    # 0.3 m) and the slope held over each 0.1 m step (sinc). Wavelengths are no multiple of the step, so the samples
    # of |cos| spread over all phases.
    ds, amplitude = 0.1, 0.005
    s = np.arange(20000) * ds
    z = amplitude * np.sin(2 * np.pi * s / wavelength)
    base = 3 * ds
    slope = amplitude * 2 * abs(math.sin(math.pi * base / wavelength)) / base * np.sinc(ds / wavelength)
    expected = 1000 * 2 / math.pi * golden_car_response(wavelength) * slope
    steady = impl.rectified_slope(z, ds)[2000:]  # after 200 m the start-up transient has died out
    assert 1000 * np.mean(steady) == pytest.approx(expected, rel=5e-3)


def sroubek_profile():
    station, elevation = np.loadtxt(PROFILES / "profile_1.txt", unpack=True)
    start = int(np.flatnonzero(np.isclose(station, 478.5))[0])  # the segmentation starts at 478.5 m
    return elevation[start:], float(station[1] - station[0])


@pytest.mark.parametrize("segment_m", [20, 100])
@pytest.mark.parametrize("method", ["sayers", "sroubeksorel"])
def test_real_profile_matches_the_reference_program_within_one_percent(impl, segment_m, method):
    """One car run over the whole profile from 478.5 m; each segment's IRI is the mean rectified slope of its
    steps, as the reference program (michalsorel/iri, python/iri.py) computes it."""
    z, ds = sroubek_profile()
    reference = np.loadtxt(PROFILES / "reference_iri_computed" / f"profile_1_seg{segment_m}_{method}_start478.5.txt")
    rs = impl.rectified_slope(z, ds)
    steps = int(round(segment_m / ds))
    ours = np.array([1000 * rs[i * steps:(i + 1) * steps].mean() for i in range(len(reference))])
    np.testing.assert_allclose(ours, reference[:, 2], rtol=0.01)
    assert len(reference) == {20: 27, 100: 5}[segment_m]


def test_profile_iri_uses_the_longest_valid_stretch(impl):
    z, ds = sroubek_profile()
    with_gaps = z[:200].copy()
    with_gaps[[30, 120]] = np.nan  # longest stretch: 31 … 119 (89 samples, 22 m)
    result = impl.profile_iri(with_gaps, ds, Config())
    assert result.length == pytest.approx(88 * ds)
    assert result.value == pytest.approx(1000 * np.mean(impl.rectified_slope(z[31:120], ds)), rel=1e-12)
    assert result.reason is None


def test_profile_iri_declines_short_or_empty_profiles(impl):
    short = np.full(400, np.nan)
    short[10:110] = 0.0  # 9.9 m < 11 m
    result = impl.profile_iri(short, 0.1, Config())
    assert result.value is None and result.reason == "valid stretch too short for IRI"
    assert result.length == pytest.approx(9.9)
    assert impl.profile_iri(short, 0.1, Config(iri={"min_length_m": 9.0})).value == pytest.approx(0.0, abs=1e-12)
    empty = impl.profile_iri(np.full(10, np.nan), 0.1, Config())
    assert empty.value is None and empty.reason == "no valid profile"


# ------------------------------------------------------------------------------- the IRI of the bins' errors alone
def _noisy_flat(backed_every: int, spread: float, bins: int = 301):
    count = np.where((np.arange(bins) % backed_every == 0) | (np.arange(bins) == bins - 1), 3, 0)
    return count, np.where(count > 0, spread, np.nan)


def _monte_carlo_iri(count, spread, draws: int = 300, seed: int = 0) -> float:
    """Mean IRI of flat profiles whose backed bins err by their stated σ (the median of 3 points: π/2·s²/3),
    linear between them."""
    from roadpreview.reference import iri as ref
    rng = np.random.default_rng(seed)
    backed = np.flatnonzero(count > 0)
    sigma = np.sqrt(np.pi / 2 * spread[backed] ** 2 / count[backed])
    return float(np.mean([ref.iri(np.interp(np.arange(len(count)), backed, rng.normal(0, sigma)), 0.1)
                          for _ in range(draws)]))


@pytest.mark.parametrize("backed_every", [1, 5])
def test_noise_is_the_iri_of_the_bins_errors_alone(impl, backed_every):
    count, spread = _noisy_flat(backed_every, 0.004)
    noise = impl.noise_iri(count, spread, 0.1)
    assert noise == pytest.approx(_monte_carlo_iri(count, spread), rel=0.04)
    assert impl.noise_iri(count, 2 * spread, 0.1) == pytest.approx(2 * noise, rel=1e-12)
    assert impl.noise_iri(np.ones(301, int), np.full(301, np.nan), 0.1) is None  # single points, nothing to pool


@settings(max_examples=40, deadline=None)
@given(st.integers(12, 400), st.floats(0.05, 0.9), st.integers(0, 2 ** 32 - 1))
def test_cpp_noise_is_the_reference_s(bins, share, seed):
    """Any pattern of backed bins and spreads (1–6 points each, a single point's spread pooled from the others)."""
    import roadpreview as rp
    rng = np.random.default_rng(seed)
    count = np.where(rng.random(bins) < share, rng.integers(1, 7, bins), 0)
    count[0] = count[-1] = 3
    spread = np.where(count >= 2, rng.uniform(0.001, 0.02, bins), np.nan)
    ref = rp.reference.noise_iri(count, spread, 0.1)
    assert rp.native.noise_iri(count, spread, 0.1) == pytest.approx(ref, rel=1e-9)
    assert ref > 0


def test_noise_rising_along_the_stretch_is_overstated_a_little():
    """The errors' power is averaged over the stretch (method.md §6): where it rises fivefold along the stretch, the
    noise errs high by about a tenth, the safe side."""
    from roadpreview.reference import iri as ref
    count, _ = _noisy_flat(3, 0.0)
    spread = np.where(count > 0, np.linspace(0.002, 0.01, len(count)), np.nan)
    ratio = ref.noise_iri(count, spread, 0.1) / _monte_carlo_iri(count, spread)
    assert 1.0 < ratio < 1.2


def test_cpp_noise_agrees_with_the_reference_on_real_profiles():
    """The C++ core's noise (lag sums of the error covariance) and the reference's (FFT of the interpolation matrix)
    on the wheel profiles of the bundled KITTI frames: the same number."""
    import roadpreview as rp
    from paths import KITTI_FRAMES, KITTI_SENSOR_HEIGHT
    from roadpreview.reference import iri as ref
    cfg = rp.Config(sensor_height=KITTI_SENSOR_HEIGHT)
    compared = 0
    for path in KITTI_FRAMES:
        res = rp.Estimator(cfg).process(rp.io.read(path), 5.0, 0.0)
        for p in (res.left, res.right):
            mine = ref.wheel_iri(np.asarray(p.z), np.asarray(p.count), 0.1, p.roughness.iso_class, cfg,
                                 np.asarray(p.spread))
            assert (mine.noise is None) == (p.roughness.iri.noise is None)
            if mine.noise is not None:
                assert p.roughness.iri.noise == pytest.approx(mine.noise, rel=1e-9)
                assert 0 < mine.noise < 10  # m/km: a few, against IRIs of 10–13 on these frames
                compared += 1
        assert res.vehicle.iri.noise == pytest.approx((res.left.roughness.iri.noise + res.right.roughness.iri.noise)
                                                      / 2, rel=1e-12)
    assert compared >= 6
