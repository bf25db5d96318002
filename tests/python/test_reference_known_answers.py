"""Known-answer tests of docs/method.md, run on every implementation in conftest.IMPLEMENTATIONS."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from roadpreview.config import Config, Extrinsics

DS = 0.1


def point_atol(impl, magnitude_m=20.0):
    """Absolute tolerance for geometry computed from points: exact to 1e-9 in double precision; the C++
    core reads points as float32, which rounds coordinates of this magnitude by up to ~1e-6 m."""
    return 1e-9 if impl.POINT_DTYPE == np.float64 else 1e-7 * magnitude_m
HALF_TIRE = 0.15  # default tire_width / 2
ISO_MEANS_E6 = [16, 64, 256, 1024, 4096, 16384, 65536, 262144]  # ISO 8608 geometric means, 10⁻⁶ m³
ISO_LIMITS_E6 = [32, 128, 512, 2048, 8192, 32768, 131072]


# ---------------------------------------------------------------------------------------------- helpers
def tilted_plane(pitch_deg=3.0, roll_deg=2.0, z0=0.3):
    """Plane z = x·tan(pitch) + y·tan(roll) + z0 as (a, b, c, d) with unit normal, c > 0."""
    tp, tr = math.tan(math.radians(pitch_deg)), math.tan(math.radians(roll_deg))
    return np.array([-tp, -tr, 1.0, -z0]) / math.sqrt(1 + tp * tp + tr * tr)


def points_on_plane(plane, x, y, above=0.0):
    """Points at (x, y) on the plane, moved ``above`` metres along its normal."""
    a, b, c, d = plane
    z = -(a * x + b * y + d) / c
    return np.column_stack([x, y, z]) + above * np.asarray(plane[:3])


def grid(x_range, y_range, step):
    x, y = np.meshgrid(np.arange(*x_range, step), np.arange(*y_range, step))
    return x.ravel(), y.ravel()


def iso_profile(gd_n0, seed, waviness=2.0, count=1000, ds=DS):
    """Gaussian profile whose one-sided PSD is G_d(n) = gd_n0·(n/0.1)^−w: random Fourier coefficients with
    E|Y_k|² = G_d(n_k)·N/(2Δ), so that the plain periodogram 2|Y_k|²Δ/N has expectation G_d(n_k)."""
    rng = np.random.default_rng(seed)
    n = np.arange(count // 2 + 1) / (count * ds)
    psd = np.zeros_like(n)
    psd[1:-1] = gd_n0 * (n[1:-1] / 0.1) ** -waviness
    coeffs = rng.standard_normal(len(n)) + 1j * rng.standard_normal(len(n))
    return np.fft.irfft(np.sqrt(psd * count / (2 * ds)) * coeffs / np.sqrt(2), n=count)


def on_wheel_circle(path, y_wheel, s, yaw_rate):
    """Point reached after the wheel (at (0, y_wheel)) has rotated s/r about the ICR in the sense of ω."""
    icr = path["icr_y"]
    w0y = y_wheel - icr
    angle = math.copysign(1.0, yaw_rate) * s / abs(w0y)
    return np.array([-math.sin(angle) * w0y, icr + math.cos(angle) * w0y])


def profile_of(impl, xy, z, speed, yaw_rate, wheel="left", cfg=None, plane=None):
    cfg = cfg or Config()
    xyz = np.column_stack([np.asarray(xy, float).reshape(-1, 2), z])
    path = impl.plan_path(speed, yaw_rate, cfg)
    return impl.wheel_profile(xyz, plane, path, wheel, speed, yaw_rate, cfg)


# ---------------------------------------------------------------------------------------------- §0 frames
def test_extrinsics_rotation_order_and_translation(impl):
    # R = Rz(90°)·Ry(90°)·Rx(90°) maps x → −z, y → y, z → x (another order, e.g. Rx·Ry·Rz, maps x → z).
    cfg = Config(extrinsics=Extrinsics(x_m=1.0, y_m=2.0, z_m=3.0, roll_rad=math.pi / 2,
                                       pitch_rad=math.pi / 2, yaw_rad=math.pi / 2))
    base, finite = impl.to_base_frame(np.eye(3), cfg)
    expected = np.array([[0, 0, -1], [0, 1, 0], [1, 0, 0]]) + [1.0, 2.0, 3.0]
    np.testing.assert_allclose(base, expected, atol=1e-12)
    assert finite.tolist() == [True, True, True]


@pytest.mark.parametrize("angles, point, expected", [
    ((0.0, 0.0, math.pi / 2), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),  # yaw left: forward becomes left
    ((math.pi / 2, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),  # roll: left becomes up
    ((0.0, 0.1, 0.0), (1.0, 0.0, 0.0), (math.cos(0.1), 0.0, -math.sin(0.1))),  # positive pitch looks down
])
def test_extrinsics_single_axes(impl, angles, point, expected):
    roll, pitch, yaw = angles
    cfg = Config(extrinsics=Extrinsics(roll_rad=roll, pitch_rad=pitch, yaw_rad=yaw))
    base, _ = impl.to_base_frame(np.array([point]), cfg)
    np.testing.assert_allclose(base[0], expected, atol=1e-12)


def test_sensor_height_shortcut_and_no_pose(impl):
    points = np.array([[5.0, 1.0, -1.75]])  # exact in float32 too
    shifted, _ = impl.to_base_frame(points, Config(sensor_height=1.75))
    np.testing.assert_allclose(shifted, [[5.0, 1.0, 0.0]], atol=1e-12)
    unchanged, _ = impl.to_base_frame(points, Config())
    np.testing.assert_array_equal(unchanged, points)


def test_sensor_height_and_extrinsics_together_is_an_error(impl):
    cfg = Config(sensor_height=1.7, extrinsics=Extrinsics(z_m=1.7))
    with pytest.raises(ValueError):
        impl.to_base_frame(np.zeros((1, 3)), cfg)
    with pytest.raises(ValueError):
        impl.process(np.zeros((1, 3)), 10.0, 0.0, cfg)


def test_non_finite_rows_dropped_in_order_and_extra_columns_ignored(impl):
    points = np.array([[1, 2, 3, 99], [np.nan, 0, 0, 0], [4, 5, np.inf, 0], [6, 7, 8, np.nan]], np.float32)
    base, finite = impl.to_base_frame(points, Config())
    assert finite.tolist() == [True, False, False, True]
    np.testing.assert_array_equal(base, [[1, 2, 3], [6, 7, 8]])
    assert base.dtype == np.float64


# ---------------------------------------------------------------------------------------------- §1 ground
def test_fit_plane_is_exact_on_a_tilted_plane(impl):
    plane = tilted_plane()
    x, y = grid((2, 30), (-5, 5), 0.5)
    np.testing.assert_allclose(impl.fit_plane(points_on_plane(plane, x, y)), plane, rtol=0, atol=1e-9)


@pytest.mark.parametrize("seed", range(5))
def test_fit_plane_reports_a_downward_normal_with_c_positive(impl, seed):
    rng = np.random.default_rng(seed)
    normal = rng.normal(size=3)
    normal[2] = -abs(normal[2]) - 0.5  # written with the normal pointing down
    down = np.append(normal, 0.7) / np.linalg.norm(normal)
    points = points_on_plane(down, rng.uniform(-20, 20, 200), rng.uniform(-20, 20, 200))
    fitted = impl.fit_plane(points)
    assert fitted[2] > 0
    np.testing.assert_allclose(fitted, -down, atol=point_atol(impl))


def ground_scene(plane, extra_heights=()):
    """Tilted ground grid inside the ROI, boxes 0.5–2 m above it, ground points outside the ROI,
    and for each h in extra_heights ten points h metres above the plane (label f"{h:+}").
    Returns (xyz, labels)."""
    x, y = grid((2, 30), (-6, 6), 0.5)
    parts = [(points_on_plane(plane, x, y), "ground")]
    bx, by = grid((10, 12), (-1, 1), 0.25)
    for height in (0.5, 1.0, 2.0):
        parts.append((points_on_plane(plane, bx, by, above=height), "obstacle"))
    outside_x = np.array([0.5, 41.0, 20.0, 20.0])
    outside_y = np.array([0.0, 0.0, 10.5, -10.5])
    parts.append((points_on_plane(plane, outside_x, outside_y), "outside"))
    for height in extra_heights:
        marked = points_on_plane(plane, np.linspace(5, 25, 10), np.full(10, 2.0), above=height)
        parts.append((marked, f"{height:+}"))
    xyz = np.vstack([p for p, _ in parts])
    labels = np.concatenate([[label] * len(p) for p, label in parts])
    return xyz, labels


@pytest.mark.parametrize("method", ["pca", "ransac"])
def test_ground_drops_obstacles_and_finds_the_exact_plane(impl, method):
    plane = tilted_plane()
    xyz, labels = ground_scene(plane)
    mask, fitted = impl.fit_ground(xyz, Config(ground={"method": method}))
    np.testing.assert_allclose(fitted, plane, rtol=0, atol=point_atol(impl))
    np.testing.assert_array_equal(mask, labels == "ground")


def test_pca_ground_threshold_is_one_sided(impl):
    # 0.1 above: kept; 0.3 above: dropped; 0.5 below: kept (never an obstacle above the road).
    xyz, labels = ground_scene(tilted_plane(), extra_heights=(0.1, 0.3, -0.5))
    mask, _ = impl.fit_ground(xyz, Config(ground={"method": "pca"}))
    expected = (labels == "ground") | (labels == "+0.1") | (labels == "-0.5")
    np.testing.assert_array_equal(mask, expected)


def test_ransac_ground_threshold_is_two_sided(impl):
    xyz, labels = ground_scene(tilted_plane(), extra_heights=(0.1, 0.3, -0.5))
    mask, _ = impl.fit_ground(xyz, Config(ground={"method": "ransac"}))
    np.testing.assert_array_equal(mask, (labels == "ground") | (labels == "+0.1"))


def test_ransac_rejects_planes_tilted_beyond_the_limit(impl):
    # A 40° ramp rising from y = 1 holds twice as many points as the level ground; the tilt limit (15°)
    # rules it out, and a plane within the limit cuts only a narrow strip of the ramp.
    x, y = grid((2, 30), (-6, 0), 0.25)
    ground = points_on_plane(np.array([0.0, 0.0, 1.0, 0.0]), x, y)
    rx, ry = grid((2, 30), (1, 7), 0.25)
    rx = np.concatenate([rx, rx + 0.125])
    ry = np.concatenate([ry, ry])
    ramp = points_on_plane(tilted_plane(pitch_deg=0, roll_deg=40, z0=-math.tan(math.radians(40))), rx, ry)
    xyz = np.vstack([ground, ramp])
    # RANSAC may prefer a plane tilted by ~1° that also takes the ramp's first rows (more inliers than the
    # level plane), so this checks properties, not the exact plane.
    mask, fitted = impl.fit_ground(xyz, Config(ground={"method": "ransac"}))
    assert fitted[2] > math.cos(math.radians(3))
    assert mask[: len(ground)].all()
    assert mask[len(ground):].sum() <= 0.1 * len(ramp)


@pytest.mark.parametrize("method", ["pca", "ransac"])
def test_no_ground_when_too_few_or_collinear_roi_points(impl, method):
    cfg = Config(ground={"method": method})
    two_points = np.array([[5.0, 0, 0], [6.0, 0, 0], [50.0, 0, 0]])  # the third is outside the ROI
    collinear = np.column_stack([np.linspace(2, 30, 50), np.zeros(50), np.zeros(50)])
    for xyz in (two_points, collinear):
        mask, plane = impl.fit_ground(xyz, cfg)
        assert plane is None
        assert not np.any(mask) and len(mask) == len(xyz)


# ---------------------------------------------------------------------------------------------- §2 paths
@pytest.mark.parametrize("speed, yaw_rate, icr_y, left_radius, right_radius", [
    (10.0, 0.5, 20.0, 19.2, 20.8),  # left turn: centre on the left, left wheel inside
    (10.0, -0.5, -20.0, 20.8, 19.2),  # right turn
    (-10.0, 0.5, -20.0, 20.8, 19.2),  # reversing while rotating counter-clockwise: centre on the right
    (5.0, 0.005, 1000.0, 999.2, 1000.8),  # |V/ω| = straight_radius_m is still an arc
])
def test_arc_paths(impl, speed, yaw_rate, icr_y, left_radius, right_radius):
    path = impl.plan_path(speed, yaw_rate, Config())
    assert path["status"] == "arc"
    assert path["icr_y"] == pytest.approx(icr_y, rel=1e-12)
    assert path["left_radius"] == pytest.approx(left_radius, rel=1e-12)
    assert path["right_radius"] == pytest.approx(right_radius, rel=1e-12)


@pytest.mark.parametrize("speed, yaw_rate", [(10.0, 0.0), (10.0, 0.001), (-3.0, -0.0001), (-3.0, 0.0)])
def test_straight_paths(impl, speed, yaw_rate):
    path = impl.plan_path(speed, yaw_rate, Config())
    assert path == {"status": "straight", "icr_y": None, "left_radius": None, "right_radius": None}


@pytest.mark.parametrize("speed, yaw_rate, stopped_speed", [
    (0.0, 0.3, 0.0), (0.0, 0.0, 0.0), (-0.0, 1.0, 0.0), (0.5, 0.1, 0.5), (-0.4, 0.0, 0.5),
])
def test_stopped_vehicle(impl, speed, yaw_rate, stopped_speed):
    cfg = Config(path={"stopped_speed_mps": stopped_speed})
    with np.errstate(all="raise"):  # no division by zero on the way
        path = impl.plan_path(speed, yaw_rate, cfg)
    assert path == {"status": "stopped", "icr_y": None, "left_radius": None, "right_radius": None}


@pytest.mark.parametrize("speed, yaw_rate",
                         [(math.nan, 0.0), (10.0, math.nan), (math.inf, 0.1), (1.0, -math.inf)])
def test_non_finite_motion_is_an_error(impl, speed, yaw_rate):
    with pytest.raises(ValueError):
        impl.plan_path(speed, yaw_rate, Config())
    with pytest.raises(ValueError):
        impl.process(np.zeros((5, 3)), speed, yaw_rate, Config())


# ---------------------------------------------------------------------------------------------- §3 profiles
@pytest.mark.parametrize("speed, yaw_rate, wheel", [
    (10.0, 0.5, "left"), (10.0, 0.5, "right"), (10.0, -0.5, "left"), (10.0, -0.5, "right"),
    (-10.0, 0.5, "left"), (-10.0, -0.5, "right"), (3.0, 0.4, "left"),
])
def test_arc_length_on_the_wheel_circle_is_angle_times_radius(impl, speed, yaw_rate, wheel):
    # A point at s = k·ds ± 1e-6 must land in bin k (resp. k − 1): s is checked to 1e-6.
    cfg = Config()
    path = impl.plan_path(speed, yaw_rate, cfg)
    y_wheel = 0.8 if wheel == "left" else -0.8
    half_turn = math.pi * path[f"{wheel}_radius"]  # only half a turn can be previewed
    bins = [k for k in (1, 50, 123, 399) if k * DS < half_turn]
    xy, z = [], []
    for k in bins:
        for offset, height in ((1e-6, k), (-1e-6, -k)):
            xy.append(on_wheel_circle(path, y_wheel, k * DS + offset, yaw_rate))
            z.append(height)
    for s_outside in (-0.05, 40.0 + 1e-6):  # behind the wheel, beyond the preview length
        xy.append(on_wheel_circle(path, y_wheel, s_outside, yaw_rate))
        z.append(1000.0)
    # The same points mirrored across the axle line (x → −x, on the same circle): where the vehicle does not go,
    # behind it driving forward and ahead of it reversing (which looks behind), so in no bin.
    xy += [p * [-1.0, 1.0] for p in xy[:2 * len(bins)]]
    z += [1000.0] * (2 * len(bins))
    profile = profile_of(impl, xy, z, speed, yaw_rate, wheel, cfg)
    expected_count = np.zeros(400, np.int64)
    for k in bins:
        expected_count[[k, k - 1]] = 1
        assert profile.z[k] == k and profile.z[k - 1] == -k
    np.testing.assert_array_equal(profile.count, expected_count)


@pytest.mark.parametrize("yaw_rate", [0.0, 0.5])
def test_points_just_outside_the_tire_half_width_are_excluded(impl, yaw_rate):
    cfg = Config()
    path = impl.plan_path(10.0, yaw_rate, cfg)
    offsets = [HALF_TIRE - 1e-6, -(HALF_TIRE - 1e-6), HALF_TIRE + 1e-6, -(HALF_TIRE + 1e-6)]
    s_values = [5.05, 10.05, 15.05, 20.05]  # bins 50, 100, 150, 200
    if path["status"] == "straight":
        xy = [(s, 0.8 + off) for s, off in zip(s_values, offsets)]
    else:  # move the point radially from the ICR by the offset
        xy = []
        for s, off in zip(s_values, offsets):
            on_circle = on_wheel_circle(path, 0.8, s, yaw_rate)
            radial = (on_circle - [0, path["icr_y"]]) / path["left_radius"]
            xy.append(on_circle + off * radial)
    profile = profile_of(impl, xy, np.zeros(4), 10.0, yaw_rate, "left", cfg)
    assert profile.count[[50, 100, 150, 200]].tolist() == [1, 1, 0, 0]


def test_straight_reverse_looks_behind(impl):
    xy = [(-5.05, 0.8), (5.05, 0.8), (-12.05, -0.8), (12.05, -0.8)]
    z = [1.0, 2.0, 3.0, 4.0]
    left = profile_of(impl, xy, z, -2.0, 0.0, "left")
    right = profile_of(impl, xy, z, -2.0, 0.0, "right")
    assert np.flatnonzero(left.count).tolist() == [50] and left.z[50] == 1.0
    assert np.flatnonzero(right.count).tolist() == [120] and right.z[120] == 3.0


def test_bins_hold_the_median_and_cover_zero_to_preview_length(impl):
    # bin 3: mean of the two middle values; bin 7: middle value; s = 0 is kept, s = 40 and s < 0 are not.
    x = [0.31, 0.32, 0.33, 0.34, 0.71, 0.72, 0.73, 0.0, 39.99, 40.0, -0.01]
    z = [1.0, 5.0, 2.0, 4.0, 1.0, 9.0, 2.0, 7.0, 8.0, 100.0, 100.0]
    profile = profile_of(impl, np.column_stack([x, np.full(len(x), 0.8)]), z, 10.0, 0.0)
    np.testing.assert_allclose(profile.s, (np.arange(400) + 0.5) * DS, rtol=1e-12)
    assert np.flatnonzero(profile.count).tolist() == [0, 3, 7, 399]
    assert profile.count[[0, 3, 7, 399]].tolist() == [1, 4, 3, 1]
    assert profile.z[[0, 3, 7, 399]].tolist() == [7.0, 3.0, 2.0, 8.0]


def test_s_just_below_the_preview_length_goes_to_the_last_bin(impl):
    # preview 0.9 m, ds 0.3 m (K = 3): floor(s/ds) rounds to K for the largest s < 0.9; the point is kept
    # (s < preview_length_m), so it belongs to bin K − 1.
    cfg = Config(profile={"preview_length_m": 0.9, "ds_m": 0.3})
    s = np.nextafter(0.9, 0.0)
    assert math.floor(s / 0.3) == 3
    profile = profile_of(impl, [(s, 0.8)], [1.0], 10.0, 0.0, cfg=cfg)
    assert profile.count.tolist() == [0, 0, 1] and profile.z[2] == 1.0


def test_a_wheel_pivoting_on_the_icr_has_no_profile_points(impl):
    path = impl.plan_path(0.8, 1.0, Config())  # ICR exactly under the left wheel: r_L = 0
    assert path["status"] == "arc" and path["left_radius"] == 0.0
    profile = profile_of(impl, [(0.05, 0.8), (0.0, 0.9), (1.0, 0.8)], [1.0, 2.0, 3.0], 0.8, 1.0)
    assert profile.count.sum() == 0 and np.isnan(profile.z).all()


def test_bin_count_rounds_up_a_partial_last_bin(impl):
    cfg = Config(profile={"preview_length_m": 10.0, "ds_m": 0.3})  # 33.3 bins → 34
    profile = profile_of(impl, [(9.95, 0.8)], [1.0], 10.0, 0.0, cfg=cfg)
    assert len(profile.z) == len(profile.s) == len(profile.count) == 34
    assert profile.count[33] == 1


@pytest.mark.parametrize("offset", [0.0, 0.2])
def test_levelling_flattens_a_pitched_ground(impl, offset):
    pitch = math.radians(2.0)
    plane = tilted_plane(pitch_deg=2.0, roll_deg=0.0, z0=offset)
    x, y = grid((0.5, 40), (0.7, 0.95), 0.05)  # a strip along the left wheel path
    xyz = points_on_plane(plane, x, y)
    path = impl.plan_path(10.0, 0.0, Config())
    levelled = impl.wheel_profile(xyz, impl.fit_plane(xyz), path, "left", 10.0, 0.0, Config())
    one_plane = impl.wheel_profile(xyz, impl.fit_plane(xyz), path, "left", 10.0, 0.0,
                                   Config(profile={"level_local": False}))
    raw = impl.wheel_profile(xyz, plane, path, "left", 10.0, 0.0, Config(profile={"level": False}))
    valid = ~np.isnan(levelled.z)
    assert valid.sum() > 380
    # Levelled locally the road reads 0 (its height above its band's plane); with one plane, the plane becomes
    # z' = −d. 1 µm leaves room for float32 point storage (§3 does not demand doubles).
    np.testing.assert_allclose(levelled.z[valid], 0.0, atol=1e-6)
    np.testing.assert_allclose(one_plane.z[valid], -plane[3], atol=1e-6)
    slope = np.polyfit(raw.s[~np.isnan(raw.z)], raw.z[~np.isnan(raw.z)], 1)[0]
    assert slope == pytest.approx(math.tan(pitch), rel=1e-3)
    assert levelled.roughness.iso_class == "A"  # the profile comes with its roughness: flat is class A
    assert levelled.roughness.gd_n0 < 1e-9


def test_level_points_takes_the_normal_onto_up(impl):
    plane = tilted_plane()
    rng = np.random.default_rng(3)
    xyz = rng.uniform(-20, 20, (50, 3))
    levelled = impl.level_points(xyz, plane)
    # Tolerances allow float32 storage of the points (§3 does not demand double precision).
    np.testing.assert_allclose(levelled[:, 2], xyz @ plane[:3], atol=1e-5)  # z' = n·p
    np.testing.assert_allclose(np.linalg.norm(levelled, axis=1), np.linalg.norm(xyz, axis=1), rtol=1e-6)
    np.testing.assert_allclose(impl.level_points(plane[None, :3], plane), [[0, 0, 1]], atol=1e-7)
    as_read = xyz.astype(impl.POINT_DTYPE).astype(np.float64)  # what the implementation works on
    np.testing.assert_array_equal(impl.level_points(xyz, np.array([0.0, 0, 1, 0])), as_read)


def test_fill_gaps(impl):
    nan = math.nan
    z = np.array([nan, nan, 0.0, nan, nan, 3.0] + [nan] * 10 + [5.0] + [nan] * 11 + [1.0, nan])
    filled = impl.fill_gaps(z, 0.1, 1.0)
    np.testing.assert_allclose(filled[:6], [nan, nan, 0, 1, 2, 3], equal_nan=True, atol=1e-12)
    np.testing.assert_allclose(filled[6:16], 3.0 + 2.0 * np.arange(1, 11) / 11, atol=1e-12)  # 1.0 m: filled
    assert np.isnan(filled[17:28]).all()  # 1.1 m: too long
    assert filled[28] == 1.0 and np.isnan(filled[29])  # trailing run stays missing
    assert np.isnan(z[3])  # the input is not modified


def test_fill_gaps_compares_the_gap_length_with_a_rounding_tolerance(impl):
    # 3 bins × 0.1 m is 0.30000000000000004 in floating point; it still counts as a 0.3 m gap.
    filled = impl.fill_gaps(np.array([0.0, math.nan, math.nan, math.nan, 4.0]), 0.1, 0.3)
    np.testing.assert_allclose(filled, [0, 1, 2, 3, 4], atol=1e-12)
    assert np.isnan(impl.fill_gaps(np.array([0.0, math.nan, math.nan, math.nan, 4.0]), 0.1, 0.29)[2])


def test_filled_bins_keep_count_zero(impl):
    xy = [(0.55, 0.8), (0.95, 0.8)]  # bins 5 and 9
    profile = profile_of(impl, xy, [1.0, 2.0], 10.0, 0.0)
    np.testing.assert_allclose(profile.z[5:10], [1.0, 1.25, 1.5, 1.75, 2.0], atol=1e-12)
    assert profile.count[5:10].tolist() == [1, 0, 0, 0, 1]
    assert np.isnan(profile.z[:5]).all() and np.isnan(profile.z[10:]).all()


def test_longest_valid_stretch(impl):
    nan = math.nan
    assert tuple(impl.longest_valid_stretch([nan, 1, 2, nan, 3, 4, nan, 5])) == (1, 3)  # first on ties
    assert tuple(impl.longest_valid_stretch([1, nan, 2, 3, 4])) == (2, 5)
    assert tuple(impl.longest_valid_stretch([1.0, 2.0])) == (0, 2)
    start, stop = impl.longest_valid_stretch([nan, nan])
    assert stop - start == 0


# ---------------------------------------------------------------------------------------------- §4 PSD
def test_psd_of_a_four_sample_stretch_by_hand(impl):
    # x = [1,−1,1,−1], Δ = 0.5: line −0.4·(j − 1.5), detrended [0.4,−1.2,1.2,−0.4], Hann [0,½,1,½],
    # U = 3/8, X = [0.4, −1.2+0.4i, 2.0], G = c|X|²·Δ/(N·U) = c|X|²/3.
    n, psd = impl.displacement_psd(np.array([1.0, -1.0, 1.0, -1.0]), 0.5)
    np.testing.assert_allclose(n, [0.0, 0.5, 1.0], rtol=1e-12)
    np.testing.assert_allclose(psd, [0.16 / 3, 2 * 1.6 / 3, 4.0 / 3], rtol=1e-12)


@pytest.mark.parametrize("frequency", [1.0, 0.37, 1.234, 3.5])
def test_sine_psd_peak_and_power(impl, frequency):
    amplitude = 0.01
    s = np.arange(1000) * DS
    n, psd = impl.displacement_psd(amplitude * np.sin(2 * np.pi * frequency * s + 0.3), DS)
    peak = int(np.argmax(psd))
    assert abs(n[peak] - frequency) <= (n[1] - n[0]) / 2
    power = psd[peak - 3: peak + 4].sum() * (n[1] - n[0])
    assert power == pytest.approx(amplitude**2 / 2, rel=0.01)


@settings(max_examples=60, deadline=None)
@given(count=st.integers(2, 400), ds=st.floats(0.01, 1.0), scale=st.floats(1e-4, 10.0),
       seed=st.integers(0, 2**32 - 1))
def test_parseval(impl, count, ds, scale, seed):
    x = scale * np.random.default_rng(seed).standard_normal(count)
    n, psd = impl.displacement_psd(x, ds)
    j = np.arange(count)
    detrended = x - np.polyval(np.polyfit(j, x, 1), j)
    window = 0.5 * (1 - np.cos(2 * np.pi * j / count))
    expected = np.mean((detrended * window) ** 2) / np.mean(window**2)
    assert len(n) == count // 2 + 1 and n[0] == 0
    assert np.sum(psd) * n[1] == pytest.approx(expected, rel=1e-10)


# ---------------------------------------------------------------------------------------------- §4 classes
def test_iso_constants(impl):
    assert impl.ISO_CLASSES == "ABCDEFGH"
    np.testing.assert_allclose(impl.ISO_GEOMETRIC_MEANS, np.array(ISO_MEANS_E6) * 1e-6, rtol=1e-15)


@pytest.mark.parametrize("index, limit_e6", list(enumerate(ISO_LIMITS_E6)))
def test_class_boundaries(impl, index, limit_e6):
    limit = limit_e6 * 1e-6
    smoother, rougher = "ABCDEFGH"[index], "ABCDEFGH"[index + 1]
    assert impl.iso_class(np.nextafter(limit, 0)) == smoother
    assert impl.iso_class(limit * (1 - 1e-9)) == smoother
    assert impl.iso_class(limit) == rougher  # exactly on a limit: the rougher class
    assert impl.iso_class(limit * (1 + 1e-9)) == rougher


def test_class_extremes(impl):
    assert impl.iso_class(0.0) == "A"
    assert impl.iso_class(1.0) == "H"


# Tolerance: the w = 2 estimate averages ~390 band ordinates (0.1–4 cycles/m over 100 m), each with
# ln-scatter π/√6 ≈ 1.28, so ln(estimate) has a standard deviation of ≈ 0.065. The class limits are a
# factor 2 (ln 2 ≈ 0.69 > 10 σ) from each geometric mean, so the exact class is required for every seed;
# gd_n0 must be within a factor 1.5 (ln 1.5 ≈ 0.41 ≈ 6 σ) of the truth.
@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("cls, mean_e6", list(zip("ABCDEFGH", ISO_MEANS_E6)))
def test_iso8608_synthetic_profiles_are_classified(impl, cls, mean_e6, seed):
    truth = mean_e6 * 1e-6
    result = impl.analyze_roughness(iso_profile(truth, seed), DS, Config())
    assert result.reason is None
    assert result.iso_class == cls
    assert 1 / 1.5 < result.gd_n0 / truth < 1.5
    assert result.band == pytest.approx((0.1, 4.0))
    assert result.waviness == pytest.approx(2.0, abs=0.4)


@pytest.mark.parametrize("seed", range(3))
def test_free_fit_recovers_the_waviness(impl, seed):
    truth = 1024e-6
    result = impl.analyze_roughness(iso_profile(truth, seed, waviness=3.0), DS, Config())
    assert result.waviness == pytest.approx(3.0, abs=0.3)
    assert 1 / 1.5 < result.gd_n0_free / truth < 1.5
    assert result.gd_n0 < truth / 4  # the w = 2 fit misreads a steeper spectrum


def test_too_short_stretch_has_no_class(impl):
    z = np.full(200, np.nan)
    z[10:59] = iso_profile(256e-6, 0, count=49)  # 4.9 m < min_length_m = 5
    result = impl.analyze_roughness(z, DS, Config())
    assert result.iso_class is None and result.gd_n0 is None
    assert result.reason == "valid stretch too short"
    z[100:150] = iso_profile(256e-6, 1, count=50)  # 5.0 m: analysed, band from 2 cycles / 5 m = 0.4
    result = impl.analyze_roughness(z, DS, Config())
    assert result.iso_class is not None and result.reason is None
    assert result.band == pytest.approx((0.4, 4.0))
    assert len(result.n) == len(result.psd) == 26


def test_all_nan_profile_has_a_reason(impl):
    result = impl.analyze_roughness(np.full(400, np.nan), DS, Config())
    assert result.iso_class is None and result.reason == "no valid profile"
    assert len(result.psd) == 0


def test_too_few_ordinates_in_band(impl):
    cfg = Config(roughness={"band_min_cpm": 3.0, "band_max_cpm": 3.35})  # 100 m: n = 3.00, 3.01, …, 3.35
    result = impl.analyze_roughness(iso_profile(256e-6, 0), DS, cfg)
    assert result.band == pytest.approx((3.0, 3.35))
    assert result.iso_class is not None
    cfg = Config(roughness={"band_min_cpm": 3.0, "band_max_cpm": 3.035, "min_band_points": 5})  # 4 ordinates
    result = impl.analyze_roughness(iso_profile(256e-6, 0), DS, cfg)
    assert result.iso_class is None and result.reason == "too few PSD ordinates in band"
    assert result.band is None and result.gd_n0 is None and len(result.psd) > 0  # the PSD is still given


def test_band_edges_are_inclusive_and_the_fit_is_the_bias_corrected_log_mean(impl):
    # Dyadic numbers make the edges exact: 64 m at 0.125 m, Δn = 1/64, band [8/64, 12/64] holds k = 8 … 12.
    cfg = Config(roughness={"band_min_cpm": 0.125, "band_max_cpm": 0.1875, "min_band_points": 5})
    result = impl.analyze_roughness(iso_profile(256e-6, 2, count=512, ds=0.125), 0.125, cfg)
    assert result.reason is None and result.band == (0.125, 0.1875)
    n, psd = np.asarray(result.n)[8:13], np.asarray(result.psd)[8:13]
    expected = math.exp(np.mean(np.log(psd) + 2 * np.log(n / 0.1)) + 0.5772156649015329)
    assert result.gd_n0 == pytest.approx(expected, rel=1e-9)


def test_band_is_clipped_to_nyquist(impl):
    result = impl.analyze_roughness(iso_profile(256e-6, 0, count=500, ds=0.2), 0.2, Config())
    assert result.band == pytest.approx((0.1, 2.5))


def test_perfectly_flat_profile_is_class_a(impl):
    result = impl.analyze_roughness(np.zeros(400), DS, Config())
    assert result.iso_class == "A" and result.gd_n0 == 0.0


def test_octave_bands(impl):
    # 10 m at 0.1 m: n = 0, 0.1, …, 5; the bands centred below 0.125 hold no ordinate and are omitted.
    result = impl.analyze_roughness(iso_profile(256e-6, 0, count=100), DS, Config())
    np.testing.assert_allclose(result.octave_centers, [0.125, 0.25, 0.5, 1, 2, 4], rtol=1e-12)
    psd, n = np.asarray(result.psd), np.asarray(result.n)
    assert result.octave_gd[0] == pytest.approx(psd[1])  # 0.0884 ≤ n < 0.177: only n = 0.1
    assert result.octave_gd[1] == pytest.approx(psd[2:4].mean())  # n = 0.2, 0.3
    assert result.octave_gd[5] == pytest.approx(psd[29:].mean())  # 2.83 ≤ n < 5.66: n = 2.9 … 5 (Nyquist)
    assert n[29] == pytest.approx(2.9) and n[-1] == pytest.approx(5.0)


def test_vehicle_averages_the_two_psds_over_the_common_stretch(impl):
    z = iso_profile(256e-6, 4, count=400)
    left, right = z.copy(), 2 * z  # the right PSD is 4× the left one
    left[:50] = np.nan
    right[300:] = np.nan
    vehicle = impl.vehicle_roughness(left, right, DS, Config())
    alone = impl.analyze_roughness(z[50:300], DS, Config())
    np.testing.assert_allclose(vehicle.psd, 2.5 * np.asarray(alone.psd), rtol=1e-12)
    assert vehicle.gd_n0 == pytest.approx(2.5 * alone.gd_n0, rel=1e-12)
    assert vehicle.band == pytest.approx(alone.band)


def test_vehicle_without_a_common_stretch_or_profile(impl):
    z = iso_profile(256e-6, 4, count=400)
    left, right = z.copy(), z.copy()
    left[:200], right[200:] = np.nan, np.nan
    assert impl.vehicle_roughness(left, right, DS, Config()).reason == "no valid profile"  # no common bin
    empty = impl.vehicle_roughness(np.zeros(0), z, DS, Config())
    assert empty.iso_class is None and empty.reason is not None


# ---------------------------------------------------------------------------------------------- pipeline
def road_scene(rng, count=20000, sensor_height=1.8):
    """Sensor-frame cloud: flat, slightly rough road (1 mm noise) and a box 1 m tall; last column intensity."""
    x, y = rng.uniform(0, 45, count), rng.uniform(-12, 12, count)
    z = -sensor_height + 0.001 * rng.standard_normal(count)
    obstacle = (x > 20) & (x < 22) & (np.abs(y) < 3)
    z[obstacle] += 1.0
    return np.column_stack([x, y, z, np.ones(count)]), obstacle


@pytest.mark.parametrize("method", ["pca", "ransac"])
def test_process_straight_road(impl, method):
    rng = np.random.default_rng(7)
    points, obstacle = road_scene(rng)
    points[::97, 1] = np.nan  # some rows are not finite
    cfg = Config(sensor_height=1.8, ground={"method": method})
    result = impl.process(points.astype(np.float32), 12.0, 0.0, cfg)
    finite = np.isfinite(points[:, :3]).all(axis=1)
    in_roi = finite & (points[:, 0] >= 1) & (points[:, 0] <= 40) & (np.abs(points[:, 1]) <= 10)
    assert result.reason is None
    assert result.points == {"input": len(points), "finite": int(finite.sum()), "roi": int(in_roi.sum()),
                             "ground": int(result.ground_mask.sum())}
    np.testing.assert_array_equal(result.ground_mask, in_roi & ~obstacle)
    np.testing.assert_allclose(result.plane, [0, 0, 1, 0], atol=2e-4)
    assert result.path["status"] == "straight"
    for profile in (result.left, result.right):
        assert len(profile.s) == 400
        np.testing.assert_allclose(profile.z[(profile.count > 0) & ~profile.blocked], 0.0, atol=0.01)
        assert profile.blocked[(profile.s > 20.5) & (profile.s < 21.5)].all()  # the raised patch stops the profile
        assert profile.roughness.iso_class is not None
    assert result.vehicle.iso_class is not None


def test_process_reverse_turn_uses_points_behind(impl):
    rng = np.random.default_rng(8)
    points, _ = road_scene(rng)
    points[:, 0] -= 45.0  # the whole scene is behind the vehicle
    cfg = Config(sensor_height=1.8)  # reversing mirrors the (front) region of interest: no ROI to configure
    result = impl.process(points, -5.0, -0.2, cfg)
    assert result.path["status"] == "arc" and result.path["icr_y"] == pytest.approx(25.0)
    assert result.left.count.sum() > 100 and result.right.count.sum() > 100
    forward = impl.process(points, 5.0, 0.2, cfg)  # same ICR, driving forward: nothing ahead
    assert forward.left.count.sum() == 0 and forward.left.roughness.iso_class is None


def test_process_stopped_and_no_ground(impl):
    rng = np.random.default_rng(9)
    points, _ = road_scene(rng, count=2000)
    stopped = impl.process(points, 0.0, 0.1, Config(sensor_height=1.8))
    assert stopped.reason == "vehicle stopped" and stopped.path["status"] == "stopped"
    assert stopped.ground_mask.sum() > 1000 and stopped.plane is not None
    assert len(stopped.left.z) == len(stopped.right.s) == 0 and stopped.vehicle.iso_class is None
    behind = points.copy()
    behind[:, 0] -= 50.0  # nothing in the ROI
    no_ground = impl.process(behind, 10.0, 0.0, Config(sensor_height=1.8))
    assert no_ground.reason == "no points in the region of interest" and no_ground.plane is None
    assert no_ground.points["roi"] == 0 and not no_ground.ground_mask.any()
    assert len(no_ground.left.z) == 0 and no_ground.left.roughness.reason is not None
    too_few = np.vstack([behind, points[:2]])  # two points in the region: no plane through them
    no_ground = impl.process(too_few, 10.0, 0.0, Config(sensor_height=1.8))
    assert no_ground.reason == "no ground" and no_ground.points["roi"] == 2 and no_ground.plane is None


@pytest.mark.parametrize("points", [
    np.zeros(9),  # 1-D
    np.zeros((5, 2)),  # N×2
    np.zeros((2, 5, 3)),  # 3-D
], ids=["1d", "nx2", "3d"])
def test_points_of_the_wrong_shape_are_a_value_error(impl, points):
    with pytest.raises(ValueError):
        impl.process(points, 10.0, 0.0, Config())


@pytest.mark.parametrize("dtype", [np.int64, bool, np.complex128])
def test_points_of_the_wrong_dtype_are_a_type_error(impl, dtype):
    with pytest.raises(TypeError):
        impl.process(np.zeros((5, 3), dtype=dtype), 10.0, 0.0, Config())


@pytest.mark.parametrize("points", [np.zeros((0, 3)), np.full((7, 4), np.nan, np.float32)],
                         ids=["empty", "all-nan"])
def test_empty_and_all_nan_clouds_give_a_reason(impl, points):
    result = impl.process(points, 10.0, 0.0, Config())
    assert result.reason == "no finite points"
    assert result.plane is None
    assert len(result.ground_mask) == len(points) and not np.any(result.ground_mask)
    assert result.points["input"] == len(points) and result.points["finite"] == 0
    assert len(result.left.z) == 0 and len(result.right.count) == 0
    assert result.vehicle.iso_class is None
