"""A rectified stereo camera: pinhole, baseline, mounting height and pitch, rendering disparity images of a Scene.

Camera frame (as roadpreview reads stereo points): origin at the left camera's optical centre, x along the optical
axis, y left, z up; pixel (u right, v down) looks along (1, −(u − cx)/f, −(v − cy)/f). The disparity of a pixel
whose ray meets the scene at depth z (along the axis) is f·B/z, plus Gaussian sub-pixel noise — independent from
pixel to pixel, or correlated as a block matcher's errors are (an exponential correlation exp(−|Δu|/L_u −
|Δv|/L_v) along and across the rows); pixels that see nothing within max_depth_m, and a random fraction of the rest
(matching failures), are invalid (0). Occlusions between the two views are not modelled: every pixel the left
camera sees is matched.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .drive import Pose, trajectory
from .scene import LABEL_NONE, Scene, cast


@dataclass(frozen=True)
class StereoCamera:
    name: str = "stereo"
    focal_px: float = 721.5377  #: fx = fy of the rectified pair
    baseline_m: float = 0.5327
    width_px: int = 1242
    rows_px: int = 375
    cx_px: float = 609.5593
    cy_px: float = 172.854
    height_m: float = 1.65  #: optical centre above the base origin (on the ground)
    pitch_deg: float = 0.0  #: positive looks down (R = Ry(pitch), as roadpreview's extrinsics define it)
    disparity_noise_px: float = 0.25  #: 1σ Gaussian noise of each valid disparity
    #: correlation lengths (px) of the disparity noise along the rows (u) and across them (v); 0: independent
    noise_correlation_px: tuple[float, float] = (0.0, 0.0)
    invalid_fraction: float = 0.02  #: share of the pixels that see the scene but get no disparity
    max_depth_m: float = 45.0  #: farther pixels are invalid (and rows that only see farther road are not rendered)

    def __post_init__(self):
        if not (self.focal_px > 0 and self.baseline_m > 0 and self.width_px > 0 and self.rows_px > 0):
            raise ValueError(f"{self.name}: focal_px, baseline_m, width_px and rows_px must be > 0")
        if not (0 <= self.invalid_fraction < 1 and self.disparity_noise_px >= 0 and self.max_depth_m > 0):
            raise ValueError(f"{self.name}: need 0 <= invalid_fraction < 1, disparity_noise_px >= 0, max_depth_m > 0")
        if len(self.noise_correlation_px) != 2 or not all(c >= 0 for c in self.noise_correlation_px):
            raise ValueError(f"{self.name}: noise_correlation_px must be two lengths >= 0 (along, across the rows), "
                             f"got {self.noise_correlation_px!r}")

    def with_(self, **changes) -> "StereoCamera":
        return dataclasses.replace(self, **changes)

    def mount_rotation(self) -> np.ndarray:
        """Camera-to-base rotation Ry(pitch)."""
        p = math.radians(self.pitch_deg)
        return np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])

    def extrinsics(self) -> dict:
        """The camera's pose in the base frame as a ``roadpreview.Config(extrinsics=...)`` value."""
        return {"x_m": 0.0, "y_m": 0.0, "z_m": self.height_m, "roll_rad": 0.0,
                "pitch_rad": math.radians(self.pitch_deg), "yaw_rad": 0.0}

    def calibration(self) -> dict:
        """fx, fy, cx, cy (px) and baseline (m), the keys of a stereo calibration YAML."""
        return {"fx": self.focal_px, "fy": self.focal_px, "cx": self.cx_px, "cy": self.cy_px,
                "baseline": self.baseline_m}

    def write_calibration(self, path) -> Path:
        """A calibration YAML (fx, fy, cx, cy, baseline, extrinsics) that ``rp.io.stereo_points`` and the CLI read."""
        lines = [f"{k}: {v!r}" for k, v in self.calibration().items()] + ["extrinsics:"]
        lines += [f"  {k}: {v!r}" for k, v in self.extrinsics().items()]
        Path(path).write_text("\n".join(lines) + "\n")
        return Path(path)

    def first_row(self) -> int:
        """The first row that sees the base plane nearer than max_depth_m (rows above see only farther road)."""
        ahead = self.mount_rotation().T @ np.array([self.max_depth_m, 0.0, -self.height_m])
        return int(min(max(math.floor(self.cy_px - self.focal_px * ahead[2] / ahead[0]), 0), self.rows_px))

    def directions(self, first_row: int) -> np.ndarray:
        """Unit rays (camera frame) of the pixels of rows first_row … rows_px − 1, row by row."""
        v, u = np.mgrid[first_row:self.rows_px, 0:self.width_px]
        d = np.stack([np.ones(v.shape), -(u - self.cx_px) / self.focal_px, -(v - self.cy_px) / self.focal_px], -1)
        d = d.reshape(-1, 3)
        return d / np.linalg.norm(d, axis=1, keepdims=True)


