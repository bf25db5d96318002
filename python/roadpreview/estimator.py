"""The pipeline estimator: a thin layer over the C++ ``Estimator``."""

from __future__ import annotations

import warnings
from typing import Optional

import numpy as np

from ._native import core
from .config import Config


YAW_RATE_SOURCES = ("option", "motion", "imu", "default")  #: the output's path.yaw_rate_source values


def _number(value, name: str) -> float:
    """A real number for argument ``name``, or TypeError saying which argument was not one."""
    try:
        return float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a number, got {value!r:.60}") from None


def _mounting_disagrees(mounting: dict) -> str:
    """What the CLI says of the first frame whose ground disagrees with the mounting, in the API's words."""
    offset = mounting["ground_offset"]
    text = (f"the fitted ground is {abs(offset):.2f} m {'below' if offset >= 0 else 'above'} the base origin and "
            f"tilted {mounting['ground_tilt_deg']:.1f}°: ")
    if mounting["source"] == "none":
        return text + ("the points are not base-frame points, as they were taken to be; give "
                       "Config(sensor_height=...) or Config(extrinsics=...)")
    height = mounting["extrinsics"][2]
    return text + f"the sensor is about {height + offset:.2f} m up, not {height:.2f} m; check sensor_height / extrinsics"


class Estimator:
    """Runs the C++ pipeline frame by frame; keeps its work buffers between calls (not thread-safe: a call while
    another thread's call on the same estimator runs raises RuntimeError; give each thread its own).

    ``Estimator(cfg)`` raises ValueError for an invalid config, naming the field. The first frame whose fitted
    ground disagrees with the mounting (``result.mounting["disagrees"]``: points in the sensor frame without
    ``sensor_height``/``extrinsics``, or a wrong height) issues a RuntimeWarning saying by how much; once.
    """

    def __init__(self, cfg: Optional[Config] = None):
        self.config = cfg if cfg is not None else Config()
        if not isinstance(self.config, Config):
            raise TypeError(f"cfg must be a roadpreview.Config, got {type(self.config).__name__}")
        self._impl = core().Estimator(self.config.to_json())
        self._mounting_warned = False

    def process(self, points, speed: float, yaw_rate: float = 0.0, *, source: str = "",
                timestamp: Optional[float] = None, yaw_rate_source: str = "", pose=None, range_variances=None,
                error_groups=None, beams=None):
        """One frame.

        points: (N, 3) or (N, C ≥ 3) array in the sensor frame, float32 (read in place when its columns
        are contiguous) or float64 (converted once); extra columns are ignored, non-finite rows dropped.
        speed: m/s, negative when reversing. yaw_rate: rad/s, positive turning left.
        yaw_rate_source: where the yaw rate came from, one of YAW_RATE_SOURCES ("option", "motion", "imu",
        "default"); when given, the output line's ``path`` carries it (docs/output.md).
        timestamp: s; with ``cfg.fusion.method`` "ema" or "kalman" the map moves by the speed and yaw rate
        integrated since the previous frame's timestamp (1/``fusion.frame_rate_hz`` without timestamps).
        pose: (x, y, yaw) of the vehicle in the odometry frame (m, m, rad), used instead of that integration.
        range_variances: (N,) m², each point's variance along its line of sight (a stereo frame's
        ``range_variances``); it sets a floor under the noise of the profiles' bins and the map's cells.
        error_groups: (N,) integers, points with one id share their range error (a stereo frame's
        ``error_groups``); a bin or a map cell counts each group once when it rates its median's noise.
        beams: (N,) integers, each point's LiDAR beam (a decoder's frame's ``beams``): with
        ``cfg.profile.beam_sigma_deg`` (or that beam's ``beam_sigmas_deg``) > 0, a beam's elevation error, shared by
        its points, is counted in that noise (method.md §3); without error_groups the beams are the groups.
        Returns a ``roadpreview.Result`` (arrays are read-only views of the C++ result).
        """
        speed, yaw_rate = _number(speed, "speed"), _number(yaw_rate, "yaw_rate")
        if timestamp is not None:
            timestamp = _number(timestamp, "timestamp")
        if not isinstance(source, str):
            raise TypeError(f"source must be a string (the frame's file name), got {type(source).__name__}")
        if yaw_rate_source and yaw_rate_source not in YAW_RATE_SOURCES:
            raise ValueError(f"yaw_rate_source must be one of {', '.join(YAW_RATE_SOURCES)}, got {yaw_rate_source!r}")
        if pose is not None:
            pose = tuple(float(v) for v in pose)
            if len(pose) != 3:
                raise ValueError(f"pose must be (x, y, yaw), got {len(pose)} values")
        error_groups, beams = int32_ids(error_groups, "error_groups"), int32_ids(beams, "beams")
        range_variances = _float32_values(range_variances, "range_variances")
        result = self._impl.process(points, speed, yaw_rate, source, timestamp, yaw_rate_source, pose,
                                    range_variances, error_groups, beams)
        if not self._mounting_warned and result.plane is not None and result.mounting["disagrees"]:
            self._mounting_warned = True
            warnings.warn(_mounting_disagrees(result.mounting), RuntimeWarning, stacklevel=2)
        return result

    def reset(self):
        """Forgets the fused map, the pose and the clock (temporal fusion); the frame counter keeps counting."""
        self._impl.reset()


def _float32_values(values, name: str):
    """``values`` (None passes) as an array the C++ core reads as float32: real numbers only (a complex part, a
    bool or an object would be cast silently), none beyond float32's range (it would read as inf)."""
    if values is None:
        return None
    values = np.asarray(values)
    if values.dtype.kind not in "fiu":
        raise TypeError(f"{name} must hold real numbers, got dtype {values.dtype}")
    finite = values[np.isfinite(values)] if values.dtype.kind == "f" else values
    if finite.size and np.abs(finite).max() > np.finfo(np.float32).max:
        raise ValueError(f"{name} must fit in float32, got {np.abs(finite).max():g}")
    return values


def int32_ids(ids, name: str):
    """``ids`` (None passes) as an array; integers beyond int32 are a ValueError (the C++ core's ids are int32)."""
    if ids is None:
        return None
    ids = np.asarray(ids)
    int32 = np.iinfo(np.int32)
    if ids.dtype.kind in "iu" and ids.size and (ids.min() < int32.min or ids.max() > int32.max):
        raise ValueError(f"{name} must fit in int32, got values {ids.min()}…{ids.max()}")
    return ids
