"""Obstacles (docs/method.md §5): Euclidean clusters of the non-ground ROI points, their boxes and heights,
the clusters crossing each wheel's widened corridor, and the profile bins they block.

The clustering is written from the definition — connected components of the graph whose edges join voxel
centroids (or points) closer than the tolerance — with a grid of cells one tolerance wide (neighbours can only
be in the 27 cells around a point's own) and a union of labels over the edges; no KD-tree, no scipy.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..config import Config
from .frames import check_per_point
from .ground import height_above, roi_mask
from .profile import arc_length, bin_count, level_points

# Candidate point pairs examined at once (bounds the memory of the vectorised distance test).
_PAIRS_PER_CHUNK = 2_000_000


def _zeros(*shape, dtype=np.float64):
    return np.zeros(shape, dtype=dtype)


@dataclass
class Obstacles:
    """Every cluster, one row per id (ids 0 … K−1, nearest first)."""

    id: np.ndarray = field(default_factory=lambda: _zeros(0, dtype=np.int32))
    count: np.ndarray = field(default_factory=lambda: _zeros(0, dtype=np.int32))  #: points per cluster
    centroid: np.ndarray = field(default_factory=lambda: _zeros(0, 3))  #: m, mean of the points
    aabb_min: np.ndarray = field(default_factory=lambda: _zeros(0, 3))  #: m, axis-aligned bounds
    aabb_max: np.ndarray = field(default_factory=lambda: _zeros(0, 3))
    obb_center: np.ndarray = field(default_factory=lambda: _zeros(0, 3))  #: m, box about the vertical axis
    obb_size: np.ndarray = field(default_factory=lambda: _zeros(0, 3))  #: m: length along yaw, width, height
    obb_yaw: np.ndarray = field(default_factory=lambda: _zeros(0))  #: rad in (−π/2, π/2]
    ground_offset: np.ndarray = field(default_factory=lambda: _zeros(0))  #: m, local ground above the plane
    height: np.ndarray = field(default_factory=lambda: _zeros(0))  #: m, top above the local ground
    bottom: np.ndarray = field(default_factory=lambda: _zeros(0))  #: m, lowest point above the local ground

    def __len__(self) -> int:
        return len(self.id)


@dataclass
class PathObstacles:
    """The clusters crossing one wheel's widened corridor, ordered by s_start."""

    id: np.ndarray = field(default_factory=lambda: _zeros(0, dtype=np.int32))
    s_start: np.ndarray = field(default_factory=lambda: _zeros(0))  #: m, nearest point in the corridor
    s_end: np.ndarray = field(default_factory=lambda: _zeros(0))  #: m, farthest point in the corridor
    height: np.ndarray = field(default_factory=lambda: _zeros(0))  #: m, highest of those above the local ground

    def __len__(self) -> int:
        return len(self.id)


# ------------------------------------------------------------------------------------------------ clustering
def _candidate_pairs(cells: np.ndarray):
    """Yield (i, j) index arrays of the point pairs in the same or in neighbouring cells, each pair once."""
    order = np.lexsort(cells.T[::-1])
    origin = cells.min(axis=0) - 1
    dims = cells.max(axis=0) - origin + 2
    keys = np.ravel_multi_index((cells - origin).T, dims)
    unique_keys, first, counts = np.unique(keys[order], return_index=True, return_counts=True)
    for offset in np.array(list(np.ndindex(3, 3, 3))) - 1:
        neighbour = np.ravel_multi_index((cells - origin + offset).T, dims)
        slot = np.minimum(np.searchsorted(unique_keys, neighbour), len(unique_keys) - 1)
        points = np.flatnonzero(unique_keys[slot] == neighbour)
        if offset.any():  # of the two cells of a pair, the one with the larger key is the neighbour
            points = points[neighbour[points] > keys[points]]
        yield from _pairs_with_cell(points, first[slot[points]], counts[slot[points]], order, same=not offset.any())


def _pairs_with_cell(points, cell_first, cell_count, order, same):
    """(i, j) for each point i of `points` and each point j of its matching cell (j > i within one cell)."""
    pairs_so_far = np.cumsum(cell_count)
    start = 0
    while start < len(points):
        done = pairs_so_far[start - 1] if start else 0
        stop = max(int(np.searchsorted(pairs_so_far, done + _PAIRS_PER_CHUNK, side="right")), start + 1)
        reps = cell_count[start:stop]
        i = np.repeat(points[start:stop], reps)
        within = np.arange(reps.sum()) - np.repeat(np.cumsum(reps) - reps, reps)
        j = order[np.repeat(cell_first[start:stop], reps) + within]
        if same:
            i, j = i[j > i], j[j > i]
        yield i, j
        start = stop


