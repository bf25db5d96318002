# SPDX-License-Identifier: BSD-3-Clause
"""The readout (docs/method.md §10, "Readout"): each wheel's profile read a fixed distance ahead and kept along the
drive (C++ ProfileReadout, `roadpreview run --read-ahead-m`) — checked against the numpy reference fed the same
results and the same run's output lines, and by properties of a drive over a known road."""

import json
import math

import numpy as np
import pytest
from hypothesis import given, strategies as st

import roadpreview as rp
from roadpreview import sim
from paths import KITTI_FRAMES, KITTI_SENSOR_HEIGHT
from paths import run_cli as run
from test_cli import one_line_error

DS = 0.1


def line(index, time_s, speed, road, distance, reason=None):
    """An output line whose two profiles (30 m, straight) are the heights road(x) at drive distance x."""
    s = (np.arange(300) + 0.5) * DS
    profile = {"s": s.tolist(), "z": [road(distance + v) for v in s], "count": [2] * 300, "spread": [0.0] * 300}
    return {"frame": index, "timestamp": time_s, "motion": {"speed": speed}, "path": None, "reason": reason,
            "profiles": {"left": profile, "right": profile}}


def test_the_native_readout_is_the_references_on_a_simulated_curved_drive_through_the_kalman_map():
    lidar = sim.os1_128(height_m=1.8, range_noise_m=0.01)
    frames = sim.drive(sim.Scene(sim.Road.iso8608("C", seed=2)), lidar, speed_mps=10, yaw_rate_rps=0.1, frames=9,
                       seed=1)
    cfg = rp.Config(extrinsics=lidar.extrinsics(), fusion={"method": "kalman"})
    est, native, reference = rp.Estimator(cfg), rp.ProfileReadout(6.0, cfg), rp.reference.Readout(6.0, cfg)
    for f in frames:
        res = est.process(f.points, 10.0, 0.1, timestamp=f.time_s)
        native.add(res)
        reference.add(res.to_dict())
    assert native.frames == 9 and native.distance_m == pytest.approx(reference.distance) == pytest.approx(8.0)
    for wheel in ("left", "right"):
        mine, theirs = getattr(native, wheel), reference.wheel(wheel)
        np.testing.assert_allclose(mine.s, theirs["s"], atol=1e-9)
        np.testing.assert_array_equal(mine.z, theirs["z"])
        np.testing.assert_array_equal(mine.count, theirs["count"])
        assert np.isfinite(mine.z).all()  # 8 m driven: all 6 m were read, 6–14 m down the drive
        assert mine.s.max() < 6.0


@given(steps=st.lists(st.floats(0.02, 2.5), min_size=1, max_size=25), ahead=st.floats(1.0, 20.0),
       gap=st.integers(0, 30))
def test_each_bin_holds_the_reading_of_the_last_frame_that_had_it_the_distance_ahead(steps, ahead, gap):
    """A drive whose frames are any distance apart (frame `gap` without profiles) and whose heights say which frame
    read them (1000 × the frame + a slope along the drive): each bin of the readout was read by the last frame
    with profiles that had it `ahead` or more ahead, at its own place, and a bin no such frame had is unread; the
    native readout fed the lines is the reference's."""
    lines, distances = [], []
    for i, step in enumerate([0.0, *steps]):
        distances.append((distances[-1] if distances else 0.0) + step)
        road = lambda x, i=i: 1000.0 * i + 0.01 * x  # noqa: E731
        lines.append(line(i, 0.1 * i, step / 0.1, road, distances[-1], reason="no ground" if i == gap else None))
    native, reference = rp.ProfileReadout(ahead), rp.reference.Readout(ahead)
    for ln in lines:
        native.add_line(json.dumps(ln))
        reference.add(ln)
    got = reference.wheel("left")
    np.testing.assert_allclose(native.left.s, got["s"], atol=1e-9)
    np.testing.assert_array_equal(native.left.z, got["z"])
    assert native.distance_m == pytest.approx(reference.distance) == pytest.approx(distances[-1])
    place = distances[-1] + got["s"]
    reader = np.round(got["z"] / 1000.0)
    for x, z, i in zip(place, got["z"], reader):
        had_it = [k for k in range(len(lines)) if k != gap and x - distances[k] >= ahead - 1e-6]
        if not np.isfinite(z):
            assert not had_it  # unread: only what no frame with profiles had `ahead` or more ahead
            continue
        assert i == max(had_it)
        assert z - 1000.0 * i == pytest.approx(0.01 * x, abs=1e-9)


