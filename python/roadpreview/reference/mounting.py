# SPDX-License-Identifier: BSD-3-Clause
"""The sensor's mounting read off the ground (docs/method.md §1, "Mounting from the ground")."""

from __future__ import annotations

import math
from typing import Optional

import numpy as np

from ..config import Config, Extrinsics
from .frames import check_points
from .ground import fit_ground

MAX_OFFSET_M = 0.3  #: a fitted ground farther than this from the base origin disagrees with the given mounting
MAX_TILT_DEG = 5.0  #: so does one tilted more than this in the base frame


def mounting_from_plane(sensor_plane) -> dict:
    """Height, roll and pitch that make a ground plane fitted in the sensor frame the base frame's z = 0.

    With extrinsics (0, 0, h, roll, pitch, 0) a sensor-frame point p has base height n·p + h, where n, the third
    row of R = Ry(pitch)·Rx(roll), is (−sin pitch, cos pitch·sin roll, cos pitch·cos roll); so n is the plane's
    normal and h its d."""
    a, b, c, d = (float(v) for v in sensor_plane)
    return {"height_m": d, "roll_rad": math.atan2(b, c), "pitch_rad": -math.asin(max(-1.0, min(1.0, a)))}


def estimate_mounting(points, cfg: Config | None = None) -> Optional[dict]:
    """The mounting the ground of sensor-frame ``points`` implies: fitted to the points below the sensor (z < 0;
    a ceiling cannot be the ground) as if the sensor were level at the base origin, with cfg's ROI and ground
    method; None without ground."""
    cfg = cfg or Config()
    xyz = check_points(points)[:, :3].astype(np.float64)
    xyz = xyz[np.isfinite(xyz).all(axis=1) & (xyz[:, 2] < 0)]
    ground, plane = fit_ground(xyz, cfg)
    if plane is None:
        return None
    return dict(mounting_from_plane(plane), ground_points=int(np.count_nonzero(ground)))


def to_extrinsics(mounting: dict) -> Extrinsics:
    return Extrinsics(z_m=mounting["height_m"], roll_rad=mounting["roll_rad"], pitch_rad=mounting["pitch_rad"])


def check_mounting(base_plane) -> dict:
    """How far a ground fitted in the base frame lies from z = 0: the base origin's height above it, its tilt."""
    offset, tilt = float(base_plane[3]), math.degrees(math.acos(max(-1.0, min(1.0, float(base_plane[2])))))
    return {"ground_offset": offset, "ground_tilt_deg": tilt,
            "disagrees": abs(offset) > MAX_OFFSET_M or tilt > MAX_TILT_DEG}
