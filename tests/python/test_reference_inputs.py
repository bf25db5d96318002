"""The numpy reference at its boundary: it takes what the C++ core takes (big-endian points) and refuses, naming
the argument, what the core refuses — where it once crashed, misread the input or broke its fusion state."""

import math

import numpy as np
import pytest

import roadpreview as rp
from roadpreview.config import Config, StereoConfig

ref = rp.reference
NAN, INF = math.nan, math.inf


def road(n=3000, seed=0):
    """Base-frame points of a gently rough road 2–30 m ahead (float32, native byte order)."""
    rng = np.random.default_rng(seed)
    x, y = rng.uniform(2, 30, n), rng.uniform(-4, 4, n)
    return np.column_stack([x, y, 0.02 * np.sin(x) + rng.normal(0, 0.005, n)]).astype(np.float32)


def fused_cfg():
    return Config(obstacles={"enabled": False}, fusion={"method": "kalman"})


# ------------------------------------------------------------------------------------------------ item 1: dtypes
@pytest.mark.parametrize("dtype", [">f4", ">f8"])
def test_big_endian_points_read_as_their_native_order_twins(dtype):
    swapped, native = road().astype(dtype), road().astype(np.dtype(dtype).newbyteorder("="))
    want, got = ref.process(native, 5.0, 0.0), ref.process(swapped, 5.0, 0.0)
    np.testing.assert_array_equal(got.left.z, want.left.z)
    np.testing.assert_array_equal(got.ground_mask, want.ground_mask)
    np.testing.assert_array_equal(ref.to_base_frame(swapped)[0], ref.to_base_frame(native)[0])
    fused = ref.process_fused(ref.FusedMap(fused_cfg()), swapped, 5.0, 0.0, timestamp=0.0)
    np.testing.assert_array_equal(fused.left.z, ref.process_fused(ref.FusedMap(fused_cfg()), native, 5.0, 0.0,
                                                                  timestamp=0.0).left.z)
    sensor = swapped.copy()
    sensor[:, 2] -= 1.7  # the sensor 1.7 m above the road
    assert ref.estimate_mounting(sensor)["height_m"] == pytest.approx(1.7, abs=0.01)


@pytest.mark.parametrize("dtype", ["f2", "i4", "c8", object])
def test_other_dtypes_are_still_refused(dtype):
    with pytest.raises(TypeError, match="points must be float32 or float64"):
        ref.process(road().astype(dtype), 5.0, 0.0)


# ------------------------------------------------------------------------------------------------ item 2: masks
def obstacle_scene():
    """(points, ground mask) of a road with a 0.5 m box on the left wheel's path 10 m ahead."""
    rng = np.random.default_rng(1)
    ground = np.column_stack([rng.uniform(2, 30, 4000), rng.uniform(-4, 4, 4000), rng.normal(0, 0.005, 4000)])
    box = np.column_stack([rng.uniform(10, 10.5, 300), rng.uniform(0.6, 1.0, 300), rng.uniform(0.05, 0.5, 300)])
    return np.vstack([ground, box]), np.arange(4300) < 4000


def test_a_ground_mask_or_labels_not_one_per_point_is_refused_not_broadcast():
    xyz, mask = obstacle_scene()
    plane = [0.0, 0.0, 1.0, 0.0]
    for bad in (mask[:, None], mask[None, :], mask[:-1]):  # (N, 1) once broadcast into N × N
        with pytest.raises(ValueError, match=r"ground_mask must have one entry per point \(4300\)"):
            ref.find_obstacles(xyz, bad, plane)
    obstacles, labels = ref.find_obstacles(xyz, mask, plane)
    assert len(obstacles) == 1
    path = ref.plan_path(5.0, 0.0)
    with pytest.raises(ValueError, match=r"labels must have one entry per point \(4300\), got shape \(4300, 1\)"):
        ref.wheel_obstacles(xyz, labels[:, None], obstacles, plane, path, "left", 5.0, 0.0)


# ------------------------------------------------------------------------------------------------ item 3: fusion
@pytest.mark.parametrize("bad, name", [
    (dict(timestamp=NAN), "timestamp must be finite"),
    (dict(timestamp=INF), "timestamp must be finite"),
    (dict(pose=(NAN, 0.0, 0.0)), "pose must be"),
    (dict(pose=(0.0, 0.0, INF)), "pose must be"),
    (dict(pose=(0.0, 0.0)), "pose must be"),
    (dict(error_groups=np.zeros(3000)), "error_groups must be an integer array"),
    (dict(range_variances=np.full(3000, -1.0)), "range variance of point 0"),  # once refused after the map moved
])
def test_a_bad_fused_frame_is_refused_and_leaves_the_map_as_it_was(bad, name):
    points = road()
    # Frames state their motion as the bad one does; without either, each call moves the map a frame's travel.
    frames = [dict(timestamp=0.1 * k) if "timestamp" in bad else dict(pose=(0.5 * k, 0.0, 0.0)) if "pose" in bad
              else {} for k in range(3)]
    clean, hit = ref.FusedMap(fused_cfg()), ref.FusedMap(fused_cfg())
    for k, frame in enumerate(frames):
        want = ref.process_fused(clean, points, 5.0, 0.0, **frame)
        if k == 1:  # the bad frame comes between two good ones
            with pytest.raises((ValueError, TypeError), match=name):
                ref.process_fused(hit, points, 5.0, 0.0, **{**frame, **bad})
        got = ref.process_fused(hit, points, 5.0, 0.0, **frame)
    for side in ("left", "right"):
        np.testing.assert_array_equal(getattr(got, side).z, getattr(want, side).z)
        np.testing.assert_array_equal(getattr(got, side).spread, getattr(want, side).spread)
    assert got.fusion == want.fusion