def _components(xyz: np.ndarray, tolerance: float) -> np.ndarray:
    """Per point the lowest index in its connected component (edges join points closer than `tolerance`), judged
    in single precision as method.md §5 says: the points rounded to float32, their squared distance summed x, then
    y, then z in float32, against the squared tolerance rounded to float32."""
    labels = np.arange(len(xyz))
    xyz = xyz.astype(np.float32)
    cells = np.floor(xyz / tolerance).astype(np.int64)
    limit = np.float32(tolerance * tolerance)
    edges_i, edges_j = [], []
    for i, j in _candidate_pairs(cells):
        d = xyz[i] - xyz[j]
        close = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2] < limit
        edges_i.append(i[close])
        edges_j.append(j[close])
    i, j = np.concatenate(edges_i), np.concatenate(edges_j)
    while True:  # hook each point to the lowest label of its edges, then jump pointers until flat
        lowest = np.minimum(labels[i], labels[j])
        updated = labels.copy()
        np.minimum.at(updated, i, lowest)
        np.minimum.at(updated, j, lowest)
        while not np.array_equal(updated, updated[updated]):
            updated = updated[updated]
        if np.array_equal(updated, labels):
            return labels
        labels = updated


def _voxel_centroids(points: np.ndarray, edge: float) -> tuple[np.ndarray, np.ndarray]:
    """(centroid of each occupied voxel floor(p / edge), voxel of each point)."""
    _, voxel = np.unique(np.floor(points / edge).astype(np.int64), axis=0, return_inverse=True)
    voxel = voxel.ravel()
    centroids = np.zeros((voxel.max() + 1, 3))
    np.add.at(centroids, voxel, points)
    return centroids / np.bincount(voxel)[:, None], voxel


def cluster_labels(xyz, cfg: Config | None = None) -> np.ndarray:
    """Cluster id per point; −1 for a non-finite point or one in a cluster outside the size limits.

    Clusters are the connected components of the voxel centroids (of the points themselves when voxel_m = 0)
    closer than the tolerance; each point joins its voxel's. Ids rank them nearest first (smallest x of their
    points), ties by their lowest point index.
    """
    cfg = cfg or Config()
    o = cfg.obstacles
    xyz = np.asarray(xyz, dtype=np.float64)[:, :3]
    finite = np.flatnonzero(np.isfinite(xyz).all(axis=1))
    labels = np.full(len(xyz), -1, dtype=np.int32)
    if len(finite) == 0:
        return labels
    points = xyz[finite]
    if o.voxel_m > 0:
        centroids, voxel = _voxel_centroids(points, o.voxel_m)
        roots = _components(centroids, o.cluster_tolerance_m)[voxel]
    else:
        roots = _components(points, o.cluster_tolerance_m)
    _, component, sizes = np.unique(roots, return_inverse=True, return_counts=True)
    component = component.ravel()
    x_min = np.full(len(sizes), np.inf)
    np.minimum.at(x_min, component, points[:, 0])
    lowest_index = np.full(len(sizes), len(points))
    np.minimum.at(lowest_index, component, np.arange(len(points)))
    kept = np.flatnonzero((sizes >= o.min_cluster_points) & (sizes <= o.max_cluster_points))
    ranked = kept[np.lexsort((lowest_index[kept], x_min[kept]))]
    rank = np.full(len(sizes), -1, dtype=np.int32)
    rank[ranked] = np.arange(len(ranked))
    labels[finite] = rank[component]
    return labels


# ------------------------------------------------------------------------------------------------ description
def oriented_box(xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """(centre, size, yaw) of the box about the vertical axis along the principal horizontal directions."""
    mean = xyz.mean(axis=0)
    d = xyz[:, :2] - mean[:2]
    cxx, cyy, cxy = d[:, 0] @ d[:, 0], d[:, 1] @ d[:, 1], d[:, 0] @ d[:, 1]
    yaw = 0.5 * math.atan2(2 * cxy + 0.0, cxx - cyy)  # + 0.0: −0 would give −π/2
    c, s = math.cos(yaw), math.sin(yaw)
    u, v = c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]
    u_mid, v_mid = (u.min() + u.max()) / 2, (v.min() + v.max()) / 2
    z = xyz[:, 2]
    centre = np.array([mean[0] + c * u_mid - s * v_mid, mean[1] + s * u_mid + c * v_mid, (z.min() + z.max()) / 2])
    size = np.array([u.max() - u.min(), v.max() - v.min(), z.max() - z.min()])
    return centre, size, yaw


def local_ground(ground_xyz: np.ndarray, plane, lo: np.ndarray, hi: np.ndarray, reach: float) -> float:
    """Median height above the plane of the ground points within `reach` of the footprint [lo, hi] in x, y."""
    x, y = ground_xyz[:, 0], ground_xyz[:, 1]
    near = (x >= lo[0] - reach) & (x <= hi[0] + reach) & (y >= lo[1] - reach) & (y <= hi[1] + reach)
    return float(np.median(height_above(ground_xyz[near], plane))) if near.any() else 0.0


