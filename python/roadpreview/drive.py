# SPDX-License-Identifier: BSD-3-Clause
"""One recording, frame by frame, the way ``roadpreview run`` processes it: ``rp.drive.run``.

    for res in rp.drive.run(["drive.pcap"], rp.Config(sensor_height=1.97), motion=(2.5, None)):
        res.vehicle.iso_class, res.to_dict()

The per-frame policy (motion table > given yaw rate > the frame's IMU > 0; timestamps from the recording, else
index / frame rate; poses; a new file sequence clears the fusion map; the mounting from the first frame with ground
when none is configured) is the C++ DriveRunner's (cpp/src/drive/), the one ``roadpreview run`` and ``rp.run``
follow. This module adds what Python reads: ROS bags and MCAP files (:mod:`roadpreview.io_bags`, their frames
fed to the runner from Python), motion tables and poses in memory (a bag's odometry topic, LiDAR odometry).
"""

from __future__ import annotations

import os
from typing import Optional, Sequence, Union

from ._native import core
from .config import Config

PathLike = Union[str, "os.PathLike[str]"]
BAG_SUFFIXES = (".bag", ".mcap", ".db3")

#: Speed and yaw rate against time (the C++ MotionTable): ``MotionTable.read_csv(path)`` (header
#: ``t,speed,yaw_rate``), ``MotionTable.from_samples(t, speed, yaw_rate, source)``; ``.at(t)`` → (m/s, rad/s).
MotionTable = core().MotionTable


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


def read_kitti_poses(path: PathLike) -> list[tuple[float, float, float]]:
    """(x, y, yaw) per line of a KITTI poses file (3×4 row-major [R | t]): t's x, y and the heading of R's x axis,
    as the runner reads them. RuntimeError naming the file and line for a malformed pose."""
    return core().read_kitti_poses(os.fspath(path))


def run(inputs, config: Optional[Config] = None, motion=None, poses=None, *, frames=(0, None),
        frame_rate: float = 0.0, **source_options):
    """The results (``rp.Result``) of the recording ``inputs``, one per frame, through the C++ DriveRunner.

    inputs: what :func:`open_source` reads (pcaps, frame files, bags), or a frame source it returned.
    motion: a CSV path (``t,speed,yaw_rate``, interpolated at each frame's time) or a :data:`MotionTable`, or
    ``(speed_mps, yaw_rate_rps)`` with yaw rate None for the frame's IMU (else 0). poses: a list of (x, y, yaw),
    one per frame of the input: each frame's pose, moving the fusion map when there is one, else only placing
    the frame; or a KITTI poses file, which needs ``config.fusion.method``. frames: (first, last) indices, last excluded or None. frame_rate: Hz, timestamps for frames that carry
    none. source_options: those of ``rp.io.open``, and ``topic`` for bags. Returns a ``roadpreview.Drive``
    (an iterator; ``.notes``, ``.config``).
    """
    from . import drive_runner

    if motion is None:
        raise ValueError("give the vehicle's motion: (speed, yaw_rate) or a motion CSV (t,speed,yaw_rate)")
    speed = yaw_rate = table = None
    if isinstance(motion, (str, os.PathLike, MotionTable)):
        table = motion
    else:
        speed, yaw_rate = motion
    return drive_runner.run(inputs, config, motion=table, poses=poses, speed=speed, yaw_rate=yaw_rate,
                            frame_rate=frame_rate, frames=frames, **source_options)


def is_source(inputs) -> bool:
    """A recording already opened: an ``rp.io`` frame source or a bag's."""
    from .io_bags import BagSource

    return isinstance(inputs, (core().FrameSource, BagSource))
