"""Reading frames: KITTI ``.bin`` / ``.pcd`` files, Ouster / Velodyne pcap recordings and stereo camera pairs
(decoded and matched in C++).

    for frame in rp.io.open("tests/data/ouster/OS-1-128_v2.3.0_1024x10_lb_n3.pcap"):
        frame.points, frame.timestamp, frame.frame_id      # (N, 4) float32 in the sensor frame, s, int
"""

from __future__ import annotations

import os
from dataclasses import dataclass
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
         beam_calibration: Optional[PathLike] = None, roi_columns=None, roi_direction: str = "ahead"):
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

    ``roi_columns``: a :class:`roadpreview.Config` with the sensor's mounting (``sensor_height`` or
    ``extrinsics``): each frame ends as soon as its region of interest, facing ``roi_direction`` ("ahead",
    "behind" when reversing, "both"), has been scanned (``roadpreview run --roi-columns``). An Ouster recording
    decodes only the columns that can see it; a Velodyne sweep ends at the cut angle after it (``cut_angle_deg``
    is not used). ``.info["notes"]`` says which; frame files raise RuntimeError.
    """
    paths = [path] if isinstance(path, (str, os.PathLike)) else list(path)
    return core().open_frames([os.fspath(p) for p in paths], os.fspath(meta) if meta else "", sensor_model or "",
                              os.fspath(calibration) if calibration else "", float(cut_angle_deg), int(lidar_port),
                              bool(skip_bad_packets), int(columns),
                              os.fspath(beam_calibration) if beam_calibration else "",
                              *_roi_regions(roi_columns, roi_direction))


_ROI_DIRECTIONS = {"ahead": [1.0], "behind": [-1.0], "both": [1.0, -1.0]}


def _roi_regions(config, direction: str) -> tuple[str, list[float]]:
    """The native arguments of ``roi_columns``: the config as JSON and the directions it faces."""
    if config is None:
        return "", []
    if direction not in _ROI_DIRECTIONS:
        raise ValueError(f"roi_direction {direction!r}: expected one of {', '.join(_ROI_DIRECTIONS)}")
    if config.sensor_height is None and config.extrinsics is None:
        raise ValueError("roi_columns needs the sensor's mounting: a Config with sensor_height or extrinsics")
    return config.to_json(), _ROI_DIRECTIONS[direction]


def open_live(url: str, meta: Optional[PathLike] = None, *, sensor_model: Optional[str] = None,
              calibration: Optional[PathLike] = None, cut_angle_deg: float = 0.0, skip_bad_packets: bool = False,
              timeout_s: float = 5.0, duration_s: float = 0.0, roi_columns=None, roi_direction: str = "ahead",
              busy_wait: bool = False):
    """Frames of a live sensor as they complete, from UDP datagrams received on a thread (``roadpreview run
    udp://...``). The same iterable of frames as :func:`open`.

    url: ``udp://[ADDR][:PORT]``. With ``meta`` (Ouster metadata JSON) an Ouster: the lidar packets on PORT (else
    the metadata's), the IMU packets on the metadata's IMU port moved by as much (else PORT + 1). Without, a
    Velodyne on PORT (default 2368), the model from the packets or ``sensor_model``.
    No datagram within ``timeout_s`` raises RuntimeError naming the address; a silence that long after datagrams
    ends the iteration (the frame being assembled comes last), and so does ``duration_s`` > 0 (s from opening).
    A port in use, a datagram of the wrong size or from another sensor raise RuntimeError naming the address.
    Each frame's ``.arrival_s`` is the :func:`steady_now_s` time of the datagram that completed it,
    ``.completed_s`` the time the decoder had it complete (that datagram decoded, the frame built), and
    ``.diagnostics`` counts lost, late and duplicate packets and missing columns; ``.info`` counts the datagrams
    received and dropped by the full receive queue. ``roi_columns`` and ``roi_direction`` as in :func:`open`:
    a frame completes when the last column that can see the region of interest arrives. ``busy_wait``: ``next()``
    waits for datagrams on a busy core (yielding it to any other thread ready to run) instead of sleeping until
    woken — one core kept busy while waiting, and the frames processed after it on a core that did not go idle
    (README "Live sensors": the latency's 99th percentile about 1 ms lower).
    ``close()`` (or leaving a ``with`` block) ends the stream from any thread: a ``next()`` waiting on another thread
    returns within 20 ms (the frame being assembled, then the end of the iteration), and the sockets are released
    (also when the source is freed). ``info`` stays readable after closing.
    """
    return core().open_live(str(url), os.fspath(meta) if meta else "", sensor_model or "",
                            os.fspath(calibration) if calibration else "", float(cut_angle_deg),
                            bool(skip_bad_packets), float(timeout_s), float(duration_s),
                            *_roi_regions(roi_columns, roi_direction), bool(busy_wait))


def replay(capture: PathLike, to: str = "127.0.0.1:7502", *, rate: Union[float, str] = 1.0, loops: int = 1,
           drop: float = 0.0, reorder: float = 0.0, seed: int = 1) -> dict:
    """Sends the UDP payloads of a pcap/pcapng capture to ``to`` ("ADDR:PORT") with their recorded timing
    (``roadpreview replay``): ``rate`` times the recorded speed or "max"; ``loops`` times through the capture.
    The capture's busiest port goes to PORT, other ports keep their distance from it. ``drop`` and ``reorder``
    (test hooks): fractions of the datagrams left out and sent one place late. Returns the counts sent, dropped,
    reordered, and ``clock_jumps``: steps of the capture's clock over 5 s between two records (sent one after the
    other, not after the gap). Blocks until done (the GIL is released: run it on a thread beside :func:`open_live`).
    """
    factor = 0.0 if rate == "max" else float(rate)
    if rate != "max" and not factor > 0.0:
        raise ValueError(f"rate {rate!r}: expected a factor > 0 or 'max'")
    return core().replay(os.fspath(capture), str(to), factor, int(loops), float(drop), float(reorder), int(seed))


def steady_now_s() -> float:
    """Seconds on the steady clock of a live frame's ``.arrival_s``."""
    return core().steady_now_s()


def imu_yaw_rate(frame, cfg=None) -> Optional[float]:
    """Yaw rate (rad/s, base frame) of the mean IMU angular velocity of ``frame``, rotated by the config's
    extrinsics; None when the frame has no IMU samples."""
    from .config import Config

    return core().imu_yaw_rate(frame, (cfg if cfg is not None else Config()).to_json())


@dataclass
class StereoPoints:
    """Points of one stereo pair (see :func:`stereo_points`)."""

    points: np.ndarray  #: (N, 4) float32: x, y, z (m, camera frame: x ahead, y left, z up), grey level 0..1
    range_variances: np.ndarray  #: (N,) float32 m²: variance of each point's distance along its line of sight
    pixels: np.ndarray  #: (N,) int32: row · width + column of each point's pixel in the left image
    #: (N,) int32: each point's error group, its tile of 2·stereo.error_correlation_along_px columns by
    #: 2·stereo.error_correlation_across_px rows: points of one tile share a matching error
    error_groups: np.ndarray
    first_row: int  #: the first image row matched (rows above it see no road within stereo.max_depth_m)
    disparity: np.ndarray  #: (rows, columns) float32 px, 0 where invalid


def stereo_points(left, right, calib: PathLike, *, disparity=None, config=None) -> StereoPoints:
    """Points of one rectified stereo pair, matched in C++ with OpenCV's StereoSGBM (``config.stereo``).

    left, right: image files (PNG, grey or colour, 8 or 16 bit) or 2-D uint8 grey arrays; None with ``disparity``.
    calib: KITTI ``calib.txt`` (P2/P3) or a YAML with fx, fy, cx, cy, baseline and optional extrinsics.
    disparity: a precomputed disparity, a 16-bit PNG (KITTI: disparity × 256) or a float (rows, columns) array in
    px (≤ 0, infinite or NaN invalid), used instead of matching. config: a :class:`roadpreview.Config`; its
    sensor_height / extrinsics (else the calibration's extrinsics) pose the camera for the road rows.
    Bad input (unreadable images, a pair of different sizes, a calibration without P2/P3, a zero or negative
    baseline, an 8-bit image as disparity) raises RuntimeError or ValueError naming the file.
    """
    from .config import Config

    cfg = config if config is not None else Config()
    as_input = (lambda x: os.fspath(x) if isinstance(x, (str, os.PathLike)) else x)
    if isinstance(disparity, np.ndarray) and not np.issubdtype(disparity.dtype, np.floating):
        # A KITTI disparity PNG read as an array holds disparity × 256: taken as px, every depth is 256× short.
        raise ValueError(f"disparity: an array must hold float px, got {disparity.dtype} (a 16-bit disparity PNG "
                         f"holds disparity x 256: divide by 256, or pass the PNG's path)")
    found, disp = core().stereo_points(as_input(left), as_input(right), os.fspath(calib), as_input(disparity),
                                       cfg.to_json())
    return StereoPoints(found["points"], found["range_variances"], found["pixels"], found["error_groups"],
                        found["first_row"], disp)


def open_stereo(left: Optional[PathLike] = None, right: Optional[PathLike] = None, calib: Optional[PathLike] = None, *,
                disparity: Optional[PathLike] = None, config=None):
    """An iterable of frames from stereo pairs, as ``roadpreview run --stereo LEFT RIGHT --calib FILE`` reads them.

    left, right: image files or directories of PNGs (paired in name order); disparity: a 16-bit disparity PNG or a
    directory of them (used instead of matching). Each frame has ``.points`` ((N, 4) float32, camera frame),
    ``.range_variances`` (m² per point) and ``.error_groups`` (pass both to ``Estimator.process(...,
    range_variances=..., error_groups=...)``), ``.source`` and ``.frame_id``. The camera's pose comes from
    ``config`` (sensor_height / extrinsics), else from the calibration YAML; neither raises ValueError.
    """
    from .config import Config

    if calib is None:
        raise ValueError("open_stereo needs calib: a KITTI calib.txt or a stereo calibration YAML")
    cfg = config if config is not None else Config()
    paths = (lambda x: [os.fspath(x)] if x is not None else [])
    return core().open_stereo(paths(left), paths(right), paths(disparity), os.fspath(calib), cfg.to_json())


def read_stereo_calibration(path: PathLike) -> dict:
    """fx, fy, cx, cy (px), baseline (m), extrinsics (dict or None) and source of a stereo calibration file."""
    return core().read_stereo_calibration(os.fspath(path))
