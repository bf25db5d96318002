"""Beam offsets from the road's shape (docs/method.md §8, "From the road's shape"), written plainly from the
method: in each frame the road in the corridor ahead is fitted by a smooth surface, every road point's height off
it divided by its elevation Jacobian is one reading of its beam's offset, and a beam's offset is the median over
frames of the median of its readings in each frame. Also the beams of points a file lists ring by ring."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..config import Config
from .calibration import BeamCalibrationResult, CalibrationError, gauge_columns, ground_mask_of, point_observations

MAD_TO_SIGMA = 1.4826
MEDIAN_EFFICIENCY = 1.2533  #: σ of a median of n Gaussians ≈ 1.2533·σ/√n


@dataclass
class SurfaceOptions:
    min_x_m: float = 3.0
    max_x_m: float = 30.0
    half_width_m: float = 3.5
    min_points: int = 30
    min_frames: int = 3
    max_sigma_deg: float = 0.05
    outlier_sigmas: float = 3.0
    rounds: int = 3
    min_beams: int = 3


def rings_in_scan_order(points) -> np.ndarray:
    """The ring of each point of a file that lists its points ring by ring, each ring one turn from azimuth 0:
    the count of the steps from an azimuth below 0 to one at or above 0 (by less than 1 rad) before it."""
    xy = np.asarray(points, float)[:, :2]
    valid = np.isfinite(xy).all(axis=1) & (np.abs(xy).sum(axis=1) > 0)
    azimuth = np.arctan2(xy[valid, 1], xy[valid, 0])
    step = np.zeros(len(azimuth), bool)
    step[1:] = (azimuth[:-1] < 0) & (azimuth[1:] >= 0) & (azimuth[1:] - azimuth[:-1] < 1.0)
    ring_of_valid = np.cumsum(step)
    # a point without a finite x, y stays in the ring of the last valid point before it
    position = np.cumsum(valid) - 1
    return np.where(position >= 0, ring_of_valid[np.maximum(position, 0)], 0).astype(np.int32)


def in_scan_order(points, beam_count: int) -> bool:
    """Exactly beam_count rings, their median elevations (beyond 4 m) falling from the top ring down."""
    ring = rings_in_scan_order(points)
    if len(ring) == 0 or ring[-1] + 1 != beam_count:
        return False
    xyz = np.asarray(points, float)[:, :3]
    r = np.linalg.norm(xyz, axis=1)
    far = np.isfinite(r) & (r >= 4.0)
    elevation = np.degrees(np.arcsin(xyz[far, 2] / r[far]))
    medians = [np.median(elevation[ring[far] == b]) for b in range(beam_count) if np.any(ring[far] == b)]
    return bool(np.all(np.diff(medians) < 0))


def fit_surface_residuals(x, y, z, options: SurfaceOptions):
    """Heights off the least-squares surface 1, x, y, x², xy, y², refitted `rounds` times to the points within
    outlier_sigmas robust σ of the last fit; returns (residuals, kept, σ of the kept)."""
    u, v = x / 10.0, y / 10.0
    design = np.column_stack([np.ones_like(u), u, v, u * u, u * v, v * v])
    keep = np.ones(len(z), bool)

    def residuals():
        coef = np.linalg.lstsq(design[keep], z[keep], rcond=None)[0]
        return z - design @ coef

    def robust_sigma(e):
        return MAD_TO_SIGMA * np.median(np.abs(e[keep] - np.median(e[keep])))

    for _ in range(options.rounds):
        e = residuals()
        sigma = robust_sigma(e)
        if not sigma > 0:  # a road without noise: nothing is an outlier
            break
        keep = np.abs(e) <= options.outlier_sigmas * sigma
    e = residuals()
    return e, keep, robust_sigma(e)


def calibrate_beams_on_surface(frames, beam_count: int, cfg: Config | None = None,
                               options: SurfaceOptions | None = None) -> BeamCalibrationResult:
    """frames: (points N×C in the sensor frame, beam index per row, −1 unknown). Raises CalibrationError when too
    few frames or beams determine the offsets."""
    cfg = cfg or Config()
    options = options or SurfaceOptions()
    frames = list(frames)
    if len(frames) < options.min_frames:
        raise CalibrationError(f"too short: {len(frames)} frame(s), the surface calibration needs at least "
                               f"{options.min_frames}")
    readings = [[] for _ in range(beam_count)]  # per beam: its offset (rad) in each frame that gave one
    reach_sum, reach_count, noise = np.zeros(beam_count), np.zeros(beam_count), []
    for points, beams in frames:
        beams = np.asarray(beams)
        mask = ground_mask_of(points, cfg) & (beams >= 0)
        obs = point_observations(points, np.where(beams >= 0, beams, 0), mask, (0.0, 0.0, 0.0), cfg)
        road = (obs["x"] >= options.min_x_m) & (obs["x"] <= options.max_x_m) & \
            (np.abs(obs["y"]) <= options.half_width_m)
        if road.sum() < options.min_points * 6:
            continue
        e, keep, sigma = fit_surface_residuals(obs["x"][road], obs["y"][road], obs["z"][road], options)
        noise.append(sigma)
        j, beam = obs["j_elevation"][road][keep], obs["beam"][road][keep]
        offset = e[keep][j != 0] / j[j != 0]
        beam, j = beam[j != 0], j[j != 0]
        np.add.at(reach_sum, beam, -j)
        np.add.at(reach_count, beam, 1)
        for b in np.unique(beam):
            mine = offset[beam == b]
            if len(mine) >= options.min_points:
                readings[b].append(np.median(mine))
    delta, sigma = np.zeros(beam_count), np.full(beam_count, np.nan)
    for b, values in enumerate(readings):
        if len(values) >= options.min_frames:
            delta[b] = np.median(values)
            spread = MAD_TO_SIGMA * np.median(np.abs(np.asarray(values) - delta[b]))
            sigma[b] = MEDIAN_EFFICIENCY * spread / math.sqrt(len(values))
    determined = sigma <= math.radians(options.max_sigma_deg)  # NaN: not
    if determined.sum() < options.min_beams:
        raise CalibrationError(f"too few beams on the ground: {int(determined.sum())} beam(s) determined")
    idx = np.flatnonzero(determined)
    reach = np.divide(reach_sum, reach_count, out=np.full(beam_count, np.inf), where=reach_count > 0)
    basis = gauge_columns(reach[idx])
    relative = delta[idx] - basis @ np.linalg.lstsq(basis, delta[idx], rcond=None)[0]
    out = BeamCalibrationResult(
        beam_count, np.zeros(beam_count), np.full(beam_count, np.nan), np.zeros(beam_count),
        np.full(beam_count, np.nan), determined, np.array([len(v) for v in readings]),
        float(np.median(noise)) if noise else 0.0, len(frames), 0.0, {"reach": reach})
    out.elevation_offset_deg[idx] = np.degrees(relative)
    out.elevation_sigma_deg[idx] = np.degrees(sigma[idx])
    return out