@pytest.fixture(scope="module")
def kitti_lines(tmp_path_factory):
    out = tmp_path_factory.mktemp("readout") / "run.jsonl"
    run("run", *KITTI_FRAMES[:3], "--speed", 8.6, "--frame-rate", 10, "--sensor-height", KITTI_SENSOR_HEIGHT,
        "--fusion", "kalman", "--read-ahead-m", 5, "-q", "-o", out)
    return [json.loads(text) for text in out.read_text().splitlines()]


def test_the_cli_adds_each_lines_readout_as_the_reference_reads_the_same_lines(kitti_lines):
    reference = rp.reference.Readout(5.0)
    for ln in kitti_lines:
        reference.add(ln)
        readout = ln["readout"]
        assert readout["ahead_m"] == 5.0 and readout["distance_m"] == pytest.approx(reference.distance)
        for wheel in ("left", "right"):
            theirs = reference.wheel(wheel)
            np.testing.assert_allclose(readout[wheel]["s"], theirs["s"], atol=1e-12)
            z = np.array([np.nan if v is None else v for v in readout[wheel]["z"]])
            np.testing.assert_array_equal(z, theirs["z"])
            assert readout[wheel]["count"] == theirs["count"].tolist()
    last = kitti_lines[-1]["readout"]["left"]  # 1.72 m driven: 5–6.72 m of the drive read, a real street's heights
    z = np.array([np.nan if v is None else v for v in last["z"]])
    read = np.array(last["s"]) >= 5.0 - 1.72 + 0.05
    assert np.isfinite(z[read]).all() and not np.isfinite(z[~read]).any() and np.nanmax(np.abs(z)) < 0.1


def route_pair():
    cfg = rp.Config()
    native = rp._native.core().RouteBuilder(cfg.to_json())
    return native, rp.reference.Route(cfg), lambda: (native.stitched("left").frames, native.stitched("right").frames)


def readout_pair():
    native = rp.ProfileReadout(6.0)
    return native, rp.reference.Readout(6.0), lambda: (native.left.z, native.right.z)


@pytest.mark.parametrize("pair", [route_pair, readout_pair])
def test_lines_that_cannot_be_placed_are_errors_or_skipped_alike_and_leave_the_state_as_it_was(pair):
    """§10, "Placing a wheel's profile": lines read back from files may hold anything. A step of the drive beyond
    1 km, a bin beyond the profiles' reach and a path without a scale are errors (once, a speed of 1e300 hung the
    readout and a far bin made the route allocate gigabytes); a wheel turning about a point beside it adds nothing."""
    native, reference, state = pair()
    road = lambda x: 0.01 * math.sin(x)
    native.add_line(json.dumps(line(0, 0.0, 10.0, road, 0.0)))
    reference.add(line(0, 0.0, 10.0, road, 0.0))
    before = [np.array(v, copy=True) for v in state()]
    far = line(1, 0.1, 10.0, road, 1.0)
    far["profiles"]["right"] = dict(far["profiles"]["right"], s=far["profiles"]["right"]["s"][:-1] + [1e9])
    no_scale = dict(line(1, 0.1, 10.0, road, 1.0), path={"icr_y": 5.0, "left_radius": 1e-320, "right_radius": 1.0})
    bad = {"a speed no drive has": (dict(line(1, 0.1, 1e300, road, 1.0)), "moves the drive on by"),
           "no speed": (dict(line(1, 0.1, None, road, 1.0)), "moves the drive on by nan m"),
           "a time stamp no drive has": (dict(line(1, 1e300, 10.0, road, 1.0)), "moves the drive on by"),
           "a bin 10^9 m ahead": (far, "a profile bin lies"),
           "a wheel without a scale": (no_scale, "give no distance along the drive")}
    for what, (bad_line, message) in bad.items():
        with pytest.raises(ValueError, match=f"frame 1.*{message}"):
            native.add_line(json.dumps(bad_line))
        with pytest.raises(ValueError, match=f"frame 1.*{message}"):
            reference.add(bad_line)
        assert native.frames == reference._drive.frames == 1, what
        for now, then in zip(state(), before):
            np.testing.assert_array_equal(now, then, err_msg=what)
    tight = dict(line(1, 0.1, 10.0, road, 1.0), path={"icr_y": 0.801, "left_radius": 0.001, "right_radius": 1.601})
    native.add_line(json.dumps(tight))
    reference.add(tight)
    assert native.distance_m == pytest.approx(reference.distance) == pytest.approx(1.0)
    left, right = state()
    if pair is route_pair:  # the left wheel (q = 801) added nothing, the right one (q = 0.5) its 15 m of drive
        np.testing.assert_array_equal(left, before[0])
        assert right[20] == 2 and right[170] == 1
        for wheel in ("left", "right"):
            np.testing.assert_array_equal(native.stitched(wheel).frames, reference.stitched(wheel).frames)
    else:
        for wheel, now in (("left", left), ("right", right)):
            np.testing.assert_array_equal(now, reference.wheel(wheel)["z"])