# ------------------------------------------------------------------------------------------------ item 4: others
@pytest.mark.parametrize("errors, error, message", [
    (dict(error_groups=np.arange(3000) + 0.5), TypeError, "error_groups must be an integer array, got dtype float64"),
    (dict(error_groups=np.arange(3000) + 2**40), ValueError, "error_groups must fit in int32"),
    (dict(beams=np.arange(3000) % 64 + 0.5), TypeError, "beams must be an integer array, got dtype float64"),
    (dict(beams=np.full(3000, 2**31)), ValueError, "beams must fit in int32"),
])
def test_point_ids_must_be_int32_integers_not_truncated(errors, error, message):
    cfg = Config(profile={"beam_sigma_deg": 0.05})
    with pytest.raises(error, match=message):
        ref.process(road(), 5.0, 0.0, cfg, **errors)


def test_roughness_support_needs_count_and_spread_of_the_profile_s_length():
    z, count, spread = np.sin(np.arange(400) * 0.3) * 0.01, np.full(400, 5), np.full(400, 0.01)
    with pytest.raises(ValueError, match="give both count and spread, or neither"):
        ref.analyze_roughness(z, 0.1, count=count)  # once silently ignored
    with pytest.raises(ValueError, match="give both count and spread, or neither"):
        ref.analyze_roughness(z, 0.1, spread=spread)
    with pytest.raises(ValueError, match=r"count must have one entry per bin of the profile \(400,\), got shape \(100,"):
        ref.analyze_roughness(z, 0.1, count=count[:100], spread=spread)  # once an IndexError or broadcast error
    with pytest.raises(ValueError, match="give both count_left and spread_left"):
        ref.vehicle_roughness(z, z, 0.1, count_left=count)
    with pytest.raises(ValueError, match="spread_right must have one entry per bin"):
        ref.vehicle_roughness(z, z, 0.1, count_left=count, spread_left=spread, count_right=count,
                              spread_right=spread[:10])


def test_fit_plane_names_a_non_finite_point():
    xyz = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [NAN, 0.0, 0.0]]
    with pytest.raises(ValueError, match=r"points_xyz must be finite, got \[nan, 0.0, 0.0\] in row 3"):
        ref.fit_plane(xyz)


def test_blocked_bins_clip_huge_intervals_and_refuse_unpaired_ends():
    last = ref.blocked_bins(1e3, 1e3)
    assert list(np.flatnonzero(last)) == [len(last) - 1]  # beyond the profile: clipped to its last bin
    np.testing.assert_array_equal(ref.blocked_bins(1e308, 1e308), last)  # once an OverflowError
    assert ref.blocked_bins(-1e308, 1e308).all()
    with pytest.raises(ValueError, match="s_start and s_end differ"):
        ref.blocked_bins([1.0, 2.0], [3.0])


@pytest.mark.parametrize("ds", [0.0, -0.1, NAN, INF])
def test_a_bin_length_that_is_not_positive_and_finite_is_refused(ds):
    z, count, spread = np.sin(np.arange(400) * 0.3) * 0.01, np.full(400, 5), np.full(400, 0.01)
    calls = [lambda: ref.displacement_psd(z, ds), lambda: ref.analyze_roughness(z, ds),
             lambda: ref.vehicle_roughness(z, z, ds), lambda: ref.noise_psd(count, spread, ds),
             lambda: ref.resolved_fraction(count, ds, [0.1, 0.2]), lambda: ref.rectified_slope(z, ds),
             lambda: ref.profile_iri(z, ds), lambda: ref.noise_iri(count, spread, ds)]
    for call in calls:  # a negative ds once gave negative PSDs, 0 a ZeroDivisionError
        with pytest.raises(ValueError, match="ds must be finite and > 0 m"):
            call()


# ------------------------------------------------------------------------------------------------ item 5: stereo
def test_an_infinite_disparity_is_invalid_not_a_point_at_the_camera():
    calib = {"fx": 700.0, "fy": 700.0, "cx": 2.0, "cy": 2.0, "baseline": 0.5}
    d = np.full((4, 4), 50.0)
    d[2, 1], d[3, 3], d[0, 0] = INF, NAN, -INF
    points, variances, pixels = ref.stereo.disparity_to_points(d, 0, calib, StereoConfig())
    assert sorted(set(range(16)) - set(pixels)) == [0, 9, 15]
    assert np.isfinite(variances).all() and (points[:, 0] == pytest.approx(7.0))  # fx·B/d = 350/50


@pytest.mark.parametrize("impl", [rp.native, rp.reference], ids=["cpp", "reference"])
def test_a_profile_without_a_valid_bin_needs_no_spacing(impl):
    """An empty or all-NaN profile has no stretch to rate whatever its spacing: both implementations say so (the
    reference once refused ds = 0 first, where the core reads the profile first)."""
    for z in (np.full(10, np.nan), np.zeros(0)):
        assert impl.analyze_roughness(z, 0.0, rp.Config()).reason == "no valid profile"
        assert impl.profile_iri(z, 0.0).reason == "no valid profile"
    with pytest.raises(ValueError, match="ds"):
        impl.analyze_roughness(np.zeros(200), 0.0, rp.Config())
