"""Beam self-calibration (docs/method.md §8): each beam's elevation-angle (and range) offset from a drive.

    frames = rp.io.open("drive.pcap")
    beams = rp.calibrate_beams(frames, speed=2.5, config=rp.Config(sensor_height=1.97))   # or poses=[...]
    beams.elevation_offset_deg, beams.elevation_sigma_deg, beams.determined
    beams.save("beams.yaml")            # then rp.io.open(..., beam_calibration="beams.yaml")
    beams = rp.read_beam_calibration("beams.yaml")
    rp.Config(profile={"beam_sigmas_deg": beams.beam_sigmas_deg(0.02)})  # count what each beam's offset leaves
"""

from __future__ import annotations

import math
import os
import warnings
from typing import Iterable, Optional, Sequence, Union

import numpy as np

from ._native import core
from .config import Config
from .estimator import int32_ids

DEFAULT_UNNUMBERED_BEAMS = 64  #: a sensor whose frames do not number their points: the KITTI HDL-64E


def read_beam_calibration(path: Union[str, os.PathLike]):
    """The beams file at ``path`` (written by ``roadpreview calibrate`` or ``BeamCalibration.save``) as a
    BeamCalibration; a bad or missing field raises RuntimeError naming the file."""
    return core().read_beam_calibration(os.fspath(path))


def _frame_arrays(frame, k: int):
    """(points, beams or None, timestamp or None) of frame k: an rp.io frame, an (N, C) array or a (points, beams)
    pair; points of float32/64 and beams of integers within int32, one per point (a cast would turn int points
    into a drive without ground, and wrap or truncate beam numbers into other beams)."""
    if isinstance(frame, tuple):
        points, beams, timestamp = *frame, None
    elif hasattr(frame, "points"):
        points, beams, timestamp = frame.points, (frame.beams if len(frame.beams) else None), frame.timestamp
    else:
        points, beams, timestamp = frame, None, None
    points = np.asarray(points)
    if points.dtype.kind != "f" or points.dtype.itemsize not in (4, 8):
        raise TypeError(f"calibrate_beams: frame {k}'s points must be float32 or float64, got {points.dtype}")
    if beams is not None:
        beams = np.asarray(beams)
        if beams.dtype.kind not in "iu" or beams.shape != (len(points),):
            raise TypeError(f"calibrate_beams: frame {k}'s beams must be one integer per point ({len(points)}), got "
                            f"{beams.dtype} of shape {beams.shape}")
        beams = int32_ids(beams, f"calibrate_beams: frame {k}'s beams").astype(np.int32)
    return points, beams, timestamp


def _integrated_poses(times: list, speed: float, yaw_rate: float, frame_rate_hz: float) -> list:
    """Poses of constant speed and yaw rate at each frame's time (1/frame_rate_hz apart where unknown)."""
    poses, x, y, yaw = [], 0.0, 0.0, 0.0
    for k, t in enumerate(times):
        if k:
            known = t is not None and times[k - 1] is not None
            dt = t - times[k - 1] if known else 1.0 / frame_rate_hz
            if yaw_rate * dt == 0:
                x, y = x + speed * dt * math.cos(yaw), y + speed * dt * math.sin(yaw)
            else:
                r, yaw_next = speed / yaw_rate, yaw + yaw_rate * dt
                x, y = x + r * (math.sin(yaw_next) - math.sin(yaw)), y - r * (math.cos(yaw_next) - math.cos(yaw))
                yaw = yaw_next
        poses.append((x, y, yaw))
    return poses


def _beam_count(arrays: list, info: Optional[dict]) -> int:
    """The recording's beam count, else the largest beam number + 1, else DEFAULT_UNNUMBERED_BEAMS."""
    numbered = [a[1] for a in arrays if a[1] is not None and len(a[1])]
    return (info or {}).get("beams") or (
        int(max(b.max() for b in numbered)) + 1 if numbered else DEFAULT_UNNUMBERED_BEAMS)


