# SPDX-License-Identifier: BSD-3-Clause
"""LiDAR odometry (KISS-ICP): speed of the OS1-128 recording against its poses file (target 0.1 m/s), KITTI seq 00
against its ground truth, the pose-to-motion arithmetic, and `--motion-from lidar` through run and batch."""

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("kiss_icp")

import roadpreview as rp  # noqa: E402
from roadpreview import odometry  # noqa: E402
from paths import KITTI_SENSOR_HEIGHT, OS1_128_HEIGHT, OS1_128_PCAP, OUSTER, SHARED_DATA  # noqa: E402

OS1_128_POSES = OUSTER / "OS-1-128_v2.3.0_1024x10_lb_n3_poses_kitti.txt"
KITTI_POSES = SHARED_DATA / "kitti" / "seq00_poses"


@pytest.fixture(scope="module")
def os1_odometry():
    return odometry.estimate(OS1_128_PCAP, rp.Config(sensor_height=OS1_128_HEIGHT))


def test_os1_128_speed_is_within_a_tenth_of_a_metre_per_second_of_its_poses_file(os1_odometry):
    ref = odometry.read_kitti_matrices(OS1_128_POSES)
    cmp = odometry.compare(os1_odometry.poses, ref, os1_odometry.times_s)
    assert cmp["frames"] == 3
    assert cmp["speed_error_max_mps"] < 0.1, cmp
    assert np.all(os1_odometry.speed_mps > 2.0)  # forward: x of the sensor frame, + for this drive
    assert np.all(np.abs(os1_odometry.yaw_rate_rps) < 0.1)  # the poses file turns by less than 0.01 rad


def test_pose_differences_give_forward_speed_and_yaw_rate():
    times = np.array([0.0, 0.1, 0.2, 0.3])
    poses = []
    x = y = yaw = 0.0
    for _ in times:
        m = np.eye(4)
        m[:2, :2] = [[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]]
        m[:2, 3] = (x, y)
        poses.append(m)
        x, y, yaw = x + math.cos(yaw), y + math.sin(yaw), yaw + 0.02  # 1 m forward, then turn 0.02 rad
    speed, yaw_rate = odometry.motion_from_poses(times, np.stack(poses))
    np.testing.assert_allclose(speed, 10.0, atol=1e-9)
    np.testing.assert_allclose(yaw_rate, 0.2, atol=1e-9)
    with pytest.raises(RuntimeError, match="frame 1 is not later than frame 0"):
        odometry.motion_from_poses(np.zeros(2), np.stack(poses[:2]))


def test_the_mounting_turns_sensor_poses_into_vehicle_poses():
    cfg = rp.Config(extrinsics={"x_m": 1.0, "z_m": 1.8, "yaw_rad": math.pi / 2})
    e = odometry.mounting_matrix(cfg)
    sensor_step = np.eye(4)
    sensor_step[1, 3] = -0.5  # the sensor, turned 90° left, sees the vehicle go 0.5 m along its -y
    base_step = e @ sensor_step @ np.linalg.inv(e)
    np.testing.assert_allclose(base_step[:3, 3], [0.5, 0.0, 0.0], atol=1e-12)


def test_odometry_refuses_a_single_frame(tmp_path):
    with pytest.raises(RuntimeError, match="000000.bin: odometry needs at least two frames, the input has 1"):
        odometry.estimate([str(OUSTER.parent / "semantickitti" / "000000.bin")], rp.Config(sensor_height=1.73))


@pytest.mark.skipif(not KITTI_POSES.exists(), reason="shared data not present")
def test_kitti_seq00_speed_against_ground_truth():
    """Frames 0-5 of seq 00 (0.1037 s apart): KISS-ICP's speed is ~15 % short of the ground truth here, as
    scan-to-scan ICP was in the field notes (about 17 %); this pins the measured agreement."""
    files = sorted((SHARED_DATA / "semantickitti" / "squeezesegv3_seq00").glob("*.bin")) + sorted(
        (SHARED_DATA / "kitti" / "patchworkpp_seq00").glob("*.bin"))
    odo = odometry.estimate([str(f) for f in files], rp.Config(sensor_height=KITTI_SENSOR_HEIGHT))
    times = np.loadtxt(KITTI_POSES / "KITTI_00_gt_times.txt")[:6]
    cmp = odometry.compare(odo.poses, odometry.read_kitti_matrices(KITTI_POSES / "00.txt")[:6], times)
    ref = np.mean(cmp["speed_ref_mps"])
    assert 8.0 < ref < 8.6
    assert 0.75 * ref < np.mean(cmp["speed_est_mps"]) < 1.05 * ref, cmp


def test_run_with_motion_from_lidar_writes_poses_and_uses_them(tmp_path):
    exe = str(Path(sys.executable).parent / "roadpreview")
    proc = subprocess.run([exe, "run", str(OS1_128_PCAP), "--motion-from", "lidar", "--sensor-height",
                           str(OS1_128_HEIGHT), "--poses-out", str(tmp_path / "p.txt"), "--motion-out",
                           str(tmp_path / "m.csv"), "-o", str(tmp_path / "o.jsonl"), "-q"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    lines = [json.loads(x) for x in (tmp_path / "o.jsonl").read_text().splitlines()]
    assert len(lines) == 3 and all(2.3 < x["motion"]["speed"] < 2.7 for x in lines)
    assert len(np.loadtxt(tmp_path / "p.txt", ndmin=2)) == 3
    assert (tmp_path / "m.csv").read_text().startswith("t,speed,yaw_rate\n")