@pytest.mark.parametrize("ahead", ["0", "-2", "nan", "40", "60"])
def test_a_distance_ahead_that_is_not_within_the_profiles_is_an_error(ahead):
    proc = run("run", KITTI_FRAMES[0], "--speed", 5, "--sensor-height", KITTI_SENSOR_HEIGHT, "--read-ahead-m",
               ahead, "-q", check=False)
    if float(ahead) > 0:
        one_line_error(proc, "--read-ahead-m: readout: the distance ahead", "profile.preview_length_m")
        assert proc.returncode == 2  # a usage error, said before the input is read
    else:  # refused by the flag's own check
        assert proc.returncode != 0 and proc.stderr.startswith("--read-ahead-m: expected a number > 0"), proc.stderr
    with pytest.raises(ValueError, match="distance ahead"):
        rp.reference.Readout(float(ahead))
    with pytest.raises(ValueError, match="distance ahead"):
        rp.ProfileReadout(float(ahead))


def test_a_stereo_drive_read_6_m_ahead_through_the_ema_map_holds_the_bump_and_a_flat_road(tmp_path):
    """The moving-average paper's experiment in little (bench/stereo.py): a 6 cm bump under the left wheel 16 m
    ahead, 14 frames at 10 m/s of simulated KITTI stereo; read 6 m ahead (where the camera first sees the road
    whole), the EMA map's readout holds the bump within 0.5 cm and the plain road under the right wheel within
    ±0.3 cm — the single frames' profiles that saw it 10–15 m ahead read it ≥ 0.5 cm low."""
    camera = sim.kitti_stereo()
    bump_x = 16.05
    scene = sim.Scene(sim.Road(bumps=(sim.SpeedBump(bump_x, 0.06, 1.0, y_min_m=0.3, y_max_m=1.3),)))
    frames = sim.drive_stereo(scene, camera, 10.0, 0.0, 14, seed=60)
    calib = camera.write_calibration(tmp_path / "stereo.yaml")
    cfg = rp.Config(extrinsics=camera.extrinsics(), fusion={"method": "ema"}, obstacles={"enabled": False},
                    stereo={"error_correlation_along_px": 0.0, "error_correlation_across_px": 0.0})
    est, readout, far_crests = rp.Estimator(cfg), rp.ProfileReadout(6.0, cfg), []
    for f in frames:
        found = rp.io.stereo_points(None, None, calib, disparity=f.disparity, config=cfg)
        res = est.process(found.points, 10.0, 0.0, timestamp=f.time_s, range_variances=found.range_variances,
                          error_groups=found.error_groups)
        readout.add(res)
        s, z = np.asarray(res.left.s), np.asarray(res.left.z)
        if 10.0 <= bump_x - f.pose.x_m <= 15.0:
            far_crests.append(np.nanmax(z[np.abs(s - (bump_x - f.pose.x_m)) < 0.3]))
    s, z = readout.left.s, readout.left.z  # 13 m driven: the bump 3 m ahead, read when it lay 6–7 m ahead
    around = (np.abs(s - (bump_x - 13.0)) >= 1.0) & (np.abs(s - (bump_x - 13.0)) <= 2.5)
    height = np.nanmax(z[np.abs(s - (bump_x - 13.0)) <= 0.3]) - np.nanmedian(z[around])
    assert height == pytest.approx(0.06, abs=0.005)
    assert np.isfinite(readout.right.z[readout.right.s >= 0.1]).all()
    assert np.max(np.abs(readout.right.z[readout.right.s >= 0.1])) <= 0.003
    assert max(far_crests) < 0.06 - 0.005
