"""Vehicle motion at constant speed and yaw rate, the frames a mounted LiDAR records, and the truth behind them.

World frame: the base frame of frame 0 (x forward, y left, z up; its origin on the road's mean plane). Each
frame's base frame is the vehicle's pose then: origin on the mean plane below the vehicle, heading yaw, and
level (the vehicle is not pitched or rolled by the road: grade and cross-slope appear as a tilted ground).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .lidar import Lidar
from .scene import LABEL_NONE, Scene, cast


@dataclass(frozen=True)
class Pose:
    """The vehicle's base frame in the world: origin (x_m, y_m) on the mean plane, heading yaw_rad."""

    x_m: float = 0.0
    y_m: float = 0.0
    yaw_rad: float = 0.0

    def to_world(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """World x, y of base-frame x, y."""
        c, s = math.cos(self.yaw_rad), math.sin(self.yaw_rad)
        x, y = np.asarray(x, float), np.asarray(y, float)
        return self.x_m + c * x - s * y, self.y_m + s * x + c * y


def trajectory(speed_mps: float, yaw_rate_rps: float, frames: int, rate_hz: float = 10.0,
               start_s: float = 0.0) -> list[Pose]:
    """Poses at t = start_s + i/rate_hz, i = 0 … frames−1, of rigid planar motion at constant V and ω that is at
    the origin at t = 0 (a later start_s: another pass along the same path, its frames taken elsewhere)."""
    if frames < 1 or rate_hz <= 0 or not math.isfinite(start_s):
        raise ValueError(f"need frames >= 1, rate_hz > 0 and a finite start_s, got {frames}, {rate_hz}, {start_s}")
    poses = []
    for i in range(frames):
        t = start_s + i / rate_hz
        heading = yaw_rate_rps * t
        if yaw_rate_rps == 0:
            poses.append(Pose(speed_mps * t, 0.0, 0.0))
        else:
            radius = speed_mps / yaw_rate_rps
            poses.append(Pose(radius * math.sin(heading), radius * (1 - math.cos(heading)), heading))
    return poses


@dataclass
class Frame:
    """One sweep: points in the sensor frame as the pipeline takes them, and the truth per point."""

    index: int
    time_s: float
    pose: Pose
    points: np.ndarray  #: (N, 4) float32 x, y, z, intensity (1.0); rays without a return are NaN rows
    labels: np.ndarray  #: (N,) uint8 LABEL_NONE / LABEL_ROAD / LABEL_OBSTACLE
    ranges_m: np.ndarray  #: (N,) exact range of each ray before noise (inf: no return)


def scan(scene: Scene, lidar: Lidar, pose: Pose, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(points, labels, exact ranges) of one sweep from the given pose (see Frame). Rays fly in their actual
    directions; the points lie along the beam table's, as a sensor computes them."""
    d_sensor = lidar.directions()
    d_actual = lidar.directions(actual=True)
    yaw = np.array([[math.cos(pose.yaw_rad), -math.sin(pose.yaw_rad), 0.0],
                    [math.sin(pose.yaw_rad), math.cos(pose.yaw_rad), 0.0], [0.0, 0.0, 1.0]])
    rotation = yaw @ lidar.mount_rotation()  # sensor → world
    ground_z = float(scene.road.plane_height(pose.x_m, pose.y_m))
    origin = np.array([pose.x_m, pose.y_m, ground_z + lidar.height_m])
    exact, labels = cast(scene, origin, d_actual @ rotation.T, lidar.max_range_m)
    measured = exact + rng.normal(0.0, lidar.range_noise_m, len(exact))
    returned = np.isfinite(exact) & (measured >= lidar.min_range_m) & (rng.random(len(exact)) >= lidar.dropout)
    labels = np.where(returned, labels, LABEL_NONE).astype(np.uint8)
    points = np.full((len(exact), 4), np.nan, dtype=np.float32)
    points[returned, :3] = d_sensor[returned] * measured[returned, None]
    points[returned, 3] = 1.0
    return points, labels, np.where(returned, exact, np.inf)


def drive(scene: Scene, lidar: Lidar, speed_mps: float, yaw_rate_rps: float = 0.0, frames: int = 10,
          rate_hz: float = 10.0, seed: int = 0, start_s: float = 0.0) -> list[Frame]:
    """Frames recorded while driving at constant speed and yaw rate, from time start_s on (see trajectory);
    deterministic for a given seed."""
    for name, value in (("speed_mps", speed_mps), ("yaw_rate_rps", yaw_rate_rps), ("start_s", start_s)):
        if not math.isfinite(value):
            raise ValueError(f"drive: {name} must be a finite number, got {value!r}")
    if not (isinstance(frames, (int, np.integer)) and frames >= 0):
        raise ValueError(f"drive: frames must be a whole number >= 0, got {frames!r}")
    if not (math.isfinite(rate_hz) and rate_hz > 0):
        raise ValueError(f"drive: rate_hz must be > 0, got {rate_hz!r}")
    streams = np.random.SeedSequence(seed).spawn(frames)
    out = []
    for i, pose in enumerate(trajectory(speed_mps, yaw_rate_rps, frames, rate_hz, start_s)):
        points, labels, ranges = scan(scene, lidar, pose, np.random.default_rng(streams[i]))
        out.append(Frame(i, start_s + i / rate_hz, pose, points, labels, ranges))
    return out


def wheel_path_xy(s, speed_mps: float, yaw_rate_rps: float, wheel_y_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Base-frame x, y reached after the wheel at (0, wheel_y_m) has rolled arc length s ≥ 0 (direction of travel
    sign(V); about the centre of rotation (0, V/ω) when ω ≠ 0, in the sense of ω)."""
    s = np.asarray(s, float)
    if yaw_rate_rps == 0:
        return math.copysign(1.0, speed_mps) * s, np.full_like(s, wheel_y_m)
    icr = speed_mps / yaw_rate_rps
    arm = wheel_y_m - icr  # the wheel relative to the centre, along y
    if arm == 0:
        return np.zeros_like(s), np.full_like(s, wheel_y_m)
    angle = math.copysign(1.0, yaw_rate_rps) * s / abs(arm)
    return -np.sin(angle) * arm, icr + np.cos(angle) * arm


def truth_profiles(scene: Scene, pose: Pose, speed_mps: float, yaw_rate_rps: float, *, track_width_m: float = 1.6,
                   ds_m: float = 0.1, preview_length_m: float = 40.0) -> dict:
    """True relief (height above the road's mean plane, m) under each wheel at the bin centres s = (k + ½)·ds
    the pipeline uses: {"s": s, "left": z, "right": z}."""
    s = (np.arange(math.ceil(preview_length_m / ds_m - 1e-9)) + 0.5) * ds_m
    out = {"s": s}
    for wheel, y_wheel in (("left", track_width_m / 2), ("right", -track_width_m / 2)):
        x_base, y_base = wheel_path_xy(s, speed_mps, yaw_rate_rps, y_wheel)
        out[wheel] = scene.road.relief(*pose.to_world(x_base, y_base))
    return out


def ring_profiles(scene: Scene, lidar: Lidar, pose: Pose, speed_mps: float, yaw_rate_rps: float, *,
                  track_width_m: float = 1.6, ds_m: float = 0.1, preview_length_m: float = 40.0) -> dict:
    """What a noise-free LiDAR with this beam table could know of the relief under each wheel: the exact relief
    where each ring crosses the wheel path, linearly interpolated in between (as the profile's gap filling
    does), at the bin centres truth_profiles uses; NaN before the nearest and after the farthest crossing.
    {"s": s, "left": z, "right": z}. A model of what one frame can resolve: between rings no return exists. Rings are where the beams (elevation − pitch, from the mounting height) meet the mean plane;
    the relief's few centimetres move them by millimetres at most; the tire's width is not averaged over."""
    s = (np.arange(math.ceil(preview_length_m / ds_m - 1e-9)) + 0.5) * ds_m
    downward = np.radians(np.asarray(lidar.elevations_deg, float) - lidar.pitch_deg)
    rings = np.sort(lidar.height_m / np.tan(-downward[downward < 0]))  # horizontal range from the sensor, m
    rings = rings[(rings >= lidar.min_range_m) & (rings <= lidar.max_range_m)]
    dense = np.arange(0.0, preview_length_m + 1.0, 0.01)  # the path finely, to find where each ring crosses it
    out = {"s": s}
    for wheel, y_wheel in (("left", track_width_m / 2), ("right", -track_width_m / 2)):
        x, y = wheel_path_xy(dense, speed_mps, yaw_rate_rps, y_wheel)
        reach = np.maximum.accumulate(np.hypot(x, y))  # the path recedes from the sensor
        crossed = rings[(rings > reach[0]) & (rings < reach[-1])]
        s_ring = np.interp(crossed, reach, dense)
        z_ring = scene.road.relief(*pose.to_world(*wheel_path_xy(s_ring, speed_mps, yaw_rate_rps, y_wheel)))
        z = np.interp(s, s_ring, z_ring) if len(s_ring) >= 2 else np.full(len(s), np.nan)
        if len(s_ring) >= 2:
            z[(s < s_ring[0]) | (s > s_ring[-1])] = np.nan
        out[wheel] = z
    return out

