"""Input checks and the sensor-to-base transform (docs/method.md §0 Frames)."""

from __future__ import annotations

import math

import numpy as np

from ..config import Config


def check_points(points) -> np.ndarray:
    """Return ``points`` as an N×C float array (C ≥ 3) in native byte order; a wrong shape is a ValueError, a
    wrong dtype a TypeError. float32 and float64 of either byte order are accepted (big-endian is converted)."""
    points = np.asarray(points)
    if points.ndim != 2:
        raise ValueError(f"points must be a 2-D N×C array (C >= 3), got shape {points.shape}")
    if points.shape[1] < 3:
        raise ValueError(f"points must have at least 3 columns (x, y, z), got shape {points.shape}")
    if points.dtype.kind != "f" or points.dtype.itemsize not in (4, 8):
        raise TypeError(f"points must be float32 or float64, got dtype {points.dtype}")
    return points.astype(points.dtype.newbyteorder("="), copy=False)


def check_per_point(values, points: np.ndarray, name: str) -> np.ndarray | None:
    """``values`` (None passes) as an array of one entry per row of ``points``; another shape is a ValueError."""
    if values is None:
        return None
    if np.shape(values) != (len(points),):
        raise ValueError(f"{name} must have one entry per point ({len(points)}), got shape {np.shape(values)}")
    return np.asarray(values)


def check_ids(values, points: np.ndarray, name: str) -> np.ndarray | None:
    """``values`` (None passes) as one integer id per row of ``points``: other dtypes are a TypeError (a float
    would be truncated), ids beyond int32 a ValueError (the C++ core's ids are int32)."""
    values = check_per_point(values, points, name)
    if values is None:
        return None
    if values.dtype.kind not in "iu":
        raise TypeError(f"{name} must be an integer array, got dtype {values.dtype}")
    int32 = np.iinfo(np.int32)
    if values.size and (values.min() < int32.min or values.max() > int32.max):
        raise ValueError(f"{name} must fit in int32, got values {values.min()}…{values.max()}")
    return values


def rotation_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """R = Rz(yaw) · Ry(pitch) · Rx(roll)."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def sensor_pose(cfg: Config) -> tuple[np.ndarray, np.ndarray]:
    """(R, t) of the sensor in the base frame; identity when neither extrinsics nor sensor_height is set."""
    if cfg.sensor_height is not None and cfg.extrinsics is not None:
        raise ValueError("set either sensor_height or extrinsics, not both")
    if cfg.sensor_height is not None:
        return np.eye(3), np.array([0.0, 0.0, float(cfg.sensor_height)])
    if cfg.extrinsics is not None:
        e = cfg.extrinsics
        return rotation_matrix(e.roll_rad, e.pitch_rad, e.yaw_rad), np.array([e.x_m, e.y_m, e.z_m], float)
    return np.eye(3), np.zeros(3)


def to_base_frame(points, cfg: Config | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Finite input points (in input order) in the base frame, and the N-long mask of the finite rows."""
    cfg = cfg or Config()
    points = check_points(points)
    rotation, translation = sensor_pose(cfg)
    xyz = points[:, :3].astype(np.float64)
    finite = np.isfinite(xyz).all(axis=1)
    return xyz[finite] @ rotation.T + translation, finite


def sensor_origin(cfg: Config) -> np.ndarray:
    """The sensor's position in the base frame (m): the extrinsics' translation, or (0, 0, sensor_height)."""
    if cfg.extrinsics is not None:
        return np.array([cfg.extrinsics.x_m, cfg.extrinsics.y_m, cfg.extrinsics.z_m])
    return np.array([0.0, 0.0, cfg.sensor_height or 0.0])
