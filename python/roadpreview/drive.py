# SPDX-License-Identifier: BSD-3-Clause
"""One recording, frame by frame, the way ``roadpreview run`` processes it: ``rp.drive.run``.

    for res in rp.drive.run(["drive.pcap"], rp.Config(sensor_height=1.97), motion=(2.5, None)):
        res.vehicle.iso_class, res.to_dict()

The per-frame policy (motion CSV > given yaw rate > the frame's IMU > 0; timestamps from the recording, else
index / frame rate; poses; a new file sequence clears the fusion map; the mounting from the first frame's ground
when none is configured) is that of the C++ DriveRunner (cpp/src/drive/, ``rp.run``, ``roadpreview run``). This
Python copy serves what the C++ runner cannot read yet — ROS bag frames and in-memory motion tables and poses —
and is to be folded into it; batch, bags and odometry code call only :func:`run` and :func:`open_source`.
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass
from typing import Iterator, Optional, Sequence, Union

import numpy as np

from .config import Config, Extrinsics

PathLike = Union[str, "os.PathLike[str]"]
BAG_SUFFIXES = (".bag", ".mcap", ".db3")


def is_bag(path: PathLike) -> bool:
    """A ROS 1 bag, an MCAP file, or a ROS 2 bag (a directory with metadata.yaml, or its .db3/.mcap)."""
    p = os.fspath(path)
    return p.lower().endswith(BAG_SUFFIXES) or (os.path.isdir(p) and os.path.isfile(os.path.join(p, "metadata.yaml")))


def open_source(inputs: Union[PathLike, Sequence[PathLike]], *, topic: Optional[str] = None, **source_options):
    """Frames of a recording: bags through :mod:`roadpreview.io_bags`, everything else through ``rp.io.open``.

    Each frame has ``.points`` ((N, ≥4) float32, sensor frame), ``.timestamp`` (s or None), ``.source``,
    ``.frame_id`` and ``.sequence_break``; the iterator's ``.info`` describes the recording.
    """
    paths = [inputs] if isinstance(inputs, (str, os.PathLike)) else list(inputs)
    if not paths:
        raise ValueError("no input given")
    bags = [p for p in paths if is_bag(p)]
    if bags:
        if len(bags) != len(paths):
            raise ValueError(f"{os.fspath(bags[0])}: a bag cannot be mixed with other inputs in one recording")
        from . import io_bags

        return io_bags.open_bag(paths, topic=topic, **source_options)
    if topic is not None:
        raise ValueError(f"{os.fspath(paths[0])}: --topic applies to ROS bags and MCAP files only")
    from . import io as rp_io

    return rp_io.open(paths, **source_options)


@dataclass
class MotionTable:
    """Speed and yaw rate against time (CSV header ``t,speed,yaw_rate``: s, m/s, rad/s), linearly interpolated."""

    t: np.ndarray
    speed: np.ndarray
    yaw_rate: np.ndarray
    source: str = "motion"

    @classmethod
    def read_csv(cls, path: PathLike) -> "MotionTable":
        path = os.fspath(path)
        try:
            data = np.genfromtxt(path, delimiter=",", names=True, dtype=float)
        except (OSError, ValueError) as err:
            raise RuntimeError(f"{path}: cannot read the motion table ({err})") from None
        names = data.dtype.names or ()
        if not {"t", "speed", "yaw_rate"} <= set(names):
            raise RuntimeError(f"{path}: the motion table needs the header t,speed,yaw_rate (has {','.join(names)})")
        data = np.atleast_1d(data)
        return cls.checked(data["t"], data["speed"], data["yaw_rate"], path)

    @classmethod
    def checked(cls, t, speed, yaw_rate, source: str) -> "MotionTable":
        t, speed, yaw_rate = (np.asarray(v, dtype=float) for v in (t, speed, yaw_rate))
        if len(t) == 0 or not (np.isfinite(t).all() and np.isfinite(speed).all() and np.isfinite(yaw_rate).all()):
            raise RuntimeError(f"{source}: the motion table is empty or holds a non-finite value")
        if np.any(np.diff(t) <= 0):
            raise RuntimeError(f"{source}: the motion table's times must increase")
        return cls(t, speed, yaw_rate, source)

    def at(self, t_s: float) -> tuple[float, float]:
        if not self.t[0] - 1e-6 <= t_s <= self.t[-1] + 1e-6:
            raise RuntimeError(f"{self.source}: time {t_s:.6f} s is outside the table's span "
                               f"[{self.t[0]:.6f}, {self.t[-1]:.6f}] s")
        return float(np.interp(t_s, self.t, self.speed)), float(np.interp(t_s, self.t, self.yaw_rate))


def read_kitti_poses(path: PathLike) -> list[tuple[float, float, float]]:
    """(x, y, yaw) per line of a KITTI poses file (3×4 row-major [R | t]): t's x, y and the heading of R's x axis."""
    path = os.fspath(path)
    poses = []
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            if not line.strip():
                continue
            try:
                m = [float(v) for v in line.split()]
            except ValueError:
                m = []
            if len(m) != 12 or not all(math.isfinite(v) for v in m):
                raise RuntimeError(f"{path}:{number}: a pose needs 12 finite numbers (3x4 [R|t])")
            poses.append((m[3], m[7], math.atan2(m[4], m[0])))
    return poses


def _motion_policy(motion):
    """(table, speed, yaw_rate) from ``motion``: a CSV path or MotionTable, or (speed, yaw_rate or None)."""
    if motion is None:
        raise ValueError("give the vehicle's motion: (speed, yaw_rate) or a motion CSV (t,speed,yaw_rate)")
    if isinstance(motion, MotionTable):
        return motion, None, None
    if isinstance(motion, (str, os.PathLike)):
        return MotionTable.read_csv(motion), None, None
    speed, yaw_rate = motion
    if not math.isfinite(float(speed)) or (yaw_rate is not None and not math.isfinite(float(yaw_rate))):
        raise ValueError(f"motion must be finite numbers, got speed {speed}, yaw rate {yaw_rate}")
    return None, float(speed), None if yaw_rate is None else float(yaw_rate)


def _frame_time(frame, index: int, frame_rate_hz: float) -> Optional[float]:
    if frame.timestamp is not None:
        return frame.timestamp
    return index / frame_rate_hz if frame_rate_hz > 0 else None


def _imu_yaw_rate(frame, cfg: Config) -> Optional[float]:
    if hasattr(frame, "imu_yaw_rate"):  # bag frames carry their IMU topic's reading
        return frame.imu_yaw_rate
    from . import io as rp_io

    return rp_io.imu_yaw_rate(frame, cfg)


def _with_mounting(cfg: Config, frame) -> Config:
    """The CLI's rule: without a configured mounting the first frame's ground gives it (if plausible)."""
    if cfg.sensor_height is not None or cfg.extrinsics is not None:
        return cfg
    from . import native

    m = native.estimate_mounting(np.ascontiguousarray(frame.points[:, :3]), cfg)
    max_tilt = math.radians(15.0)
    if m is None or m["height_m"] <= 0 or abs(m["roll_rad"]) > max_tilt or abs(m["pitch_rad"]) > max_tilt:
        return cfg
    return dataclasses.replace(cfg, extrinsics=Extrinsics(0.0, 0.0, m["height_m"], m["roll_rad"], m["pitch_rad"], 0.0))


def run(inputs, config: Optional[Config] = None, motion=None, poses=None, *, frames=(0, None),
        frame_rate: float = 0.0, **source_options) -> Iterator:
    """Yields one ``rp.Result`` per frame of the recording ``inputs`` (what ``rp.Estimator.process`` returns).

    motion: a CSV path (``t,speed,yaw_rate``, interpolated at each frame's time) or a MotionTable, or
    ``(speed_mps, yaw_rate_rps)`` with yaw rate None for the frame's IMU (else 0). poses: a KITTI poses file or
    a list of (x, y, yaw), one per frame of the input, moving the fusion map. frames: (first, last) indices,
    last excluded or None. frame_rate: Hz, timestamps for frames that carry none. source_options: those of
    ``rp.io.open``, and ``topic`` for bags.
    """
    from .estimator import Estimator

    cfg = config if config is not None else Config()
    table, speed, yaw_rate = _motion_policy(motion)
    if isinstance(poses, (str, os.PathLike)):
        poses = read_kitti_poses(poses)
    first, last = frames
    est = None
    for index, frame in enumerate(open_source(inputs, **source_options)):
        if last is not None and index >= last:
            break
        if index < first:
            continue
        if est is None:
            cfg = _with_mounting(cfg, frame)
            est = Estimator(cfg)
        t = _frame_time(frame, index, frame_rate)
        if table is not None:
            if t is None:
                raise RuntimeError(f"{frame.source}: frame has no timestamp to look up in {table.source} "
                                   "(give a frame rate for file inputs)")
            (v, w), source = table.at(t), "motion"
        elif yaw_rate is not None:
            (v, w), source = (speed, yaw_rate), "option"
        else:
            imu = _imu_yaw_rate(frame, cfg)
            (v, w), source = (speed, imu if imu is not None else 0.0), "imu" if imu is not None else "default"
        pose = None
        if poses is not None:
            if index >= len(poses):
                raise RuntimeError(f"poses: no pose for frame {index} (there are {len(poses)})")
            pose = poses[index]
        if frame.sequence_break and index > first:
            est.reset()
        yield est.process(frame.points, v, w, source=frame.source, timestamp=t, yaw_rate_source=source, pose=pose)
