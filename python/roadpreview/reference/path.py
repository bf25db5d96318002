"""Wheel paths from speed and yaw rate (docs/method.md §2 Wheel paths)."""

from __future__ import annotations

import math

from ..config import Config


def finite_number(value, name: str, not_a_number: type = ValueError) -> float:
    """``value`` as a float; `not_a_number` when it is none, ValueError when it is not finite."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise not_a_number(f"{name} must be a number, got {value!r:.60}") from None
    if not math.isfinite(number):
        raise ValueError(f"{name} must be finite, got {number}")
    return number


def check_motion(speed, yaw_rate) -> tuple[float, float]:
    """(V, ω) as floats; ValueError when either is not a finite number."""
    return finite_number(speed, "speed"), finite_number(yaw_rate, "yaw_rate")


def wheel_y(wheel: str, cfg: Config) -> float:
    if wheel not in ("left", "right"):
        raise ValueError(f"wheel must be 'left' or 'right', got {wheel!r}")
    half_track = cfg.track_width / 2
    return half_track if wheel == "left" else -half_track


def plan_path(speed, yaw_rate, cfg: Config | None = None) -> dict:
    """{"status": "arc"|"straight"|"stopped", "icr_y", "left_radius", "right_radius"} (None unless arc)."""
    cfg = cfg or Config()
    speed, yaw_rate = check_motion(speed, yaw_rate)
    path = {"status": "arc", "icr_y": None, "left_radius": None, "right_radius": None}
    if abs(speed) <= cfg.path.stopped_speed_mps:
        path["status"] = "stopped"
    elif yaw_rate == 0 or abs(speed / yaw_rate) > cfg.path.straight_radius_m:
        path["status"] = "straight"
    else:
        icr_y = speed / yaw_rate  # valid for every sign combination of V and ω
        path["icr_y"] = icr_y
        path["left_radius"] = abs(icr_y - wheel_y("left", cfg))
        path["right_radius"] = abs(icr_y - wheel_y("right", cfg))
    return path
