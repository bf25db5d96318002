"""Zone ground (docs/method.md §1, method ``zones``): rings × sectors over the ROI, the paper's plane fit per patch,
then the uprightness, elevation and flatness tests. Written from the definition, patch by patch, for clarity."""

from __future__ import annotations

import math

import numpy as np

from ..config import Config
from .ground import DegenerateFit, fit_plane, height_above, tilt_deg

LEVEL = np.array([0.0, 0.0, 1.0, 0.0])  # the ground level the extrinsics give: z = 0 in the base frame


def patch_rings_sectors(xyz: np.ndarray, cfg: Config) -> tuple[np.ndarray, np.ndarray]:
    """(ring, sector) of each point; ring −1 outside every ring. Sector from φ = atan2(y, x) + π, φ = 2π as 0."""
    g = cfg.ground
    edges = np.asarray(g.zone_ring_edges_m, dtype=np.float64)
    sectors = np.asarray(g.zone_sectors, dtype=np.int64)
    ring = np.searchsorted(edges, np.hypot(xyz[:, 0], xyz[:, 1]), side="right") - 1
    ring[(ring < 0) | (ring >= len(sectors))] = -1
    count = sectors[np.maximum(ring, 0)]
    phi = np.arctan2(xyz[:, 1], xyz[:, 0]) + np.pi
    sector = np.mod(np.floor(phi / (2 * np.pi) * count).astype(np.int64), count)
    return ring, sector


