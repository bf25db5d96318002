"""Zone ground and the tilt limit (docs/method.md §1), known-answer scenes on every implementation."""

import math

import numpy as np
import pytest

import roadpreview as rp
import roadpreview.native
from paths import KITTI_FRAMES, KITTI_SENSOR_HEIGHT, OUSTER
from roadpreview.config import Config

STEP_M = 0.25  # grid spacing of the synthetic scenes


def road_grid(height, x_range=(1.0, 40.0), y_range=(-9.0, 9.0), step=STEP_M):
    """Points on the surface z = height(x, y) over a regular grid (base frame)."""
    x, y = np.meshgrid(np.arange(*x_range, step), np.arange(y_range[0], y_range[1] + 1e-9, step))
    x, y = x.ravel(), y.ravel()
    return np.column_stack([x, y, height(x, y)])


def grade(x, y):
    """Level to 15 m, then rising 3 % (0.75 m higher at 40 m): one plane cannot follow it."""
    return 0.03 * np.maximum(x - 15.0, 0.0)


def crest(x, y):
    """Up 5 % to a crest 1 m high at 20 m, then down 5 %."""
    return 0.05 * np.minimum(x, 40.0 - x)


def kerb(x, y):
    """Road |y| < 4 m level, pavements beyond it 0.15 m higher."""
    return np.where(np.abs(y) < 4.0, 0.0, 0.15)


def bank(x, y):
    """A road banked by 6 % to the left (3.4°)."""
    return 0.06 * y


def with_extra(road, extra):
    return np.vstack([road, extra]), np.arange(len(road) + len(extra)) < len(road)


def wall_scene():
    """Level road and a 3 m wall along y = 6 m (its face every 0.2 m in x and z, from 0.3 m up)."""
    road = road_grid(lambda x, y: 0.0 * x, y_range=(-9.0, 5.5))
    x, z = np.meshgrid(np.arange(1.0, 40.0, 0.2), np.arange(0.3, 3.0, 0.2))
    wall = np.column_stack([x.ravel(), np.full(x.size, 6.0), z.ravel()])
    return with_extra(road, wall)


def canopy_scene():
    """Level road under a canopy 6.7 m up over x 10–20 m, |y| ≤ 5 m (a filling station roof)."""
    road = road_grid(lambda x, y: 0.0 * x)
    x, y = np.meshgrid(np.arange(10.0, 20.0, 0.2), np.arange(-5.0, 5.0, 0.2))
    roof = np.column_stack([x.ravel(), y.ravel(), np.full(x.size, 6.7)])
    return with_extra(road, roof)


def car_beside_a_camera():
    """A camera's view: the road from 6 m on, and the side of a car 2 m to the right filling the near field (a fit
    of every point within the root's 10 m leans 10° through it: the KITTI stereo pair's case)."""
    road = road_grid(lambda x, y: 0.0 * x, x_range=(6.0, 40.0))
    x, z = np.meshgrid(np.arange(3.5, 5.5, 0.05), np.arange(0.4, 1.5, 0.05))
    side = np.column_stack([x.ravel(), np.full(x.size, -2.0), z.ravel()])
    return with_extra(road, side)


def sparse_rings():
    """A 16-beam sensor 1.8 m up on a level road: its ground rings 1.4–14 m apart (the VLP-16's −15°…−3° beams),
    a point every 0.2° of azimuth, each with 3 cm of range noise along its ray. Each patch holds one ring's arc:
    a ribbon along the arc and along the rays, which lean 3–15° — any plane through the arc fits it."""
    rng = np.random.default_rng(7)
    elevation, azimuth = (v.ravel() for v in np.meshgrid(np.radians([-15.0, -13.0, -11.0, -9.0, -7.0, -5.0, -3.0]),
                                                          np.radians(np.arange(-90.0, 90.0, 0.2))))
    ray = np.column_stack([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth), np.sin(elevation)])
    reach = 1.8 / -np.sin(elevation) + rng.normal(0.0, 0.03, len(ray))
    road = ray * reach[:, None] + [0.0, 0.0, 1.8]
    road = road[(road[:, 0] >= 1.0) & (np.abs(road[:, 1]) <= 10.0)]
    return road, np.ones(len(road), dtype=bool)


