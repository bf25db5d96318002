"""The whole pipeline, points → ground → wheel paths → obstacles → profiles → roughness (docs/method.md §0–§5)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..config import Config
from .frames import check_points, to_base_frame
from .ground import ground_model, roi_facing, roi_mask
from .obstacles import Obstacles, PathObstacles, blocked_bins, find_obstacles, wheel_obstacles
from .path import check_motion, plan_path
from .point_errors import point_errors
from .profile import Profile, empty_profile, wheel_profile
from .iri import Iri, vehicle_iri
from .roughness import Roughness, vehicle_from_wheels, vehicle_roughness


@dataclass
class Result:
    ground_mask: np.ndarray  #: N bools over the input points
    plane: Optional[np.ndarray]  #: (a, b, c, d) with c > 0, or None
    points: dict  #: counts "input", "finite", "roi", "ground"
    path: dict  #: as returned by plan_path
    left: Profile = field(default_factory=Profile)
    right: Profile = field(default_factory=Profile)
    vehicle: Roughness = field(default_factory=Roughness)
    reason: Optional[str] = None
    obstacles: Optional[Obstacles] = None  #: every cluster; None when clustering is off
    cluster_labels: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int32))  #: per input row
    speed: float = 0.0  #: m/s, the motion the paths were planned from
    yaw_rate: float = 0.0  #: rad/s
    config: Config = field(default_factory=Config)  #: the configuration the frame was processed with

    def to_dict(self) -> dict:
        """The output line of docs/output.md (timing_ms and fusion are null: the reference has neither)."""
        from .output import result_to_dict

        return result_to_dict(self)

    def __repr__(self) -> str:
        classes = ", ".join(f"{name} {r.iso_class or '-'}" for name, r in
                            (("left", self.left.roughness), ("right", self.right.roughness), ("vehicle", self.vehicle)))
        head = f"<roadpreview.reference.Result {self.points['input']} points, {self.points['ground']} ground, " \
               f"{self.path['status']}"
        return f"{head}; no profiles: {self.reason}>" if self.reason else f"{head}; class {classes}>"


def _without_profiles(ground_mask, plane, counts, path, reason: str, cfg: Config, obstacles, labels) -> Result:
    profiles = [empty_profile(reason) for _ in range(2)]
    for profile in profiles:
        profile.obstacles = PathObstacles() if cfg.obstacles.enabled else None
    return Result(ground_mask, plane, counts, path, *profiles, Roughness(reason=reason, iri=Iri(reason=reason)), reason,
                  obstacles, labels)


def _clusters(base_xyz, ground, plane, cfg: Config):
    """(obstacles, cluster id per point): None when clustering is off, no cluster without a ground plane."""
    if not cfg.obstacles.enabled:
        return None, np.full(len(base_xyz), -1, dtype=np.int32)
    if plane is None:
        return Obstacles(), np.full(len(base_xyz), -1, dtype=np.int32)
    return find_obstacles(base_xyz, ground, plane, cfg)


def process(points, speed, yaw_rate, cfg: Config | None = None, range_variances=None, error_groups=None,
            beams=None) -> Result:
    """Road profiles and roughness of one frame. Bad input raises ValueError; an empty scene, no ground
    or a stopped vehicle give a result with the reason (checked in that order). ``range_variances`` (m², one per
    point: a stereo frame's) and ``error_groups`` (one per point) raise the profile bins' spreads (method.md §12),
    and so do ``beams`` (one per point) with ``cfg.profile.beam_sigma_deg`` or ``beam_sigmas_deg`` > 0 (§3)."""
    cfg = cfg or Config()
    points = check_points(points)
    speed, yaw_rate = check_motion(speed, yaw_rate)
    result = _process(points, speed, yaw_rate, cfg, (range_variances, error_groups, beams))
    result.speed, result.yaw_rate, result.config = speed, yaw_rate, cfg
    return result


def _process(points, speed: float, yaw_rate: float, cfg: Config, errors=(None, None, None)) -> Result:
    path = plan_path(speed, yaw_rate, cfg)
    if path["status"] != "stopped":
        cfg = roi_facing(cfg, speed)  # reversing looks behind
    base_xyz, finite = to_base_frame(points, cfg)
    variances, groups = point_errors(points, base_xyz, finite, cfg, *errors)
    counts = {"input": len(points), "finite": len(base_xyz), "roi": 0, "ground": 0}
    ground_mask = np.zeros(len(points), dtype=bool)
    labels = np.full(len(points), -1, dtype=np.int32)
    if len(base_xyz) == 0:
        obstacles = Obstacles() if cfg.obstacles.enabled else None
        return _without_profiles(ground_mask, None, counts, path, "no finite points", cfg, obstacles, labels)
    counts["roi"] = int(np.count_nonzero(roi_mask(base_xyz, cfg)))
    model = ground_model(base_xyz, cfg)
    ground, plane = model.mask, model.plane
    ground_mask[np.flatnonzero(finite)[ground]] = True
    counts["ground"] = int(np.count_nonzero(ground))
    obstacles, finite_labels = _clusters(base_xyz, ground, plane, cfg)
    labels[finite] = finite_labels
    if plane is None:
        return _without_profiles(ground_mask, None, counts, path, model.reason, cfg, obstacles, labels)
    if path["status"] == "stopped":
        return _without_profiles(ground_mask, plane, counts, path, "vehicle stopped", cfg, obstacles, labels)
    left, right = (_wheel(base_xyz, ground, finite_labels, obstacles, plane, path, wheel, speed, yaw_rate, cfg,
                          variances, groups) for wheel in ("left", "right"))
    vehicle = vehicle_roughness(left.z, right.z, cfg.profile.ds_m, cfg, count_left=left.count,
                                spread_left=left.spread, count_right=right.count, spread_right=right.spread)
    vehicle = vehicle_from_wheels(vehicle, left.roughness, right.roughness)
    vehicle.iri = vehicle_iri(left.roughness.iri, right.roughness.iri)
    return Result(ground_mask, plane, counts, path, left, right, vehicle, None, obstacles, labels)


def _wheel(base_xyz, ground, labels, obstacles, plane, path, wheel, speed, yaw_rate, cfg: Config, variances=None,
           groups=None):
    """One wheel's profile, stopping at the obstacles in its path when clustering is on."""
    ground_variances = None if variances is None else variances[ground]
    ground_groups = None if groups is None else groups[ground]
    if not cfg.obstacles.enabled:
        return wheel_profile(base_xyz[ground], plane, path, wheel, speed, yaw_rate, cfg,
                             height_variances=ground_variances, error_groups=ground_groups)
    in_path = wheel_obstacles(base_xyz, labels, obstacles, plane, path, wheel, speed, yaw_rate, cfg)
    blocked = blocked_bins(in_path.s_start, in_path.s_end, cfg)
    profile = wheel_profile(base_xyz[ground], plane, path, wheel, speed, yaw_rate, cfg, blocked, ground_variances,
                            ground_groups)
    profile.obstacles = in_path
    return profile
