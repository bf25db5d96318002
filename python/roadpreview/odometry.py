# SPDX-License-Identifier: BSD-3-Clause
"""LiDAR odometry for recordings without a motion log: KISS-ICP (the ``kiss-icp`` package) on the frames.

    odo = rp.odometry.estimate("drive.pcap", rp.Config(sensor_height=1.97))
    odo.speed_mps, odo.yaw_rate_rps, odo.times_s          # per frame, base frame
    odo.write("drive.poses.txt", "drive.motion.csv")      # KITTI poses; t,speed,yaw_rate (roadpreview run --motion)

Poses are those of the base frame (x forward, y left, z up) in the first frame's base frame: KISS-ICP
registers sensor-frame clouds, and the sensor's mounting (the config's extrinsics) turns its poses into the
vehicle's, T_base = E · T_sensor · E⁻¹. Speed is the forward displacement between consecutive frames over
their time difference; yaw rate the heading change over it (the first frame takes the second's values).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Optional

import numpy as np

from . import drive
from .config import Config


@dataclass
class Odometry:
    times_s: np.ndarray    # (K,)
    poses: np.ndarray      # (K, 4, 4) base frame in the first frame's base frame
    speed_mps: np.ndarray  # (K,)
    yaw_rate_rps: np.ndarray

    def planar(self) -> list[tuple[float, float, float]]:
        """(x, y, yaw) per frame, as ``roadpreview run --poses`` reads them."""
        return [(float(p[0, 3]), float(p[1, 3]), math.atan2(p[1, 0], p[0, 0])) for p in self.poses]

    def motion_table(self, source: str = "lidar odometry") -> drive.MotionTable:
        if len(self.times_s) < 2:
            raise RuntimeError(f"{source}: odometry needs at least two frames")
        return drive.MotionTable.from_samples(self.times_s, self.speed_mps, self.yaw_rate_rps, source)

    def write(self, poses_path: Optional[str] = None, motion_path: Optional[str] = None) -> None:
        if poses_path:
            np.savetxt(poses_path, self.poses[:, :3, :].reshape(len(self.poses), 12), fmt="%.9g")
        if motion_path:
            rows = np.column_stack((self.times_s, self.speed_mps, self.yaw_rate_rps))
            np.savetxt(motion_path, rows, fmt="%.9f", delimiter=",", header="t,speed,yaw_rate", comments="")


def mounting_matrix(cfg: Config) -> np.ndarray:
    """E: sensor frame → base frame (R = Rz(yaw)·Ry(pitch)·Rx(roll), then the sensor's position)."""
    e = cfg.extrinsics
    if e is None:
        return np.diag([1.0, 1.0, 1.0, 1.0]) if cfg.sensor_height is None else _translation(0, 0, cfg.sensor_height)
    cr, sr, cp, sp, cy, sy = (math.cos(e.roll_rad), math.sin(e.roll_rad), math.cos(e.pitch_rad),
                              math.sin(e.pitch_rad), math.cos(e.yaw_rad), math.sin(e.yaw_rad))
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    m = _translation(e.x_m, e.y_m, e.z_m)
    m[:3, :3] = rz @ ry @ rx
    return m


def _translation(x, y, z) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


VOXEL_M = 0.25  # KISS-ICP's default is max_range / 100 (1 m); 0.25 m tracks the bundled OS1-128 drive (docs/scale.md)


def kiss_icp(max_range_m: float = 100.0, min_range_m: float = 2.0, voxel_m: float = VOXEL_M, deskew: bool = False):
    """A KISS-ICP pipeline (its adaptive threshold and constant-velocity prior) on sensor-frame clouds."""
    from kiss_icp.config import KISSConfig
    from kiss_icp.kiss_icp import KissICP

    config = KISSConfig()
    config.data.deskew, config.data.max_range, config.data.min_range = deskew, max_range_m, min_range_m
    config.mapping.voxel_size = voxel_m
    config.registration.max_num_threads = 1  # one core per worker, and the same poses on every run
    return KissICP(config=config)


def motion_from_poses(times_s: np.ndarray, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Forward speed and yaw rate between consecutive base-frame poses; the first frame repeats the second's."""
    k = len(poses)
    speed, yaw_rate = np.zeros(k), np.zeros(k)
    for i in range(1, k):
        dt = times_s[i] - times_s[i - 1]
        if not dt > 0:
            raise RuntimeError(f"odometry: frame {i} is not later than frame {i - 1} ({dt:+.6f} s)")
        step = np.linalg.solve(poses[i - 1], poses[i])  # motion in the previous frame's base frame
        speed[i] = step[0, 3] / dt
        yaw_rate[i] = math.atan2(step[1, 0], step[0, 0]) / dt
    if k > 1:
        speed[0], yaw_rate[0] = speed[1], yaw_rate[1]
    return speed, yaw_rate


def estimate(inputs, config: Optional[Config] = None, *, frames=(0, None), frame_rate: float = 10.0,
             max_range_m: float = 100.0, quiet: bool = True, **source_options) -> Odometry:
    """KISS-ICP odometry of a recording (any input ``rp.drive.open_source`` reads). Frames without a
    timestamp are ``1/frame_rate`` apart. Raises RuntimeError naming the input when it has fewer than two
    frames."""
    cfg = config if config is not None else Config()
    mount = mounting_matrix(cfg)
    unmount = np.linalg.inv(mount)
    pipeline = kiss_icp(max_range_m)
    times, poses = [], []
    first, last = frames
    for index, frame in enumerate(drive.open_source(inputs, **source_options)):
        if last is not None and index >= last:
            break
        if index < first:
            continue
        points = np.asarray(frame.points[:, :3], dtype=np.float64)
        points = points[np.isfinite(points).all(axis=1)]
        pipeline.register_frame(points, np.zeros(len(points)))
        poses.append(mount @ pipeline.last_pose @ unmount)
        times.append(frame.timestamp if frame.timestamp is not None else index / frame_rate)
        if not quiet:
            x, y = poses[-1][0, 3], poses[-1][1, 3]
            print(f"[odometry {index}] x {x:.2f} m, y {y:.2f} m", flush=True, file=__import__("sys").stderr)
    name = os.fspath(inputs if isinstance(inputs, (str, os.PathLike)) else inputs[0])
    if len(poses) < 2:
        raise RuntimeError(f"{name}: odometry needs at least two frames, the input has {len(poses)}")
    times_s, poses_arr = np.asarray(times, dtype=float), np.stack(poses)
    speed, yaw_rate = motion_from_poses(times_s, poses_arr)
    return Odometry(times_s, poses_arr, speed, yaw_rate)


def read_kitti_matrices(path) -> np.ndarray:
    """(K, 4, 4) poses of a KITTI poses file (12 numbers per line)."""
    rows = np.loadtxt(os.fspath(path), ndmin=2)
    if rows.shape[1] != 12:
        raise RuntimeError(f"{os.fspath(path)}: a KITTI pose needs 12 numbers per line, found {rows.shape[1]}")
    out = np.tile(np.eye(4), (len(rows), 1, 1))
    out[:, :3, :] = rows.reshape(-1, 3, 4)
    return out


def compare(estimated: np.ndarray, reference: np.ndarray, times_s: np.ndarray) -> dict:
    """Speed error (m/s, from the distance between consecutive positions, frame conventions aside) and the
    translation drift: end-point distance between the two trajectories after aligning their starts, in % of
    the reference's path length."""
    def speeds(p):
        return np.linalg.norm(np.diff(p[:, :3, 3], axis=0), axis=1) / np.diff(times_s)

    k = min(len(estimated), len(reference))
    est, ref = estimated[:k], reference[:k]
    est_rel = np.linalg.inv(est[0]) @ est
    ref_rel = np.linalg.inv(ref[0]) @ ref
    v_est, v_ref = speeds(est_rel), speeds(ref_rel)
    length = float(np.sum(np.linalg.norm(np.diff(ref_rel[:, :3, 3], axis=0), axis=1)))
    end_est = np.linalg.norm(est_rel[-1, :3, 3])
    end_ref = np.linalg.norm(ref_rel[-1, :3, 3])
    return {"frames": k, "path_m": length, "speed_ref_mps": v_ref.tolist(), "speed_est_mps": v_est.tolist(),
            "speed_error_max_mps": float(np.max(np.abs(v_est - v_ref))),
            "speed_error_mean_mps": float(np.mean(v_est - v_ref)),
            "drift_percent": 100.0 * abs(end_est - end_ref) / length if length > 0 else float("nan")}
