"""Stereo cameras (docs/method.md §12): calibration, disparity → depth → points, their range variances and their
error groups.

Camera frame as roadpreview reads it: origin at the left camera's optical centre, x along the optical axis, y left,
z up; a pixel (u right, v down) at disparity d has depth z = fx·B/d and lies (u − cx)·z/fx to the right and
(v − cy)·z/fy below the axis.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..config import Config, StereoConfig
from .frames import rotation_matrix, sensor_origin


def kitti_calibration(path) -> dict:
    """fx, fy, cx, cy (px) and baseline (m) of the colour pair of a KITTI calib.txt: the rows P2 and P3; the
    baseline is (P2[0,3] − P3[0,3]) / fx (−P3[0,3]/fx is camera 3's offset from camera 0, not from camera 2)."""
    rows = {}
    for line in Path(path).read_text().splitlines():
        name, _, values = line.partition(":")
        if name.strip() in ("P2", "P3"):
            rows[name.strip()] = np.array(values.split(), dtype=float).reshape(3, 4)
    if "P2" not in rows or "P3" not in rows:
        raise ValueError(f"{path}: a KITTI stereo calibration needs the P2 and P3 lines")
    p2, p3 = rows["P2"], rows["P3"]
    baseline = (p2[0, 3] - p3[0, 3]) / p2[0, 0]
    if not baseline > 0:
        raise ValueError(f"{path}: the baseline must be > 0 m, got {baseline}")
    return {"fx": p2[0, 0], "fy": p2[1, 1], "cx": p2[0, 2], "cy": p2[1, 2], "baseline": baseline}


def first_road_row(calib: dict, rows: int, cfg: Config) -> int:
    """The image row of the point stereo.max_depth_m ahead and stereo.road_rise_m above the base plane, as the
    camera posed by cfg (sensor_height / extrinsics) sees it: rows above it see no road within max_depth_m."""
    s = cfg.stereo
    if cfg.extrinsics is not None:
        e = cfg.extrinsics
        rotation, origin = rotation_matrix(e.roll_rad, e.pitch_rad, e.yaw_rad), np.array([e.x_m, e.y_m, e.z_m])
    else:
        rotation, origin = np.eye(3), np.array([0.0, 0.0, cfg.sensor_height or 0.0])
    ahead, _, up = rotation.T @ (np.array([s.max_depth_m, 0.0, s.road_rise_m]) - origin)
    if ahead <= 0:
        return 0
    return int(min(max(math.floor(calib["cy"] - calib["fy"] * up / ahead), 0), rows))


def disparity_to_points(disparity, first_row: int, calib: dict, stereo: StereoConfig | None = None):
    """(points (N, 3) camera frame, range variances (N,) m², pixel indices (N,)) of the valid pixels of rows
    first_row … nearer than stereo.max_depth_m, row by row: a finite disparity d ≥ fx·B/max_depth_m (zero,
    negative, infinite and NaN disparities are invalid). Range variance: σ_z = z²·σ_d/(fx·B) along the axis,
    times r/z along the ray."""
    stereo = stereo or StereoConfig()
    d = np.asarray(disparity, dtype=np.float64)
    fb = calib["fx"] * calib["baseline"]
    v, u = np.mgrid[0:d.shape[0], 0:d.shape[1]]
    with np.errstate(invalid="ignore"):  # d = ∞ would be a point at the camera with a NaN variance
        valid = (v >= first_row) & np.isfinite(d) & (d >= fb / stereo.max_depth_m)
    z = fb / d[valid]
    right = (u[valid] - calib["cx"]) * z / calib["fx"]
    down = (v[valid] - calib["cy"]) * z / calib["fy"]
    points = np.column_stack([z, -right, -down])
    sigma_z = z ** 2 * stereo.disparity_sigma_px / fb
    sigma_r = sigma_z * np.linalg.norm(points, axis=1) / z
    return points, sigma_r ** 2, np.flatnonzero(valid.ravel())


def height_variances(base_xyz, range_variances, cfg: Config) -> np.ndarray:
    """Variance of each base-frame point's height from its range variance: a range error moves the point along its
    line of sight from the sensor, u_z metres up per metre."""
    ray = np.asarray(base_xyz, float)[:, :3] - sensor_origin(cfg)
    squared = np.einsum("ij,ij->i", ray, ray)
    uz2 = np.divide(ray[:, 2] ** 2, squared, out=np.ones(len(ray)), where=squared > 0)
    v = np.asarray(range_variances, float)
    return np.where(np.isfinite(v) & (v > 0), uz2 * v, 0.0)


def error_groups(pixels, width: int, stereo: StereoConfig | None = None) -> np.ndarray:
    """Each point's error group from its pixel index (row · width + column): the tile of 2·error_correlation_along_px
    columns by 2·error_correlation_across_px rows (at least one each, rounded half up) it lies in, numbered row by
    row. SGBM's errors are correlated over about that extent, so a tile's points hold about one independent error."""
    stereo = stereo or StereoConfig()
    tile_columns = max(1, math.floor(2 * stereo.error_correlation_along_px + 0.5))
    tile_rows = max(1, math.floor(2 * stereo.error_correlation_across_px + 0.5))
    v, u = np.divmod(np.asarray(pixels, np.int64), width)
    return (v // tile_rows * -(-width // tile_columns) + u // tile_columns).astype(np.int32)


def groups_per_bin(bins, groups, minlength: int) -> np.ndarray:
    """How many distinct error groups each bin (or cell) index in ``bins`` holds."""
    bins = np.asarray(bins, np.int64)
    if len(bins) == 0:
        return np.zeros(minlength, np.int64)
    pairs = np.unique(np.column_stack([bins, np.asarray(groups, np.int64)]), axis=0)
    return np.bincount(pairs[:, 0], minlength=minlength)
