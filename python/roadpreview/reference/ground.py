"""Ground segmentation (docs/method.md §1 Ground): ROI, PCA plane fit, iterative `pca` and `ransac` methods."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..config import Config

# Relative size of the middle covariance eigenvalue below which a point set is a line (or a point),
# so its plane normal is undefined.
_DEGENERATE_RATIO = 1e-12


class DegenerateFit(ValueError):
    """A plane cannot be fitted: fewer than 3 points or all of them on one line."""


class NoPlaneWithinTilt(DegenerateFit):
    """The points span a plane, but none within the tilt limit."""


def roi_mask(base_xyz: np.ndarray, cfg: Config) -> np.ndarray:
    g = cfg.ground
    x, y = base_xyz[:, 0], base_xyz[:, 1]
    return (x >= g.roi_x_min_m) & (x <= g.roi_x_max_m) & (np.abs(y) <= g.roi_y_abs_max_m)


def roi_facing(cfg: Config, direction: float) -> Config:
    """``cfg`` with the region of interest behind the vehicle when reversing (direction < 0): x in
    [-roi_x_max_m, -roi_x_min_m]; unchanged otherwise."""
    if direction >= 0:
        return cfg
    g = cfg.ground
    behind = dataclasses.replace(g, roi_x_min_m=-g.roi_x_max_m, roi_x_max_m=-g.roi_x_min_m)
    return dataclasses.replace(cfg, ground=behind)


def fit_plane(points_xyz) -> np.ndarray:
    """PCA plane (a, b, c, d) with unit normal and c > 0 (c = 0 keeps the solver's sign). Non-finite points are
    a ValueError (not a DegenerateFit, which callers take as "no plane here")."""
    xyz = np.asarray(points_xyz, dtype=np.float64)[:, :3]
    bad = ~np.isfinite(xyz).all(axis=1)
    if bad.any():
        row = int(np.argmax(bad))
        raise ValueError(f"points_xyz must be finite, got {xyz[row].tolist()} in row {row}")
    if len(xyz) < 3:
        raise DegenerateFit(f"a plane needs at least 3 points, got {len(xyz)}")
    centre = xyz.mean(axis=0)
    offsets = xyz - centre
    covariance = offsets.T @ offsets / len(xyz)
    eigenvalues, eigenvectors = np.linalg.eigh(covariance)  # ascending
    if eigenvalues[1] <= _DEGENERATE_RATIO * eigenvalues[2]:
        raise DegenerateFit("the points are collinear or coincident")
    normal = eigenvectors[:, 0]
    if normal[2] < 0:
        normal = -normal
    return np.append(normal, -normal @ centre)


def tilt_deg(plane) -> float:
    """Angle between the plane's normal and the base frame's up axis, degrees."""
    return math.degrees(math.acos(min(1.0, max(-1.0, float(plane[2])))))


def height_above(xyz: np.ndarray, plane: np.ndarray) -> np.ndarray:
    return xyz @ plane[:3] + plane[3]


NO_GROUND = "no ground"
NO_ROI_POINTS = "no points in the region of interest"  #: nothing to fit ground to: the sensor looks elsewhere
TILTED_GROUND = "no ground within the tilt limit"  #: the only plane found is steeper than ground.max_tilt_deg


@dataclass
class GroundModel:
    mask: np.ndarray  #: bool per point: ground
    plane: np.ndarray | None  #: the frame's plane (a, b, c, d), None without ground
    reason: str | None = None  #: why there is no ground


def fit_ground(base_xyz, cfg: Config | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """Ground mask over ``base_xyz`` and the ground plane, or (all False, None) when there is no ground."""
    model = ground_model(base_xyz, cfg)
    return model.mask, model.plane


def ground_model(base_xyz, cfg: Config | None = None) -> GroundModel:
    """The ground of the ROI points among ``base_xyz`` by cfg.ground.method, with the tilt limit applied."""
    from .zones import zone_ground  # zones builds on this module's plane fit

    cfg = cfg or Config()
    xyz = np.asarray(base_xyz, dtype=np.float64)
    roi = np.flatnonzero(roi_mask(xyz, cfg))
    fitters = {"pca": _pca_ground, "ransac": _ransac_ground}
    if cfg.ground.method not in (*fitters, "zones"):
        raise ValueError(f"unknown ground method {cfg.ground.method!r}; expected 'zones', 'pca' or 'ransac'")
    mask = np.zeros(len(xyz), dtype=bool)
    if len(roi) == 0:
        return GroundModel(mask, None, NO_ROI_POINTS)
    if cfg.ground.method == "zones":
        in_roi, plane, too_steep = zone_ground(xyz[roi], cfg)
        ground = np.flatnonzero(in_roi)
        if plane is None and too_steep:
            return GroundModel(mask, None, TILTED_GROUND)
    else:
        try:
            ground, plane = fitters[cfg.ground.method](xyz[roi], cfg)
        except NoPlaneWithinTilt:
            return GroundModel(mask, None, TILTED_GROUND)
        except DegenerateFit:
            plane = None
    if plane is None:
        return GroundModel(mask, None, NO_GROUND)
    # A wall, a bank of vegetation: not ground (zones: each patch was held to the limit, not the frame's plane).
    if cfg.ground.method != "zones" and tilt_deg(plane) > cfg.ground.max_tilt_deg:
        return GroundModel(mask, None, TILTED_GROUND)
    mask[roi[ground]] = True
    return GroundModel(mask, plane)


def _pca_ground(xyz: np.ndarray, cfg: Config) -> tuple[np.ndarray, np.ndarray]:
    """The paper's method: refit and drop points too far ABOVE the plane, `pca_iterations` times; then the
    points more than max_depth_m below the last plane (they took part in the fits) are not ground either."""
    g = cfg.ground
    if g.pca_iterations < 1:
        raise ValueError(f"ground.pca_iterations must be >= 1, got {g.pca_iterations}")
    kept = np.arange(len(xyz))
    for _ in range(g.pca_iterations):
        plane = fit_plane(xyz[kept])
        kept = kept[height_above(xyz[kept], plane) <= g.pca_threshold_m]
    kept = kept[height_above(xyz[kept], plane) >= -g.max_depth_m]
    if len(kept) < 3:
        raise DegenerateFit("fewer than 3 ground points")
    return kept, plane


def _ransac_ground(xyz: np.ndarray, cfg: Config) -> tuple[np.ndarray, np.ndarray]:
    """Best near-horizontal 3-point plane, refined by PCA on its inliers."""
    g = cfg.ground
    best = _ransac_best_plane(xyz, cfg)
    plane = fit_plane(xyz[np.abs(height_above(xyz, best)) <= g.ransac_distance_m])
    ground = np.flatnonzero(np.abs(height_above(xyz, plane)) <= g.ransac_distance_m)
    if len(ground) < 3:
        raise DegenerateFit("fewer than 3 ground points")
    return ground, plane


def _ransac_best_plane(xyz: np.ndarray, cfg: Config) -> np.ndarray:
    g = cfg.ground
    if len(xyz) < 3:
        raise DegenerateFit(f"a plane needs at least 3 points, got {len(xyz)}")
    rng = np.random.default_rng(g.ransac_seed)
    min_up = math.cos(math.radians(g.max_tilt_deg))
    best, best_count = None, 0
    for _ in range(g.ransac_max_iterations):
        plane = _plane_through(xyz[rng.choice(len(xyz), size=3, replace=False)])
        if plane is None or plane[2] < min_up:  # collinear sample, or tilted too far from the up axis
            continue
        count = np.count_nonzero(np.abs(height_above(xyz, plane)) <= g.ransac_distance_m)
        if count > best_count:
            best, best_count = plane, count
    if best is None:
        steep = False
        try:
            steep = tilt_deg(fit_plane(xyz)) > g.max_tilt_deg  # do the points span a plane, only a steep one?
        except DegenerateFit:
            pass
        raise (NoPlaneWithinTilt if steep else DegenerateFit)("no RANSAC sample gave a plane within the tilt limit")
    return best


def _plane_through(triangle: np.ndarray) -> np.ndarray | None:
    """Plane (unit normal, c >= 0) through three points, or None if they are (nearly) collinear."""
    normal = np.cross(triangle[1] - triangle[0], triangle[2] - triangle[0])
    length = np.linalg.norm(normal)
    if length < 1e-12:
        return None
    normal = normal / length
    if normal[2] < 0:
        normal = -normal
    return np.append(normal, -normal @ triangle[0])
