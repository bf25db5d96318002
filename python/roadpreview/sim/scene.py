"""Scenes (a road plus box obstacles) and the vectorised ray caster that scans them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .road import Road

LABEL_NONE, LABEL_ROAD, LABEL_OBSTACLE = 0, 1, 2  #: per-point truth: no return, road surface, obstacle
_MARCH_STEP_M = 0.05  # horizontal step of the search for a ray's first crossing of the surface
_BISECTIONS = 24  # refinement of the crossing: 0.05 m / 2^24 ≈ 3 nm
_CHUNK_SAMPLES = 2_000_000  # march samples evaluated at once (bounds memory)


@dataclass(frozen=True)
class Box:
    """An upright box standing on the road: footprint x_min_m…x_max_m × y_min_m…y_max_m (world frame), top
    height_m above the road's mean plane at the footprint's centre. A car, a wall, a post."""

    x_min_m: float
    x_max_m: float
    y_min_m: float
    y_max_m: float
    height_m: float

    def __post_init__(self):
        if not (self.x_min_m < self.x_max_m and self.y_min_m < self.y_max_m and self.height_m > 0):
            raise ValueError(f"box needs x_min < x_max, y_min < y_max and height_m > 0: {self}")


@dataclass(frozen=True)
class Scene:
    road: Road
    boxes: tuple = ()


def _first_crossing(road: Road, origin: np.ndarray, d: np.ndarray, t_max: float) -> np.ndarray:
    """Range along unit rays d from one origin to their first intersection with the road (inf if none ≤ t_max).

    Above the surface f(t) = height of the ray above the road > 0. The ray can only meet the road inside the slab
    of relief bounds; it is sampled there every _MARCH_STEP_M horizontally and the first sample below the surface
    is refined by bisection against the previous one.
    """
    lo, hi = road.relief_bounds()
    a = origin[2] - road.plane_height(origin[0], origin[1])  # height above the plane at t = 0
    b = d[:, 2] - road.grade * d[:, 0] - road.cross_slope * d[:, 1]  # its rate of change along the ray
    with np.errstate(divide="ignore", invalid="ignore"):
        t_in = np.where(b < 0, (a - hi) / -b, np.inf)
        t_out = np.minimum(np.where(b < 0, (a - lo) / -b, np.inf), t_max)
    t_in = np.maximum(t_in, 0.0)
    step = _MARCH_STEP_M / np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)
    crossing = t_in <= t_out
    counts = np.zeros(len(d), dtype=np.int64)
    counts[crossing] = np.ceil((t_out[crossing] - t_in[crossing]) / step[crossing]).astype(np.int64) + 1
    result = np.full(len(d), np.inf)

    def height_above(rays, t):
        p = origin + t[:, None] * d[rays]
        return p[:, 2] - road.height(p[:, 0], p[:, 1])

    for rays in _chunks(np.flatnonzero(counts), counts, _CHUNK_SAMPLES):
        n = counts[rays]
        owner = np.repeat(np.arange(len(rays)), n)
        k = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)  # sample index along its ray
        t = np.minimum(t_in[rays][owner] + k * step[rays][owner], t_out[rays][owner])
        below = np.flatnonzero(height_above(rays[owner], t) <= 0)
        hit, first = np.unique(owner[below], return_index=True)  # samples are ordered by ray, then by t
        idx = below[first]
        t_hi = t[idx]
        t_lo = np.where(k[idx] > 0, t[idx - 1], t_in[rays[hit]])
        for _ in range(_BISECTIONS):
            mid = 0.5 * (t_lo + t_hi)
            under = height_above(rays[hit], mid) <= 0
            t_hi, t_lo = np.where(under, mid, t_hi), np.where(under, t_lo, mid)
        result[rays[hit]] = t_hi
    return result


def _chunks(rays: np.ndarray, counts: np.ndarray, limit: int):
    """Consecutive groups of rays whose march samples add up to about `limit` (a long ray may stand alone)."""
    total = np.cumsum(counts[rays])
    if len(rays) == 0:
        return []
    cuts = np.searchsorted(total, np.arange(1, total[-1] // limit + 1) * limit, side="right")
    edges = np.unique(np.concatenate(([0], cuts, [len(rays)])))
    return [rays[a:b] for a, b in zip(edges[:-1], edges[1:])]


def _box_ranges(box: Box, road: Road, origin: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Range along unit rays d to an axis-aligned box (slab method; inf where missed or behind)."""
    cx, cy = 0.5 * (box.x_min_m + box.x_max_m), 0.5 * (box.y_min_m + box.y_max_m)
    base = float(road.plane_height(cx, cy))
    lower = np.array([box.x_min_m, box.y_min_m, base - 1.0])  # reaches below any relief
    upper = np.array([box.x_max_m, box.y_max_m, base + box.height_m])
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (lower - origin) / d, (upper - origin) / d
    t_near = np.nanmax(np.minimum(t0, t1), axis=1)
    t_far = np.nanmin(np.maximum(t0, t1), axis=1)
    return np.where((t_near <= t_far) & (t_near > 0), t_near, np.inf)


def cast(scene: Scene, origin, directions, max_range_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact ranges (m, inf = nothing within max_range_m) and labels (LABEL_*) of rays from one world origin."""
    origin = np.asarray(origin, float)
    d = np.asarray(directions, float)
    t_road = _first_crossing(scene.road, origin, d, max_range_m)
    t_box = np.full(len(d), np.inf)
    for box in scene.boxes:
        t_box = np.minimum(t_box, _box_ranges(box, scene.road, origin, d))
    t = np.minimum(t_road, t_box)
    t[t > max_range_m] = np.inf
    labels = np.where(np.isinf(t), LABEL_NONE, np.where(t_road <= t_box, LABEL_ROAD, LABEL_OBSTACLE))
    return t, labels.astype(np.uint8)