def find_obstacles(base_xyz, ground_mask, plane, cfg: Config | None = None) -> tuple[Obstacles, np.ndarray]:
    """Clusters of the non-ground ROI points among ``base_xyz`` and the cluster id per point (−1: none)."""
    cfg = cfg or Config()
    xyz = np.asarray(base_xyz, dtype=np.float64)[:, :3]
    # The shape, not len(): an (N, 1) mask would broadcast against N-long masks into N × N.
    ground_mask = check_per_point(ground_mask, xyz, "ground_mask").astype(bool)
    plane = np.asarray(plane, dtype=np.float64)
    candidates = np.flatnonzero(roi_mask(xyz, cfg) & ~ground_mask)
    labels = np.full(len(xyz), -1, dtype=np.int32)
    labels[candidates] = cluster_labels(xyz[candidates], cfg)
    ground_xyz = xyz[roi_mask(xyz, cfg) & ground_mask]
    rows = []
    for cluster_id in range(labels.max() + 1):
        points = xyz[labels == cluster_id]
        lo, hi = points.min(axis=0), points.max(axis=0)
        offset = local_ground(ground_xyz, plane, lo, hi, cfg.obstacles.ground_search_m)
        centre, size, yaw = oriented_box(points)
        heights = height_above(points, plane)
        rows.append((cluster_id, len(points), points.mean(axis=0), lo, hi, centre, size, yaw, offset,
                     heights.max() - offset, heights.min() - offset))
    return _obstacles_from_rows(rows), labels


def _obstacles_from_rows(rows) -> Obstacles:
    if not rows:
        return Obstacles()
    names = [f.name for f in dataclasses.fields(Obstacles)]
    columns = {name: np.array(values) for name, values in zip(names, zip(*rows))}
    columns["id"] = columns["id"].astype(np.int32)
    columns["count"] = columns["count"].astype(np.int32)
    return Obstacles(**columns)


# ------------------------------------------------------------------------------------------------ wheel paths
def wheel_obstacles(base_xyz, labels, obstacles: Obstacles, plane, path: dict, wheel: str, speed, yaw_rate,
                    cfg: Config | None = None) -> PathObstacles:
    """The clusters with points in the wheel's corridor widened by the safety margin, 0 ≤ s < preview length,
    whose points there rise at least min_height_m above the cluster's local ground — unless the whole cluster
    is higher than clearance_m above it (a canopy, a sign, a bridge: the vehicle passes under)."""
    cfg = cfg or Config()
    if path["status"] == "stopped" or len(obstacles) == 0:
        return PathObstacles()
    labels = check_per_point(labels, base_xyz, "labels")
    clustered = labels >= 0
    xyz = np.asarray(base_xyz, dtype=np.float64)[clustered, :3]
    ids = labels[clustered]
    levelled = level_points(xyz, plane) if cfg.profile.level else xyz
    widened = dataclasses.replace(cfg, tire_width=cfg.tire_width + 2 * cfg.obstacles.safety_margin_m)
    s, in_corridor = arc_length(levelled[:, :2], path, wheel, float(speed), float(yaw_rate), widened)
    hit = in_corridor & (s >= 0) & (s < cfg.profile.preview_length_m)
    heights = height_above(xyz, np.asarray(plane, dtype=np.float64))
    rows = []
    for cluster_id in np.unique(ids[hit]):
        if obstacles.bottom[cluster_id] > cfg.obstacles.clearance_m:
            continue
        mine = hit & (ids == cluster_id)
        height = heights[mine].max() - obstacles.ground_offset[cluster_id]
        if height >= cfg.obstacles.min_height_m:  # lower: ground the ground fit missed (a rising road, a ramp)
            rows.append((cluster_id, s[mine].min(), s[mine].max(), height))
    rows.sort(key=lambda row: (row[1], row[0]))
    if not rows:
        return PathObstacles()
    cluster_id, s_start, s_end, height = (np.array(column) for column in zip(*rows))
    return PathObstacles(cluster_id.astype(np.int32), s_start, s_end, height)


def blocked_bins(s_start, s_end, cfg: Config | None = None) -> np.ndarray:
    """Bin k = [k·ds, (k+1)·ds) is blocked when it overlaps [s_start − margin, s_end + margin] of an obstacle."""
    cfg = cfg or Config()
    count, ds, margin = bin_count(cfg), cfg.profile.ds_m, cfg.obstacles.safety_margin_m
    blocked = np.zeros(count, dtype=bool)
    s_start, s_end = np.atleast_1d(s_start), np.atleast_1d(s_end)
    if s_start.shape != s_end.shape:
        raise ValueError(f"blocked_bins: s_start and s_end differ in shape: {s_start.shape} vs {s_end.shape}")
    for start, end in zip(s_start, s_end):
        if not (np.isfinite(start) and np.isfinite(end) and start <= end):
            raise ValueError("blocked_bins: an obstacle needs finite s_start <= s_end")
        # Clipped before the cast to int: (s ± margin)/ds overflows to ±inf for s near ±1e308.
        with np.errstate(over="ignore"):
            first = int(np.clip(np.floor((start - margin) / ds), 0, count - 1))
            last = int(np.clip(np.floor((end + margin) / ds), 0, count - 1))
        blocked[first:last + 1] = True
    return blocked
