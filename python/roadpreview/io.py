"""Reading frames: KITTI ``.bin`` / ``.pcd`` files and Ouster / Velodyne pcap recordings (decoded in C++).

    for frame in rp.io.open("tests/data/ouster/OS-1-128_v2.3.0_1024x10_lb_n3.pcap"):
        frame.points, frame.timestamp, frame.frame_id      # (N, 4) float32 in the sensor frame, s, int
"""

from __future__ import annotations

import os
from typing import Optional, Sequence, Union

import numpy as np

from ._native import core

PathLike = Union[str, "os.PathLike[str]"]


def read(path: PathLike, columns: int = 0) -> np.ndarray:
    """Points of a frame file as an (N, 4) float32 array: x, y, z, intensity (0 when the file has none).

    ``.bin``: raw little-endian float32, ``columns`` values per point (default 5 for nuScenes ``*.pcd.bin``,
    else 4 as KITTI); ``.pcd`` (any encoding); ``.ply`` (ascii, binary little or big endian).
    Raises RuntimeError naming the file when it is missing, truncated or corrupt, or when its header declares
    more data than the file holds.
    """
    return core().read_frame(os.fspath(path), int(columns))


def expand(inputs: list[str]) -> list[str]:
    """Files of the given files and directories (directories sorted by name), as the CLI sees them."""
    return core().expand_inputs([os.fspath(p) for p in inputs])


def open(path: Union[PathLike, Sequence[PathLike]], meta: Optional[PathLike] = None, *,  # noqa: A001
         sensor_model: Optional[str] = None, calibration: Optional[PathLike] = None, cut_angle_deg: float = 0.0,
         lidar_port: int = 0, skip_bad_packets: bool = False, columns: int = 0,
         beam_calibration: Optional[PathLike] = None):
    """An iterable of frames, decoded one at a time with constant memory (as ``roadpreview run`` reads them).

    path: ``.pcap``/``.pcapng`` recordings (several: split recordings of one drive, read in order), or
    ``.bin``/``.pcd``/``.ply`` files and directories (a list); ``columns`` as in :func:`read`. A file frame's
    ``.sequence_break`` says why it does not continue the previous file (docs/method.md, "Inputs").
    meta: Ouster metadata JSON; by default the ``.json`` next to the pcap whose name is the pcap's name or
    its longest ``_``-separated prefix. A pcap without metadata is read as Velodyne when it holds Velodyne
    data packets; ``sensor_model`` ("VLP-16", "VLP-32C", "HDL-32E", "HDL-64E") overrides the model read from
    the packets, ``calibration`` is a ROS velodyne_pointcloud YAML (HDL-64E needs one), ``cut_angle_deg``
    the azimuth where one Velodyne sweep ends. ``lidar_port`` overrides the metadata's UDP port.

    Each frame has ``.points`` ((N, 4) float32: x, y, z in m in the sensor frame, then reflectivity),
    ``.timestamp`` (s; capture time of the frame's first packet), ``.frame_id``, ``.point_times``,
    ``.imu_angular_velocity`` and ``.diagnostics`` (missing columns, skipped packets, complete).
    The iterator's ``.info`` describes the recording. Bad input raises RuntimeError naming the file and the
    problem; frames yielded before it stay valid. ``skip_bad_packets=True`` skips and counts lidar packets
    that do not decode instead. ``beam_calibration`` is a beams file (``rp.calibrate_beams``, ``roadpreview
    calibrate``) applied while decoding; a file for another sensor raises RuntimeError naming it. Frames also have
    ``.beams`` (int32 beam of each point; empty when the input does not number them).
    """
    paths = [path] if isinstance(path, (str, os.PathLike)) else list(path)
    return core().open_frames([os.fspath(p) for p in paths], os.fspath(meta) if meta else "", sensor_model or "",
                              os.fspath(calibration) if calibration else "", float(cut_angle_deg), int(lidar_port),
                              bool(skip_bad_packets), int(columns),
                              os.fspath(beam_calibration) if beam_calibration else "")


def imu_yaw_rate(frame, cfg=None) -> Optional[float]:
    """Yaw rate (rad/s, base frame) of the mean IMU angular velocity of ``frame``, rotated by the config's
    extrinsics; None when the frame has no IMU samples."""
    from .config import Config

    return core().imu_yaw_rate(frame, (cfg if cfg is not None else Config()).to_json())
