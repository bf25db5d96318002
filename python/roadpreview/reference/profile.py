"""Wheel height profiles (docs/method.md §3 Profiles): levelling, wheel corridors and arc length,
median binning and gap filling. `wheel_profile` also fills in the profile's roughness (§4) and IRI (§6)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Optional

import numpy as np

from ..config import Config
from .path import wheel_y
from .iri import Iri, wheel_iri
from .roughness import Roughness, analyze_roughness
from .runs import true_runs
from .stereo import groups_per_bin

# Tolerance on "run length ≤ max_gap_m", so that e.g. 3 bins × 0.1 m count as 0.3 m.
_GAP_LENGTH_TOLERANCE = 1e-9


@dataclass
class Profile:
    s: np.ndarray = field(default_factory=lambda: np.zeros(0))  #: bin centres, m
    z: np.ndarray = field(default_factory=lambda: np.zeros(0))  #: median height per bin, NaN = missing
    count: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))  #: points per bin
    spread: np.ndarray = field(default_factory=lambda: np.zeros(0))  #: sample std of the bin's heights, NaN below 2
    roughness: Roughness = field(default_factory=Roughness)
    blocked: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))  #: bin covered by an obstacle
    obstacles: Optional[Any] = None  #: obstacles.PathObstacles in this wheel's path; None: clustering is off


def levelling_rotation(plane) -> np.ndarray:
    """The rotation about the origin that takes the plane normal n onto ẑ along the shortest arc."""
    normal = np.asarray(plane[:3], dtype=np.float64)
    normal = normal / np.linalg.norm(normal)
    # Rodrigues for a onto b: R = I + [v]× + [v]×² / (1 + a·b), v = a × b; identity when n = ẑ.
    vx, vy, vz = np.cross(normal, [0.0, 0.0, 1.0])
    skew = np.array([[0, -vz, vy], [vz, 0, -vx], [-vy, vx, 0]])
    return np.eye(3) + skew + skew @ skew / (1 + normal[2])


def level_points(xyz, plane) -> np.ndarray:
    """Rotate the points about the origin so the plane normal n goes onto ẑ along the shortest arc (z' = n·p)."""
    return np.asarray(xyz, dtype=np.float64) @ levelling_rotation(plane).T


def arc_length(xy: np.ndarray, path: dict, wheel: str, speed: float, yaw_rate: float, cfg: Config):
    """(s, in_corridor) per point: signed distance along the wheel's path (ahead ≥ 0) and corridor membership."""
    half_tire = cfg.tire_width / 2
    y_wheel = wheel_y(wheel, cfg)
    if path["status"] == "straight":
        return math.copysign(1.0, speed) * xy[:, 0], np.abs(xy[:, 1] - y_wheel) <= half_tire
    radius = path[f"{wheel}_radius"]
    u = xy - [0.0, path["icr_y"]]  # points relative to the ICR
    w0 = np.array([0.0, y_wheel - path["icr_y"]])  # the wheel relative to the ICR
    cross = w0[0] * u[:, 1] - w0[1] * u[:, 0] + 0.0  # + 0.0 turns −0 into +0, so φ = π, never −π
    phi = np.arctan2(cross, u @ w0)
    in_corridor = (np.abs(np.hypot(u[:, 0], u[:, 1]) - radius) <= half_tire) & (radius > 0)
    # The wheel turns in the sense of ω whatever the sign of V: ahead when sign(φ) = sign(ω).
    return math.copysign(1.0, yaw_rate) * phi * radius, in_corridor


def bin_count(cfg: Config) -> int:
    p = cfg.profile
    return math.ceil(p.preview_length_m / p.ds_m - 1e-9)


def bin_statistics(s: np.ndarray, z: np.ndarray, cfg: Config,
                   variances=None, error_groups=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(median z, count, spread) per bin k = floor(s/ds) for points with 0 <= s < preview_length_m; the spread is
    the sample standard deviation (n − 1 in the denominator) of the bin's heights, NaN below 2 points. With the
    points' height ``variances`` (m²) it is at least the root of their mean in the bin (a single point's: the root
    of its own), and with their ``error_groups`` it is scaled by √(points / distinct groups) in the bin (method.md
    §12)."""
    k_bins = bin_count(cfg)
    kept = (s >= 0) & (s < cfg.profile.preview_length_m)
    # s just below the preview length can round to bin K; it still belongs to the last bin.
    k = np.minimum(np.floor(s[kept] / cfg.profile.ds_m).astype(np.int64), k_bins - 1)
    order = np.lexsort((z[kept], k))  # by bin, then by height
    k, z_sorted = k[order], z[kept][order]
    count = np.bincount(k, minlength=k_bins).astype(np.int64)
    first = np.concatenate(([0], np.cumsum(count)[:-1]))
    filled = count > 0
    lower = first[filled] + (count[filled] - 1) // 2  # the two middle values coincide for odd counts
    upper = first[filled] + count[filled] // 2
    median = np.full(k_bins, np.nan)
    median[filled] = (z_sorted[lower] + z_sorted[upper]) / 2
    mean = np.bincount(k, weights=z_sorted, minlength=k_bins) / np.maximum(count, 1)
    squares = np.bincount(k, weights=(z_sorted - mean[k]) ** 2, minlength=k_bins)
    spread = np.full(k_bins, np.nan)
    multi = count >= 2
    spread[multi] = np.sqrt(squares[multi] / (count[multi] - 1))
    if variances is not None:
        mean_variance = np.bincount(k, weights=np.asarray(variances, float)[kept][order], minlength=k_bins)
        mean_variance /= np.maximum(count, 1)
        spread[multi] = np.sqrt(np.maximum(spread[multi] ** 2, mean_variance[multi]))
        single = (count == 1) & (mean_variance > 0)  # one point: the variance its sensor states
        spread[single] = np.sqrt(mean_variance[single])
    if error_groups is not None:
        groups = groups_per_bin(k, np.asarray(error_groups)[kept][order], k_bins)
        spread[multi] *= np.sqrt(count[multi] / groups[multi])
    return median, count, spread


def fill_gaps(z, ds: float, max_gap_m: float, blocked=None) -> np.ndarray:
    """Linearly interpolate interior NaN runs no longer than max_gap_m; leading/trailing runs stay NaN.

    A ``blocked`` bin (obstacle) counts as missing, and a run holding one is left as it is.
    """
    z = np.array(z, dtype=np.float64)
    blocked = np.zeros(len(z), dtype=bool) if blocked is None else np.asarray(blocked, dtype=bool)
    if blocked.shape != z.shape:
        raise ValueError(f"blocked has shape {blocked.shape}, z has {z.shape}")
    for start, stop in true_runs(np.isnan(z) | blocked):
        interior = start > 0 and stop < len(z)
        if interior and not blocked[start:stop].any() and (stop - start) * ds <= max_gap_m + _GAP_LENGTH_TOLERANCE:
            left, right = z[start - 1], z[stop]
            fraction = np.arange(1, stop - start + 1) / (stop - start + 1)
            z[start:stop] = left + (right - left) * fraction
    return z


LEVEL_CORRIDOR_HALF_WIDTH_M = 1.5  # the wheel tracks (track ≤ 2 m) and a margin, not the pavements and cars beside
LEVEL_MIN_SPAN = 0.5  # of the band: the corridor points must span this much range to tell a grade
LEVEL_KEEP_M = 0.2  # refits keep the corridor points this close to the last plane, either side,
LEVEL_KEEP_SIGMAS = 3.0  # and this many robust standard deviations of their heights above it
LEVEL_KEEP_MIN_M = 0.005  # (at least this much) from the median of those heights
LEVEL_REFITS = 8  # at most: refits stop when they keep the same points


def distance_from_path(xy: np.ndarray, path: dict) -> np.ndarray:
    """Distance of base-frame points from the path of the vehicle's centre: |y| straight, from its circle about
    the ICR on an arc (method.md §3)."""
    if path["status"] != "arc":
        return np.abs(xy[:, 1])
    return np.abs(np.hypot(xy[:, 0], xy[:, 1] - path["icr_y"]) - abs(path["icr_y"]))


def _band_plane(xyz: np.ndarray) -> np.ndarray:
    """PCA plane of a band's corridor points, refitted to those near it until they no longer change: spurious
    returns far below the road are ground to the paper's rule, which drops only points above, and a bump is relief,
    not the ground's grade. Raises DegenerateFit."""
    from .ground import DegenerateFit, fit_plane, height_above

    plane = fit_plane(xyz)
    kept = np.ones(len(xyz), dtype=bool)
    for _ in range(LEVEL_REFITS):
        h = height_above(xyz, plane)
        near = np.abs(h) <= LEVEL_KEEP_M
        if near.any():
            centre = np.median(h[near])
            sigma = 1.4826 * np.median(np.abs(h[near] - centre))  # robust standard deviation
            near &= np.abs(h - centre) <= max(LEVEL_KEEP_SIGMAS * sigma, LEVEL_KEEP_MIN_M)
        if np.array_equal(near, kept):
            break  # the same points as the last fit
        kept = near
        try:
            plane = fit_plane(xyz[near])
        except DegenerateFit:
            break  # too few points, or collinear ones, are left: the last fit stands
    return plane


@dataclass
class LocalGround:
    """One frame's local ground model (method.md §3): a plane per band ⌊r / band_m⌋ of horizontal range that has
    corridor points, the frame plane elsewhere; ``direction`` is the side of the base origin the corridor lies on."""

    planes: dict
    frame: np.ndarray
    band_m: float
    direction: float = 1.0

    def heights(self, xyz) -> np.ndarray:
        """Heights of base-frame points above the model, blended between band centres: a point t bands from its
        band's centre (|t| ≤ ½) takes |t| of its height above the neighbour band it lies towards, when that band
        has a plane of its own — continuous where bands meet. A point on the other side of the base origin (road
        already driven) takes the nearest band's plane alone: the farther bands lie ahead."""
        from .ground import height_above

        xyz = np.asarray(xyz, dtype=np.float64)[:, :3]
        r = np.hypot(xyz[:, 0], xyz[:, 1])
        band = np.floor(r / self.band_m)
        position = r / self.band_m - band - 0.5
        behind = xyz[:, 0] * self.direction < 0
        band[behind], position[behind] = 0, 0.0
        neighbour = band + np.where(position < 0, -1, 1)
        z = np.empty(len(xyz))
        for k in np.unique(band):
            mine = band == k
            z[mine] = height_above(xyz[mine], self.planes.get(k, self.frame))
            for j in (k - 1, k + 1):
                towards = mine & (neighbour == j) & ~behind
                if j in self.planes and towards.any():
                    w = np.abs(position[towards])
                    z[towards] = (1 - w) * z[towards] + w * height_above(xyz[towards], self.planes[j])
        return z


def local_ground_model(ground_xyz, plane, cfg: Config, path: dict | None = None,
                       direction: float = 1.0) -> LocalGround:
    """The local ground model of a frame's ground points (method.md §3). Bands are ⌊r / level_band_m⌋ of
    horizontal distance r; a band's plane is fitted to its ground points within 1.5 m of the vehicle's path
    (straight ahead without ``path``) when they span at least half the band in range, and refitted to those
    within 0.2 m of the last fit and 3 robust standard deviations of their median height above it until they no
    longer change; a band
    whose points span less (or whose fit is degenerate) gets the normal of the nearest fitted band (the frame
    plane's if there is none) through the median of its points; a band without corridor points, the frame
    plane."""
    from .ground import DegenerateFit  # the profile builds on the ground stage's fit

    xyz = np.asarray(ground_xyz, dtype=np.float64)[:, :3]
    frame = np.asarray(plane, dtype=np.float64)
    band = np.floor(np.hypot(xyz[:, 0], xyz[:, 1]) / cfg.profile.level_band_m)
    near = distance_from_path(xyz[:, :2], path or {"status": "straight"}) <= LEVEL_CORRIDOR_HALF_WIDTH_M
    planes, short = {}, {}
    for k in np.unique(band[near]):
        corridor = xyz[(band == k) & near]
        r = np.hypot(corridor[:, 0], corridor[:, 1])
        if np.ptp(r) >= LEVEL_MIN_SPAN * cfg.profile.level_band_m:  # else a short patch: it cannot tell a grade
            try:
                planes[k] = _band_plane(corridor)
                continue
            except DegenerateFit:
                pass
        short[k] = corridor
    fitted = sorted(planes)
    for k, corridor in short.items():
        normal = planes[min(fitted, key=lambda j: (abs(j - k), j))][:3] if fitted else frame[:3]
        planes[k] = np.append(normal, -np.median(corridor @ normal))
    return LocalGround(planes, frame, cfg.profile.level_band_m, direction)


def local_ground_heights(ground_xyz, plane, cfg: Config, path: dict | None = None,
                         direction: float = 1.0) -> np.ndarray:
    """Each ground point's height above the local ground model of the points (:func:`local_ground_model`), the
    vehicle driving forward (``direction`` 1) or reversing (−1)."""
    return local_ground_model(ground_xyz, plane, cfg, path, direction).heights(ground_xyz)


def empty_profile(reason: str) -> Profile:
    return Profile(roughness=Roughness(reason=reason, iri=Iri(reason=reason)))


def wheel_profile(ground_xyz, plane, path: dict, wheel: str, speed, yaw_rate,
                  cfg: Config | None = None, blocked=None, height_variances=None, error_groups=None) -> Profile:
    """Height profile along one wheel's path from ground points (levelled by ``plane`` unless it is None),
    with its roughness analysed. A stopped path gives an empty profile with reason "vehicle stopped".
    ``blocked`` bins (obstacles, method.md §5) get no height and are not interpolated across.
    With ``profile.level_local`` the heights are those of :func:`local_ground_heights` (method.md §3);
    ``height_variances`` (m², one per point) and ``error_groups`` raise the bins' spreads (method.md §12)."""
    cfg = cfg or Config()
    if path["status"] == "stopped":
        return empty_profile("vehicle stopped")
    xyz = np.asarray(ground_xyz, dtype=np.float64)[:, :3]
    if cfg.profile.level and plane is not None:
        xyz = level_points(xyz, plane)
        if cfg.profile.level_local:
            xyz[:, 2] = local_ground_heights(ground_xyz, plane, cfg, path, math.copysign(1.0, speed))
    s, in_corridor = arc_length(xyz[:, :2], path, wheel, float(speed), float(yaw_rate), cfg)
    variances = None if height_variances is None else np.asarray(height_variances, float)[in_corridor]
    groups = None if error_groups is None else np.asarray(error_groups)[in_corridor]
    median, count, spread = bin_statistics(s[in_corridor], xyz[in_corridor, 2], cfg, variances, groups)
    blocked = np.zeros(len(median), dtype=bool) if blocked is None else np.asarray(blocked, dtype=bool)
    median[blocked] = np.nan  # an obstacle's points are not road
    spread[blocked] = np.nan
    ds = cfg.profile.ds_m
    z = fill_gaps(median, ds, cfg.profile.max_gap_m, blocked)
    centres = (np.arange(len(z)) + 0.5) * ds
    roughness = analyze_roughness(z, ds, cfg, count=count, spread=spread)
    roughness.iri = wheel_iri(z, count, ds, roughness.iso_class, cfg, spread)
    return Profile(s=centres, z=z, count=count, spread=spread, roughness=roughness, blocked=blocked)