def crest_road(x):
    """Rising 1.6 % to a crest 12 m ahead, then falling 1.2 %."""
    return np.where(x <= 12.0, 0.016 * x - 0.1, 0.092 - 0.012 * (x - 12.0))


def object_beyond_a_crest():
    """Dense road to 11 m (its patches fit the 1.6 % rise), then one ring per patch over the crest (12–39 m), and
    the face of an object 20.4 m ahead from 0.4 m above the road: handed on unchanged from 10 m, the rising
    plane stands 0.24 m above the road there and the face's lowest row is ground (the bundled OS-1-32 capture)."""
    x, y = np.meshgrid(np.arange(1.0, 11.0, STEP_M), np.arange(-9.0, 9.0 + 1e-9, STEP_M))
    near = np.column_stack([x.ravel(), y.ravel(), crest_road(x.ravel())])
    arcs = []
    for r in (12.0, 14.2, 16.7, 19.5, 22.5, 26.0, 30.0, 34.0, 39.0):
        azimuth = np.radians(np.arange(-90.0, 90.0, 0.2))
        xa, ya = r * np.cos(azimuth), r * np.sin(azimuth)
        keep = (xa >= 1.0) & (np.abs(ya) <= 10.0)
        arcs.append(np.column_stack([xa[keep], ya[keep], crest_road(xa[keep])]))
    y, dz = np.meshgrid(np.arange(-0.6, 0.6 + 1e-9, 0.1), np.arange(0.4, 1.31, 0.15))
    face = np.column_stack([np.full(y.size, 20.4), y.ravel(), crest_road(20.4) + dz.ravel()])
    return with_extra(np.vstack([near, *arcs]), face)


# Returns metres under the road (a reflection, multipath): KITTI frames hold a few 9–10 m down, the OS-0-128
# capture one 9 m down in a wheel's path. The method paper keeps every point below its plane.
UNDER_THE_ROAD = np.array([[11.0, -0.8, -9.2], [11.1, -0.8, -9.0], [25.0, 3.0, -2.5], [6.0, 1.0, -6.7]])


def returns_from_under_the_road():
    return with_extra(road_grid(grade), UNDER_THE_ROAD)


def under_a_step_down():
    """The road steps 0.25 m down at 13 m (a kerb's height: the outer patches accept their own planes) and one
    return lies 2.1 m below the step's inner road, 1.85 m below its own patch's plane: deeper than max_depth_m
    under the reference, it takes no part in the patch (method.md §1, zones step 4) — it once was ground."""
    step_down = road_grid(lambda x, y: np.where(np.hypot(x, y) < 13.0, 0.0, -0.25), (1.0, 20.0), (-3.0, 3.0), 0.04)
    return with_extra(step_down, [[15.0, 0.0, -2.1]])


def surface_scene(height):
    road = road_grid(height)
    return road, np.ones(len(road), dtype=bool)


SCENES = {
    "grade": lambda: surface_scene(grade),
    "crest": lambda: surface_scene(crest),
    "kerb": lambda: surface_scene(kerb),
    "bank": lambda: surface_scene(bank),
    "wall beside the road": wall_scene,
    "overhead canopy": canopy_scene,
    "car beside a camera": car_beside_a_camera,
    "rings of a sparse sensor": sparse_rings,
    "object beyond a crest, one ring per patch": object_beyond_a_crest,
    "returns from under the road": returns_from_under_the_road,
    "a return from under a step down": under_a_step_down,
}