def kitti_stereo(**changes) -> StereoCamera:
    """KITTI's colour pair (rectified image_2/image_3, 2011_09_26 calibration: fx = 721.5377 px, baseline
    0.5327 m, 1242 × 375) mounted 1.65 m high, looking level (Geiger et al., IJRR 2013)."""
    return StereoCamera("KITTI colour pair").with_(**changes)


#: OpenCV StereoSGBM's disparity errors on the bundled KITTI pair's road, measured against the Velodyne scan of the
#: same instant (bench/stereo.py --parts noise): σ ≈ 0.3 px, correlated over ≈ 15 px along the rows, ≈ 2 across.
SGBM_ON_KITTI = {"disparity_noise_px": 0.3, "noise_correlation_px": (15.0, 2.0)}


def correlated_noise(shape: tuple[int, int], sigma: float, lengths: tuple[float, float],
                     rng: np.random.Generator) -> np.ndarray:
    """Gaussian noise of standard deviation sigma on a (rows, columns) grid with the correlation
    exp(−|Δcolumn|/lengths[0] − |Δrow|/lengths[1]): a stationary first-order autoregression along each axis."""
    field = rng.normal(0.0, 1.0, shape)
    for axis, length in ((1, lengths[0]), (0, lengths[1])):
        if length <= 0:
            continue
        rho = math.exp(-1.0 / length)
        field = np.moveaxis(field, axis, 0)  # a view: the recursion runs along its first index
        for k in range(1, field.shape[0]):
            field[k] = rho * field[k - 1] + math.sqrt(1.0 - rho * rho) * field[k]
        field = np.moveaxis(field, 0, axis)
    return sigma * field


@dataclass
class StereoFrame:
    index: int
    time_s: float
    pose: Pose
    disparity: np.ndarray  #: (rows_px, width_px) float32 px, 0 = invalid
    labels: np.ndarray  #: (rows_px, width_px) uint8 LABEL_* of the surface each pixel sees
    depth_m: np.ndarray  #: (rows_px, width_px) exact depth along the axis (inf: nothing)


def render(scene: Scene, camera: StereoCamera, pose: Pose, rng: np.random.Generator) -> StereoFrame:
    """One disparity image from the given vehicle pose (index, time 0; see StereoFrame)."""
    first = camera.first_row()
    d_cam = camera.directions(first)
    c, s = math.cos(pose.yaw_rad), math.sin(pose.yaw_rad)
    rotation = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ camera.mount_rotation()
    origin = np.array([pose.x_m, pose.y_m, float(scene.road.plane_height(pose.x_m, pose.y_m)) + camera.height_m])
    t, labels = cast(scene, origin, d_cam @ rotation.T, camera.max_depth_m / np.min(d_cam[:, 0]))
    depth = t * d_cam[:, 0]  # along the optical axis
    seen = np.isfinite(depth) & (depth <= camera.max_depth_m)
    disparity = np.zeros(len(depth))
    disparity[seen] = camera.focal_px * camera.baseline_m / depth[seen]
    if any(camera.noise_correlation_px):
        field = correlated_noise((camera.rows_px - first, camera.width_px), camera.disparity_noise_px,
                                 camera.noise_correlation_px, rng).ravel()
        disparity[seen] += field[seen]
    else:
        disparity[seen] += rng.normal(0.0, camera.disparity_noise_px, np.count_nonzero(seen))
    disparity[rng.random(len(depth)) < camera.invalid_fraction] = 0.0
    shape = (camera.rows_px, camera.width_px)
    full = lambda values, fill, dtype: np.concatenate([np.full(first * camera.width_px, fill, dtype),  # noqa: E731
                                                        values.astype(dtype)]).reshape(shape)
    return StereoFrame(0, 0.0, pose, full(np.maximum(disparity, 0.0), 0.0, np.float32),
                       full(np.where(seen, labels, LABEL_NONE), LABEL_NONE, np.uint8),
                       full(np.where(seen, depth, np.inf), np.inf, np.float64))


def drive_stereo(scene: Scene, camera: StereoCamera, speed_mps: float, yaw_rate_rps: float = 0.0, frames: int = 10,
                 rate_hz: float = 10.0, seed: int = 0) -> list[StereoFrame]:
    """Disparity images recorded while driving at constant speed and yaw rate; deterministic for a given seed."""
    streams = np.random.SeedSequence(seed).spawn(frames)
    out = []
    for i, pose in enumerate(trajectory(speed_mps, yaw_rate_rps, frames, rate_hz)):
        frame = render(scene, camera, pose, np.random.default_rng(streams[i]))
        out.append(dataclasses.replace(frame, index=i, time_s=i / rate_hz))
    return out