def _frame_poses(arrays: list, poses: Optional[Sequence], speed: Optional[float], yaw_rate: float,
                 frame_rate_hz: float) -> list:
    """One (x, y, yaw) per frame: the poses given, else the speed and yaw rate integrated over the frames' times."""
    if poses is None:
        if speed is None:
            raise ValueError("calibrate_beams needs the motion: speed (and yaw_rate) or poses "
                             "(or method='surface', which needs none)")
        for name, value in (("speed", speed), ("yaw_rate", yaw_rate), ("frame_rate_hz", frame_rate_hz)):
            if not math.isfinite(float(value)):
                raise ValueError(f"calibrate_beams: {name} must be finite, got {value}")
        poses = _integrated_poses([a[2] for a in arrays], float(speed), float(yaw_rate), frame_rate_hz)
    if len(poses) < len(arrays):
        raise ValueError(f"calibrate_beams: {len(poses)} poses for {len(arrays)} frames")
    out = [tuple(map(float, p)) for p in poses[:len(arrays)]]
    bad = next((k for k, p in enumerate(out) if len(p) < 3 or not all(map(math.isfinite, p[:3]))), None)
    if bad is not None:
        raise ValueError(f"calibrate_beams: pose {bad} must be three finite numbers (x, y, yaw), got {out[bad]}")
    return [p[:3] for p in out]


def calibrate_beams(frames: Iterable, *, speed: Optional[float] = None, yaw_rate: float = 0.0,
                    poses: Optional[Sequence] = None, config: Optional[Config] = None,
                    beam_count: Optional[int] = None, frame_rate_hz: float = 10.0, cell_m: float = 0.2,
                    max_sigma_deg: Optional[float] = None, min_observations: int = 100, method: str = "motion",
                    min_frames: int = 3):
    """Per-beam offsets from a drive, estimated in C++ (as ``roadpreview calibrate``).

    frames: rp.io frames (their ``.beams`` number the points), (points, beams) pairs, or bare (N, C) arrays whose
    beams are then found by their scan order or elevation. method: ``"motion"`` compares the road cells that
    different beams see as the vehicle moves and needs the motion — poses: (x, y, yaw) of the base frame per frame
    (m, rad; e.g. from a KITTI poses file), else speed (m/s) and yaw_rate (rad/s) integrated between the frames'
    timestamps (or 1/frame_rate_hz); ``"surface"`` compares each frame's beams with its smooth road, needs no
    motion and at least ``min_frames`` frames, best from different places (docs/method.md §8). config: extrinsics
    and ground settings (rp.Config). beam_count: default the recording's (rp.io ``.info["beams"]``), else 64 for
    unnumbered frames, else the largest beam + 1. max_sigma_deg: a beam less certain is not determined (default
    0.01 for motion, 0.05 for surface).
    Returns a BeamCalibration (``.save(path)`` writes beams.yaml); raises CalibrationError (a ValueError) when
    the drive cannot determine the offsets (too short, no motion, too few beams on the ground).
    """
    if method not in ("motion", "surface"):
        raise ValueError(f"calibrate_beams: method must be 'motion' or 'surface', got {method!r}")
    info = getattr(frames, "info", None)
    arrays = [_frame_arrays(f, k) for k, f in enumerate(frames)]
    if not arrays:
        raise core().CalibrationError("calibrate_beams: no frames given")
    beam_count = beam_count if beam_count is not None else _beam_count(arrays, info)
    points, beams, config_json = [a[0] for a in arrays], [a[1] for a in arrays], (config or Config()).to_json()
    if method == "surface":
        out = core().calibrate_beams_on_surface(points, beams, int(beam_count), config_json,
                                                float(max_sigma_deg or 0.05), int(min_frames))
    else:
        out = core().calibrate_beams(points, beams, _frame_poses(arrays, poses, speed, yaw_rate, frame_rate_hz),
                                     int(beam_count), config_json, float(cell_m), float(max_sigma_deg or 0.01),
                                     int(min_observations))
    if info:
        out.sensor_model, out.serial = info.get("sensor_model", ""), info.get("serial", "")
    warning = core().short_drive_warning(out.travel_m) if method != "surface" else ""
    if warning:
        warnings.warn(f"calibrate_beams: {warning} (method='surface')", RuntimeWarning, stacklevel=2)
    return out