@pytest.mark.parametrize("scene", SCENES)
def test_zone_ground_follows_the_road_and_leaves_the_rest(impl, scene):
    xyz, road = SCENES[scene]()
    mask, plane = impl.fit_ground(xyz, Config(ground={"method": "zones"}))
    assert plane is not None
    np.testing.assert_array_equal(mask, road)


def steep_grade(x, y):
    """Level to 15 m, then rising 8 % (2 m higher at 40 m)."""
    return 0.08 * np.maximum(x - 15.0, 0.0)


@pytest.mark.parametrize("height", [steep_grade, crest])
def test_one_plane_cannot_follow_a_grade_or_crest(impl, height):
    """Why zones exist: the paper's one plane drops part of these roads, the zones keep all of it."""
    xyz = road_grid(height)
    assert np.count_nonzero(~impl.fit_ground(xyz, Config(ground={"method": "pca"}))[0]) > 0.05 * len(xyz)
    assert impl.fit_ground(xyz, Config(ground={"method": "zones"}))[0].all()


@pytest.mark.parametrize("method", ["zones", "pca"])
def test_returns_deeper_than_max_depth_under_the_road_are_not_ground(impl, method):
    xyz, road = with_extra(road_grid(lambda x, y: 0.0 * x), UNDER_THE_ROAD)
    mask, _ = impl.fit_ground(xyz, Config(ground={"method": method}))
    np.testing.assert_array_equal(mask, road)
    # The paper's rule (points below the plane are ground) comes back with a depth beyond them.
    mask, _ = impl.fit_ground(xyz, Config(ground={"method": method, "max_depth_m": 20.0}))
    assert mask.all()


def test_a_return_from_under_the_road_in_a_wheel_path_is_no_profile_bin():
    """The bundled OS-0-128 capture holds one return 9.2 m under the road 11 m ahead in the right wheel's path: it
    made a profile bin, the gap filling drew a slope down to it and the right wheel read class H."""
    frame = next(iter(rp.io.open(OUSTER / "OS-0-128-U1_v2.3.0_1024x10.pcap")))
    res = rp.Estimator(rp.Config(sensor_height=1.97)).process(frame.points, 5.0, 0.0)
    for wheel in (res.left, res.right):
        z = wheel.z[np.isfinite(wheel.z)]
        assert len(z) > 50 and np.abs(z).max() < 0.2


def test_the_ground_handed_on_over_a_crest_follows_the_rings_on_a_real_sparse_sensor():
    """The bundled OS-1-32 capture: the road rises to 7 cm 12 m ahead and falls to −5 cm at 20 m, where an object
    stands. The plane handed on unchanged from 10 m stood 26 cm above the road there: a return 0.33 m up behind
    the object was ground and made the left wheel's last bin 0.35 m high."""
    res = next(iter(rp.run(OUSTER / "OS-1-32-G_v2.1.1_1024x10.pcap", rp.Config(), speed=5.0)))  # mounting estimated
    for wheel in (res.left, res.right):
        z = wheel.z[np.isfinite(wheel.z)]
        assert len(z) > 40 and np.abs(z).max() < 0.1


def wall_only():
    """Nothing but a wall 3 m ahead across the ROI and a few returns on its foot: the only plane is vertical."""
    y, z = np.meshgrid(np.arange(-9.0, 9.0, 0.1), np.arange(-1.5, 2.0, 0.1))
    return np.column_stack([np.full(y.size, 3.0) + 0.01 * np.sin(y.ravel()), y.ravel(), z.ravel()])


@pytest.mark.parametrize("method", ["zones", "pca", "ransac"])
def test_a_wall_is_never_ground(impl, method):
    mask, plane = impl.fit_ground(wall_only(), Config(ground={"method": method}))
    assert plane is None and not mask.any()


