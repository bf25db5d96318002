"""The whole pipeline, points → ground → wheel paths → profiles → roughness (docs/method.md §0–§4)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..config import Config
from .frames import check_points, to_base_frame
from .ground import fit_ground, roi_mask
from .path import check_motion, plan_path
from .profile import Profile, empty_profile, wheel_profile
from .iri import Iri, vehicle_iri
from .roughness import Roughness, vehicle_roughness


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


def _without_profiles(ground_mask, plane, counts, path, reason: str) -> Result:
    return Result(ground_mask, plane, counts, path, empty_profile(reason), empty_profile(reason),
                  Roughness(reason=reason, iri=Iri(reason=reason)), reason)


def process(points, speed, yaw_rate, cfg: Config | None = None) -> Result:
    """Road profiles and roughness of one frame. Bad input raises ValueError; an empty scene, no ground
    or a stopped vehicle give a result with the reason (checked in that order)."""
    cfg = cfg or Config()
    points = check_points(points)
    speed, yaw_rate = check_motion(speed, yaw_rate)
    path = plan_path(speed, yaw_rate, cfg)
    base_xyz, finite = to_base_frame(points, cfg)
    counts = {"input": len(points), "finite": len(base_xyz), "roi": 0, "ground": 0}
    ground_mask = np.zeros(len(points), dtype=bool)
    if len(base_xyz) == 0:
        return _without_profiles(ground_mask, None, counts, path, "no finite points")
    counts["roi"] = int(np.count_nonzero(roi_mask(base_xyz, cfg)))
    ground, plane = fit_ground(base_xyz, cfg)
    ground_mask[np.flatnonzero(finite)[ground]] = True
    counts["ground"] = int(np.count_nonzero(ground))
    if plane is None:
        return _without_profiles(ground_mask, None, counts, path, "no ground")
    if path["status"] == "stopped":
        return _without_profiles(ground_mask, plane, counts, path, "vehicle stopped")
    left, right = (wheel_profile(base_xyz[ground], plane, path, wheel, speed, yaw_rate, cfg)
                   for wheel in ("left", "right"))
    vehicle = vehicle_roughness(left.z, right.z, cfg.profile.ds_m, cfg, count_left=left.count,
                                spread_left=left.spread, count_right=right.count, spread_right=right.spread)
    vehicle.iri = vehicle_iri(left.roughness.iri, right.roughness.iri)
    return Result(ground_mask, plane, counts, path, left, right, vehicle)
