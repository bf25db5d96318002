"""What a frame states about its points' errors, as each finite point's height variance and error group: range
variances and error groups (docs/method.md §12), and LiDAR beams, whose elevation errors their points share (§3)."""

from __future__ import annotations

import math

import numpy as np

from ..config import Config
from .frames import check_ids, check_per_point, sensor_origin
from .stereo import height_variances


def point_errors(points, base_xyz, finite, cfg: Config, range_variances=None, error_groups=None, beams=None):
    """(height variances, error groups) of the finite points ``base_xyz`` (``finite`` picks them from the rows of
    ``points``; each None when nothing is stated). A beam's elevation error of σ (``cfg.profile.beam_sigmas_deg``
    for the beams it lists, ``beam_sigma_deg`` for the others) moves a point by its horizontal distance d from the
    sensor per radian: d²σ² joins its height variance, and its beam is its error group unless ``error_groups`` are
    given (a point of a beam with σ = 0, or of an unknown beam < 0, is a group of its own: −1 − its row). With
    every σ = 0 the beams are not used."""
    range_variances = check_per_point(range_variances, points, "range_variances")
    error_groups = check_ids(error_groups, points, "error_groups")
    beams = check_ids(beams, points, "beams")
    listed = np.radians(np.asarray(cfg.profile.beam_sigmas_deg, dtype=float))
    others = math.radians(cfg.profile.beam_sigma_deg)
    counted = beams is not None and (others > 0 or bool(np.any(listed > 0)))
    if range_variances is not None:  # a point's stated variance weighs it: NaN, ±inf or < 0 cannot
        stated = np.asarray(range_variances[finite], dtype=float)
        bad = ~(np.isfinite(stated) & (stated >= 0))
        if bad.any():
            row = int(np.flatnonzero(finite)[np.argmax(bad)])
            raise ValueError(f"range variance of point {row} must be finite and >= 0 m², got {range_variances[row]:g}")
    variances = None if range_variances is None else height_variances(base_xyz, range_variances[finite], cfg)
    if counted:
        beam = np.asarray(beams[finite], dtype=np.int64)
        in_list = (beam >= 0) & (beam < len(listed))
        sigma = np.full(len(beam), others)
        sigma[in_list] = listed[beam[in_list]]
        ray = np.asarray(base_xyz, float)[:, :2] - sensor_origin(cfg)[:2]
        beam_variance = np.einsum("ij,ij->i", ray, ray) * sigma ** 2
        variances = beam_variance if variances is None else variances + beam_variance
    groups = None
    if error_groups is not None:
        groups = error_groups[finite]
    elif counted:
        rows = np.flatnonzero(finite)
        groups = np.where((beam >= 0) & (sigma > 0), beam, -1 - rows).astype(np.int64)
    return variances, groups
