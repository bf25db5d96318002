"""Repeatability (docs/method.md §9): known answers of the metric — identical and offset copies, a shifted copy,
independent noise — and its errors."""

import math

import numpy as np
import pytest

import roadpreview as rp
from roadpreview.reference.iri import suspension_slope

DS = 0.1
S = np.arange(2000) * DS  # 200 m


def swell(shift_m=0.0, wavelength_m=5.0, amplitude_m=0.01):
    return amplitude_m * np.sin(2 * np.pi * (S + shift_m) / wavelength_m)


def test_identical_profiles_agree_perfectly():
    rep = rp.repeatability(swell(), swell(), DS)
    assert rep.correlation == pytest.approx(1.0, abs=1e-12)
    assert rep.rms_m == pytest.approx(0.0, abs=1e-12) and rep.filtered_rms == pytest.approx(0.0, abs=1e-9)
    assert rep.length_m == pytest.approx(199.9) and rep.reason is None


def test_an_offset_and_a_grade_are_not_disagreement():
    rep = rp.repeatability(swell(), swell() + 0.3 + 0.01 * S, DS)
    assert rep.correlation == pytest.approx(1.0, abs=1e-9)
    assert rep.rms_m == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("shift_m", [0.25, 0.5, 1.25, 2.5])
def test_a_copy_shifted_along_the_road_correlates_as_the_cosine_of_its_phase(shift_m):
    # The quarter car passes a sine as a sine of the same wavelength: shifted by δ, the filtered profiles
    # correlate as cos(2πδ/λ) (up to the first metres of the filter's transient).
    rep = rp.repeatability(swell(), swell(shift_m), DS)
    assert rep.correlation == pytest.approx(math.cos(2 * math.pi * shift_m / 5.0), abs=0.01)


def test_independent_noise_lowers_the_correlation_by_its_share_of_the_filtered_power():
    rng = np.random.default_rng(4)
    road = np.cumsum(rng.normal(0, 0.002, len(S)))  # a random walk: a rough road's n^-2 spectrum
    for sigma in (0.0005, 0.001, 0.002):
        noise_a, noise_b = rng.normal(0, sigma, len(S)), rng.normal(0, sigma, len(S))
        rep = rp.repeatability(road + noise_a, road + noise_b, DS)
        power = [np.sum(suspension_slope(x, DS) ** 2) for x in (road, noise_a, noise_b)]
        expected = power[0] / math.sqrt((power[0] + power[1]) * (power[0] + power[2]))
        assert rep.correlation == pytest.approx(expected, abs=0.02), sigma
        assert rep.rms_m == pytest.approx(sigma * math.sqrt(2), rel=0.1), sigma


def test_only_the_common_stretch_counts():
    a, b = swell(), swell()
    a[:300] = np.nan
    b[1500:] = np.nan
    b[1200] = np.nan  # the longest common run is then bins 300-1199
    rep = rp.repeatability(a, b, DS)
    assert rep.length_m == pytest.approx(89.9) and rep.correlation == pytest.approx(1.0)
    short = rp.repeatability(swell()[:30], swell()[:30], DS)
    assert short.correlation is None and short.reason == "common stretch too short"


def test_bad_input_is_an_error_that_says_what_was_wrong():
    with pytest.raises(ValueError, match="share one grid"):
        rp.repeatability(swell(), swell()[:-1], DS)
    with pytest.raises(ValueError, match="infinite"):
        rp.repeatability(np.full(100, np.inf), swell()[:100], DS)
    with pytest.raises(ValueError, match="1-D"):
        rp.repeatability(np.zeros((10, 2)), np.zeros((10, 2)), DS)
    with pytest.raises(ValueError, match="ds"):
        rp.repeatability(swell(), swell(), 0.0)


def test_world_profile_places_a_later_frames_bins_where_the_road_is():
    s = (np.arange(400) + 0.5) * DS
    grid = np.arange(100, 250) * DS + 0.05
    far = rp.world_profile(s, np.sin(s), 0.0, grid)  # seen from the start
    near = rp.world_profile(s, np.sin(s + 9.0), 9.0, grid)  # the same road from 9 m further on
    np.testing.assert_allclose(near, far, atol=1e-12)