@pytest.mark.parametrize("method", ["zones", "pca", "ransac"])
def test_the_tilt_limit_is_configurable(impl, method):
    """A uniform 20° slope is ground with a 25° limit, not with the default 15°."""
    slope = road_grid(lambda x, y: math.tan(math.radians(20.0)) * y)
    assert impl.fit_ground(slope, Config(ground={"method": method}))[1] is None
    mask, plane = impl.fit_ground(slope, Config(ground={"method": method, "max_tilt_deg": 25.0}))
    assert plane is not None and mask.mean() > 0.95
    assert math.degrees(math.acos(plane[2])) == pytest.approx(20.0, abs=0.1)


def test_a_frame_without_acceptable_ground_says_why():
    for method in ("zones", "pca", "ransac"):
        cfg = Config(ground={"method": method})
        for result in (rp.Estimator(cfg).process(wall_only().astype(np.float32), 5.0, 0.0),
                       rp.reference.process(wall_only(), 5.0, 0.0, cfg)):
            assert result.reason == "no ground within the tilt limit", method
            assert result.plane is None


def test_the_old_name_of_the_tilt_limit_is_still_read(tmp_path):
    cfg = Config.from_dict({"ground": {"ransac_max_tilt_deg": 12.0}})
    assert cfg.ground.max_tilt_deg == 12.0
    path = tmp_path / "old.json"
    path.write_text('{"ground": {"ransac_max_tilt_deg": 12.0}}')
    assert rp.Estimator(Config.from_file(path)).config.ground.max_tilt_deg == 12.0
    with pytest.raises(ValueError, match="not both"):
        Config.from_dict({"ground": {"ransac_max_tilt_deg": 12.0, "max_tilt_deg": 10.0}})


def test_zones_is_the_default():
    assert Config().ground.method == "zones"


@pytest.mark.parametrize("frame", KITTI_FRAMES, ids=lambda p: p.stem)
def test_zone_ground_cpp_and_reference_agree_on_real_kitti_frames(frame):
    base = rp.io.read(frame)[:, :3].astype(np.float64)
    base[:, 2] += KITTI_SENSOR_HEIGHT
    cfg = Config()
    cpp_mask, cpp_plane = rp.native.fit_ground(base, cfg)
    ref_mask, ref_plane = rp.reference.fit_ground(base, cfg)
    assert np.count_nonzero(cpp_mask != ref_mask) <= 1e-4 * len(base)  # float32 coordinates in C++
    assert ref_mask.sum() > 0.2 * len(base)
    np.testing.assert_allclose(cpp_plane, ref_plane, atol=1e-6)


def canopy_over_the_path(height_m):
    """Level road (sensor frame, 1.73 m up) under a slab `height_m` up over x 10–20 m, |y| ≤ 3 m."""
    road = road_grid(lambda x, y: 0.0 * x)
    x, y = np.meshgrid(np.arange(10.0, 20.0, 0.2), np.arange(-3.0, 3.0, 0.2))
    slab = np.column_stack([x.ravel(), y.ravel(), np.full(x.size, height_m)])
    points = np.vstack([road, slab])
    points[:, 2] -= KITTI_SENSOR_HEIGHT
    return points.astype(np.float32)


@pytest.mark.parametrize("height_m, clearance_m, blocks", [(6.7, 2.5, False), (1.5, 2.5, True), (6.7, 8.0, True)])
def test_an_overhead_cluster_blocks_no_wheel_path(height_m, clearance_m, blocks):
    cfg = Config(sensor_height=KITTI_SENSOR_HEIGHT, obstacles={"clearance_m": clearance_m})
    points = canopy_over_the_path(height_m)
    for result in (rp.Estimator(cfg).process(points, 5.0, 0.0), rp.reference.process(points, 5.0, 0.0, cfg)):
        assert len(result.obstacles) == 1
        assert result.obstacles.bottom[0] == pytest.approx(height_m, abs=0.01)
        assert (len(result.left.obstacles) == 1) == blocks and (len(result.right.obstacles) == 1) == blocks
