"""Off-road clouds (ROUGH dataset samples in the shared data, Ouster 128 × 1024 in forest terrain) with their
calibration: the default ground finds the forest floor and at least one wheel profile is built.

In both clouds undergrowth covers the floor beyond ~3 m (the lowest 5 % of the returns 3–6 m ahead lie 0.13–0.36 m
above the floor under the robot, 0.8–0.9 m at 6–10 m), so the floor is seen only near the robot: the profiles are
3–4 m long, and with obstacles on, the undergrowth in the wheel paths blocks them (clusters ≥ 0.1 m high)."""

import math

import numpy as np
import pytest
import yaml

import roadpreview as rp
from paths import SHARED_DATA

OFFROAD = SHARED_DATA / "offroad"
CLOUDS = {"rough_marv": "1727353472_601360559", "rough_tradr": "1725981157_851716757"}


def matrix(calibration: dict, name: str) -> np.ndarray:
    entry = calibration[name]
    return np.array([float(v) for v in entry["data"]]).reshape(entry["rows"], entry["cols"])


def extrinsics(path) -> rp.Extrinsics:
    """The sensor's pose in the base frame: base_footprint (on the ground) ← base_link ← os_sensor."""
    calibration = yaml.safe_load(path.read_text())
    footprint_from_sensor = np.linalg.inv(matrix(calibration, "T_base_link__base_footprint")) @ matrix(
        calibration, "T_base_link__os_sensor")
    r, t = footprint_from_sensor[:3, :3], footprint_from_sensor[:3, 3]
    # R = Rz(yaw)·Ry(pitch)·Rx(roll) (docs/method.md §0)
    return rp.Extrinsics(x_m=t[0], y_m=t[1], z_m=t[2], roll_rad=math.atan2(r[2, 1], r[2, 2]),
                         pitch_rad=-math.asin(np.clip(r[2, 0], -1, 1)), yaw_rad=math.atan2(r[1, 0], r[0, 0]))


@pytest.mark.parametrize("robot", CLOUDS)
def test_offroad_cloud_gives_ground_and_a_wheel_profile(robot):
    folder = OFFROAD / robot
    cloud = folder / f"{CLOUDS[robot]}.derived_xyzi.bin"
    if not cloud.exists():
        pytest.skip(f"shared data not found: {cloud}")
    cfg = rp.Config(extrinsics=extrinsics(folder / "transformations.yaml"), obstacles={"enabled": False})
    result = rp.Estimator(cfg).process(rp.io.read(cloud), 1.0, 0.0)
    assert result.plane is not None, result.reason
    assert math.degrees(math.acos(result.plane[2])) < 20.0  # a forest slope, levelled by the calibration
    assert result.points["ground"] > 3000
    valid = [np.count_nonzero(np.isfinite(p.z)) for p in (result.left, result.right)]
    assert max(valid) >= 10, valid  # at least 1 m of one wheel's profile
