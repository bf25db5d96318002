# SPDX-License-Identifier: BSD-3-Clause
"""Roadside perception, docs/method.md §13, in plain numpy/scipy: background (and the world background of a moving
scanner), grid labelling, L-shape boxes, gated assignment and the constant-velocity Kalman step. The test oracle
for roadpreview::roadside."""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage, optimize


def background(ranges: np.ndarray) -> np.ndarray:
    """§13.3: per beam, the median of the finite ranges of the learning scans (rows) when more than half returned."""
    r = np.asarray(ranges, np.float64)
    finite = np.isfinite(r)
    out = np.full(r.shape[1], np.nan)
    for i in range(r.shape[1]):
        v = np.sort(r[finite[:, i], i])
        if 2 * len(v) > r.shape[0]:
            out[i] = v[len(v) // 2]  # the upper median, as nth_element at n/2
    return out


def foreground(ranges: np.ndarray, bg: np.ndarray, margin_m: float = 0.3) -> np.ndarray:
    r = np.asarray(ranges, np.float64)
    with np.errstate(invalid="ignore"):
        return np.isfinite(r) & (~np.isfinite(bg) | (r < bg - margin_m))


def scan_points(ranges: np.ndarray, start_rad: float, step_rad: float, pose=(0.0, 0.0, 0.0), mask=None) -> np.ndarray:
    """§13.5: beam endpoints in the site frame, (N, 2)."""
    r = np.asarray(ranges, np.float64)
    keep = np.isfinite(r) if mask is None else (np.isfinite(r) & mask)
    a = start_rad + step_rad * np.arange(len(r))
    lx, ly = r[keep] * np.cos(a[keep]), r[keep] * np.sin(a[keep])
    x, y, yaw = pose
    return np.column_stack([x + math.cos(yaw) * lx - math.sin(yaw) * ly, y + math.sin(yaw) * lx + math.cos(yaw) * ly])


def label_points(xy: np.ndarray, cell_m: float = 0.1, dilation_cells: int = 2) -> tuple[np.ndarray, int]:
    """§13.5: each point's component (1…n) after gridding, square dilation and 8-connected labelling."""
    xy = np.asarray(xy, np.float64).reshape(-1, 2)
    if len(xy) == 0:
        return np.zeros(0, np.int32), 0
    margin = (dilation_cells + 1) * cell_m
    x0, y0 = xy[:, 0].min() - margin, xy[:, 1].min() - margin
    cols = int(math.floor((xy[:, 0].max() + margin - x0) / cell_m)) + 1
    rows = int(math.floor((xy[:, 1].max() + margin - y0) / cell_m)) + 1
    r = ((xy[:, 1] - y0) / cell_m).astype(int)
    c = ((xy[:, 0] - x0) / cell_m).astype(int)
    grid = np.zeros((rows, cols), bool)
    grid[r, c] = True
    if dilation_cells > 0:
        k = 2 * dilation_cells + 1
        grid = ndimage.binary_dilation(grid, structure=np.ones((k, k), bool))
    labels, n = ndimage.label(grid, structure=np.ones((3, 3), int))
    return labels[r, c].astype(np.int32), int(n)


def fit_l_shape(xy: np.ndarray) -> tuple[float, float, float, float, float]:
    """§13.6: (x, y, length, width, heading) of the closeness-criterion rectangle, length ≥ width."""
    p = np.asarray(xy, np.float64).reshape(-1, 2)
    best = None
    for step in range(90):
        th = math.radians(step)
        c1 = p[:, 0] * math.cos(th) + p[:, 1] * math.sin(th)
        c2 = -p[:, 0] * math.sin(th) + p[:, 1] * math.cos(th)
        d1 = np.minimum(c1.max() - c1, c1 - c1.min())
        d2 = np.minimum(c2.max() - c2, c2 - c2.min())
        score = np.sum(1.0 / np.maximum(np.minimum(d1, d2), 0.01))
        if best is None or score > best[0]:
            m1, m2 = (c1.min() + c1.max()) / 2, (c2.min() + c2.max()) / 2
            best = (score, m1 * math.cos(th) - m2 * math.sin(th), m1 * math.sin(th) + m2 * math.cos(th),
                    c1.max() - c1.min(), c2.max() - c2.min(), th)
    _, x, y, length, width, heading = best
    if width > length:
        length, width, heading = width, length, heading + math.pi / 2
    heading = (heading + math.pi / 2) % math.pi - math.pi / 2  # to [−π/2, π/2)
    if heading == -math.pi / 2:
        heading = math.pi / 2
    return x, y, length, width, heading


def assign(cost, gate: float) -> list[tuple[int, int]]:
    """§13.7: as many pairs with cost ≤ gate as possible, then the least summed cost (scipy's Hungarian solver)."""
    c = np.asarray(cost, np.float64)
    if c.size == 0:
        return []
    allowed = np.isfinite(c) & (c <= gate)
    big = (gate + 1.0) * (max(c.shape) + 1)
    profit = np.where(allowed, big - np.where(allowed, c, 0.0), 0.0)
    rows, cols = optimize.linear_sum_assignment(profit, maximize=True)
    return [(int(r), int(k)) for r, k in zip(rows, cols) if allowed[r, k]]


def kalman_predict(x: np.ndarray, P: np.ndarray, dt: float, accel_sigma: float = 3.0):
    """§13.7: constant-velocity prediction of (x, y, vx, vy)."""
    F = np.eye(4)
    F[0, 2] = F[1, 3] = dt
    q = accel_sigma ** 2
    Q = np.zeros((4, 4))
    Q[0, 0] = Q[1, 1] = q * dt ** 4 / 4
    Q[0, 2] = Q[2, 0] = Q[1, 3] = Q[3, 1] = q * dt ** 3 / 2
    Q[2, 2] = Q[3, 3] = q * dt ** 2
    return F @ x, F @ P @ F.T + Q


def kalman_update(x: np.ndarray, P: np.ndarray, z, sigma_m: float = 0.08):
    H = np.zeros((2, 4))
    H[0, 0] = H[1, 1] = 1.0
    S = H @ P @ H.T + sigma_m ** 2 * np.eye(2)
    K = P @ H.T @ np.linalg.inv(S)
    return x + K @ (np.asarray(z, float) - H @ x), (np.eye(4) - K @ H) @ P


def world_background(scans, poses, cell_m: float = 0.2, free_margin_m: float = 0.3, max_range_m: float = 30.0,
                     hit_radius_cells: int = 3):
    """§13.3, a moving scanner: (x0, y0, free, hits) of the world grid, counts per cell (rows y, columns x).
    A cell is free for a scan when its centre lies inside the scan's fan: within the beams' angular span and on
    the scanner's side of the straight edge between the two shortened beam ends around its bearing."""
    poses = np.asarray(poses, np.float64).reshape(-1, 3)
    reach = max_range_m + cell_m
    x0, y0 = poses[:, 0].min() - reach, poses[:, 1].min() - reach
    width = int(math.ceil((np.ptp(poses[:, 0]) + 2 * reach) / cell_m))
    height = int(math.ceil((np.ptp(poses[:, 1]) + 2 * reach) / cell_m))
    free = np.zeros((height, width), np.int32)
    hits = np.zeros((height, width), np.int32)
    cx = x0 + (np.arange(width) + 0.5) * cell_m
    cy = y0 + (np.arange(height) + 0.5) * cell_m
    for scan, (px, py, yaw) in zip(scans, poses):
        r = np.asarray(scan["ranges_m"], np.float64)
        n = len(r)
        returned = np.isfinite(r) & (r > 0) & (r <= max_range_m)
        reach_m = np.where(returned, np.maximum(r - free_margin_m, 0.0), max_range_m)
        angles = yaw + scan["start_angle_rad"] + scan["step_rad"] * np.arange(n)
        ends = np.column_stack([px + reach_m * np.cos(angles), py + reach_m * np.sin(angles)])
        # Cells near the scanner, their bearing as a fractional beam index.
        cols = np.flatnonzero(np.abs(cx - px) <= max_range_m + cell_m)
        rows = np.flatnonzero(np.abs(cy - py) <= max_range_m + cell_m)
        gx, gy = np.meshgrid(cx[cols], cy[rows])
        bearing = np.arctan2(gy - py, gx - px) - yaw - scan["start_angle_rad"]
        beam = np.mod(bearing, 2 * math.pi) / scan["step_rad"]
        i = np.floor(beam).astype(int)
        inside_span = (i >= 0) & (i < n - 1)
        i = np.clip(i, 0, n - 2)
        ax, ay = ends[i, 0] - px, ends[i, 1] - py
        bx, by = ends[i + 1, 0] - px, ends[i + 1, 1] - py
        qx, qy = gx - px, gy - py
        # The cell and the scanner on the same side of the edge a→b (or on it).
        edge = (bx - ax) * (qy - ay) - (by - ay) * (qx - ax)
        scanner_side = (bx - ax) * (0 - ay) - (by - ay) * (0 - ax)
        inside = inside_span & (edge * scanner_side >= 0)
        free[np.ix_(rows, cols)] += inside
        # Cells within the hit radius of a return, once per scan.
        ex = px + r[returned] * np.cos(angles[returned])
        ey = py + r[returned] * np.sin(angles[returned])
        mark = np.zeros((height, width), bool)
        hc, hr = np.floor((ex - x0) / cell_m).astype(int), np.floor((ey - y0) / cell_m).astype(int)
        for dr in range(-hit_radius_cells, hit_radius_cells + 1):
            for dc in range(-hit_radius_cells, hit_radius_cells + 1):
                rr, cc = hr + dr, hc + dc
                ok = (rr >= 0) & (rr < height) & (cc >= 0) & (cc < width)
                mark[rr[ok], cc[ok]] = True
        hits += mark
    return x0, y0, free, hits


def world_foreground(scan, pose, grid, cell_m: float = 0.2, max_range_m: float = 30.0, min_free_scans: int = 10,
                     max_hit_ratio: float = 0.1, max_hit_scans: int = 40) -> np.ndarray:
    """§13.3: per beam, a return in a cell mostly seen free and hit by few scans."""
    x0, y0, free, hits = grid
    r = np.asarray(scan["ranges_m"], np.float64)
    px, py, yaw = pose
    a = yaw + scan["start_angle_rad"] + scan["step_rad"] * np.arange(len(r))
    returned = np.isfinite(r) & (r > 0) & (r <= max_range_m)
    rs = np.where(returned, r, 0.0)
    col = np.floor((px + rs * np.cos(a) - x0) / cell_m).astype(int)
    row = np.floor((py + rs * np.sin(a) - y0) / cell_m).astype(int)
    f, h = free[row, col], hits[row, col]
    return returned & (f >= min_free_scans) & (h <= np.minimum(max_hit_ratio * f, max_hit_scans))