def paper_fit(xyz: np.ndarray, start: np.ndarray, cfg: Config, eligible=True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The paper's iteration from the points `start` selects: (plane of the last fit, the points that fit was
    made on, the points it keeps — at most pca_threshold_m above it and max_depth_m below), among the points
    `eligible` marks (those that take part at all)."""
    kept = start
    for _ in range(cfg.ground.pca_iterations):
        fitted = kept
        plane = fit_plane(xyz[fitted])
        h = height_above(xyz, plane)
        kept = (h <= cfg.ground.pca_threshold_m) & (h >= -cfg.ground.max_depth_m) & eligible
    return plane, fitted, kept


def _spreads_and_centre(xyz: np.ndarray) -> tuple[float, float, np.ndarray]:
    """RMS distance of the points from their PCA plane (flatness), their RMS spread across their longest
    direction within it (breadth), and their mean."""
    centre = xyz.mean(axis=0)
    offsets = xyz - centre
    smallest, middle, _ = np.linalg.eigvalsh(offsets.T @ offsets / len(xyz))
    return math.sqrt(max(smallest, 0.0)), math.sqrt(max(middle, 0.0)), centre


SLAB_SEARCH_M = 20.0  # the root's seeds lie within ±20 m of the level (a 10 m mounting plus the tilt limit)


def densest_slab(heights: np.ndarray, thickness_m: float) -> np.ndarray:
    """Mask of the heights in the slab `thickness_m` thick (four bins of a quarter of it, counted from
    −SLAB_SEARCH_M) that holds the most of them; the lowest such slab on ties."""
    bin_m = thickness_m / 4
    bins = math.ceil(2 * SLAB_SEARCH_M / bin_m)
    index = np.floor((heights + SLAB_SEARCH_M) / bin_m)
    index = np.where((index >= 0) & (index < bins), index, -1).astype(np.int64)
    count = np.bincount(index[index >= 0], minlength=bins)
    window = np.convolve(count, np.ones(4, dtype=np.int64))[3:]  # window[b] = count[b] + … + count[b + 3]
    best = int(np.argmax(window))
    return (index >= best) & (index < best + 4)


def _root_reference(xyz: np.ndarray, cfg: Config) -> tuple[np.ndarray, bool]:
    """The innermost ring's reference: the paper's plane of the points within zone_root_m, started from their
    densest horizontal slab (the road, not the side of a car beside it), else the level z = 0; and whether it
    is a fit (not the level)."""
    xyz = xyz[np.hypot(xyz[:, 0], xyz[:, 1]) < cfg.ground.zone_root_m]
    try:
        plane, _, _ = paper_fit(xyz, densest_slab(xyz[:, 2], cfg.ground.pca_threshold_m), cfg)
    except DegenerateFit:
        return LEVEL, False
    return (plane, True) if tilt_deg(plane) <= cfg.ground.max_tilt_deg else (LEVEL, False)


def fit_patch(xyz: np.ndarray, reference: np.ndarray, cfg: Config):
    """(plane, ground mask, too steep) of one patch; the plane is None when it has no plane of its own (too few
    points or seeds for a fit, a fit on a line of points, or a fit that failed a test: then the points at most
    pca_threshold_m above the reference are ground), and `too steep` says whether its fit failed the
    uprightness test. Points more than max_depth_m below the reference are never ground nor seeds."""
    g = cfg.ground
    above_reference = height_above(xyz, reference)
    not_under = above_reference >= -g.max_depth_m  # deeper: a return from under the road
    inherited = not_under & (above_reference <= g.pca_threshold_m)  # the inner ground goes on
    if not_under.sum() < g.zone_min_points:
        return None, inherited, False
    # Seeds: up to the threshold above the lowest points, and never above the threshold over the reference.
    lowest = min(np.sort(above_reference[not_under])[:g.zone_seed_points].mean(), 0.0)
    seeds = not_under & (above_reference <= lowest + g.pca_threshold_m)
    try:
        plane, fitted, ground = paper_fit(xyz, seeds, cfg, eligible=not_under)
    except DegenerateFit:  # too few seeds for a plane of its own
        return None, inherited, False
    flatness, breadth, centre = _spreads_and_centre(xyz[fitted])
    if breadth < g.zone_min_breadth_m:  # one ring's arc: a line, no plane of its own (and no failed test)
        return None, inherited, False
    upright = tilt_deg(plane) <= g.max_tilt_deg
    near_inner = abs(height_above(centre[None, :], reference)[0]) <= g.zone_max_step_m
    flat = flatness <= g.zone_max_flatness_m
    if upright and near_inner and flat:
        return plane, ground, False
    return None, inherited, not upright  # a rejected fit: the inner ground goes on (its foot is no obstacle)


MIN_ANCHOR_POINTS = 3


def handed_on(xyz: np.ndarray, reference: np.ndarray, plane, ground: np.ndarray, too_steep: bool, cfg: Config):
    """What a patch hands on to the next ring: its plane; else (unless too steep) the reference raised or lowered
    to the median height above it of the patch's ground points within pca_threshold_m of it, when there are at
    least MIN_ANCHOR_POINTS of them; else the reference unchanged."""
    if plane is not None:
        return plane
    if too_steep:
        return reference
    h = height_above(xyz[ground], reference)
    h = h[np.abs(h) <= cfg.ground.pca_threshold_m]
    if len(h) < MIN_ANCHOR_POINTS:
        return reference
    return reference - np.array([0.0, 0.0, 0.0, np.median(h)])


def zone_ground(xyz: np.ndarray, cfg: Config):
    """(ground mask, frame plane or None, too steep): the frame plane is the PCA plane of all the ground points;
    `too steep` says, when there is none, that a patch held a plane beyond the tilt limit."""
    g = cfg.ground
    ring, sector = patch_rings_sectors(xyz, cfg)
    first = np.concatenate([[0], np.cumsum(g.zone_sectors)])  # patch number of each ring's sector 0
    patch = np.where(ring >= 0, first[np.maximum(ring, 0)] + sector, -1)
    order = np.argsort(patch, kind="stable")  # the points patch by patch, each patch's in input order
    bounds = np.searchsorted(patch[order], np.arange(first[-1] + 1))
    ground = np.zeros(len(xyz), dtype=bool)
    root, accepted = _root_reference(xyz, cfg)  # a fitted root is ground of its own, as an accepted patch
    handed_inward = None
    too_steep = False
    for r, count in enumerate(g.zone_sectors):
        handed = []
        for s in range(count):
            # The inner patch holding this patch's central azimuth hands on its plane (or its reference, moved to
            # its ground).
            reference = root if r == 0 else handed_inward[(2 * s + 1) * g.zone_sectors[r - 1] // (2 * count)]
            rows = order[bounds[first[r] + s]:bounds[first[r] + s + 1]]
            plane, mine, steep = fit_patch(xyz[rows], reference, cfg)
            too_steep |= steep
            accepted |= plane is not None
            handed.append(handed_on(xyz[rows], reference, plane, mine, steep, cfg))
            if mine is not None:
                ground[rows[mine]] = True
        handed_inward = handed
    try:
        if not accepted:  # ground handed on from the level alone is no ground: no plane was fitted
            raise DegenerateFit("no plane fitted")
        plane = fit_plane(xyz[ground])
    except DegenerateFit:
        return np.zeros(len(xyz), dtype=bool), None, too_steep
    return ground, plane, False
