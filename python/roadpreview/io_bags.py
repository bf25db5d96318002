# SPDX-License-Identifier: BSD-3-Clause
"""ROS 1 bags, ROS 2 bags and MCAP files (the ``rosbags`` package; no ROS installation needed).

    for frame in rp.io_bags.open_bag("drive.bag", topic="/points"):
        frame.points, frame.timestamp          # (N, 4) float32 x, y, z, intensity in the sensor frame; s

Point clouds: ``sensor_msgs/PointCloud2`` (x, y, z and an intensity field, in whatever order, offset, type and
byte order the message declares; organised or not; the header stamp is the frame's time). Ouster packet bags
(ouster-ros ``PacketMsg`` lidar and IMU topics plus the ``metadata`` string topic) are decoded by the library's
Ouster decoder, as a pcap would be. ``nav_msgs/Odometry`` and ``sensor_msgs/Imu`` topics give the motion
(:func:`motion_table`).
"""

from __future__ import annotations

import os
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator, Optional, Sequence

import numpy as np

POINTCLOUD2 = "sensor_msgs/msg/PointCloud2"
ODOMETRY = "nav_msgs/msg/Odometry"
IMU = "sensor_msgs/msg/Imu"
OUSTER_PACKET_TYPES = ("ouster_ros/msg/PacketMsg", "ouster_sensor_msgs/msg/PacketMsg")
STRING = "std_msgs/msg/String"

# sensor_msgs/PointField datatypes → numpy kinds and sizes
_FIELD_TYPES = {1: "i1", 2: "u1", 3: "i2", 4: "u2", 5: "i4", 6: "u4", 7: "f4", 8: "f8"}
_INTENSITY_NAMES = ("intensity", "reflectivity", "i", "remission", "signal")


@dataclass
class BagFrame:
    """One point cloud of a bag, shaped like ``rp.io`` frames."""

    points: np.ndarray
    timestamp: Optional[float]
    source: str
    frame_id: int
    sequence_break: str = ""
    imu_yaw_rate: Optional[float] = None  # bags give motion through motion_table(), not per frame
    diagnostics: dict = field(default_factory=lambda: {"missing_columns": 0, "skipped_packets": 0, "complete": True})


@contextmanager
def bag_reader(paths: Sequence[str]):
    """An open rosbags AnyReader (ROS 1 bag, ROS 2 bag with SQLite or MCAP storage); unreadable files raise
    RuntimeError naming the file."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    for p in paths:
        if not os.path.exists(p):
            raise RuntimeError(f"{p}: no such bag")
    try:
        reader = AnyReader([Path(p) for p in paths], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except Exception as err:  # rosbags raises its own error classes per format
        raise RuntimeError(f"{paths[0]}: not a readable ROS bag or MCAP file ({err})") from None
    try:
        yield reader
    finally:
        reader.close()


def topics(path) -> list[dict]:
    """Every topic of a bag: name, message type, message count."""
    paths = _paths(path)
    with bag_reader(paths) as reader:
        counts: dict = {}
        for c in reader.connections:
            entry = counts.setdefault(c.topic, {"topic": c.topic, "type": c.msgtype, "messages": 0})
            entry["messages"] += c.msgcount
        return sorted(counts.values(), key=lambda d: d["topic"])


def _paths(path) -> list[str]:
    return [os.fspath(path)] if isinstance(path, (str, os.PathLike)) else [os.fspath(p) for p in path]


def _choose(paths: list[str], available: list[dict], topic: Optional[str]) -> tuple[str, str]:
    """(kind, topic): the given topic, else the bag's only point-cloud or Ouster packet topic."""
    clouds = [t for t in available if t["type"] == POINTCLOUD2]
    packets = [t for t in available if t["type"] in OUSTER_PACKET_TYPES and "lidar" in t["topic"]]
    listing = ", ".join(f"{t['topic']} ({t['type']})" for t in available) or "none"
    if topic is not None:
        match = [t for t in available if t["topic"] == topic]
        if not match:
            raise ValueError(f"{paths[0]}: no topic {topic}; the bag has {listing}")
        if match[0]["type"] == POINTCLOUD2:
            return "cloud", topic
        if match[0]["type"] in OUSTER_PACKET_TYPES:
            return "ouster", topic
        raise ValueError(f"{paths[0]}: topic {topic} holds {match[0]['type']}, not point clouds or Ouster packets")
    choices = clouds + packets
    if not choices:
        raise ValueError(f"{paths[0]}: no point clouds in this bag (no sensor_msgs/PointCloud2 or Ouster packet "
                         f"topic); it has {listing}")
    if len(choices) > 1:
        names = ", ".join(t["topic"] for t in choices)
        raise ValueError(f"{paths[0]}: several point-cloud topics ({names}): choose one with --topic")
    return ("cloud" if choices[0]["type"] == POINTCLOUD2 else "ouster"), choices[0]["topic"]


def stamp_s(header) -> float:
    return float(header.stamp.sec) + 1e-9 * float(header.stamp.nanosec)


def cloud_points(msg, where: str = "PointCloud2") -> np.ndarray:
    """(N, 4) float32 x, y, z, intensity (0 without one) of a PointCloud2; rows with a non-finite x/y/z dropped."""
    fields = {f.name: f for f in msg.fields}
    missing = [n for n in "xyz" if n not in fields]
    if missing:
        raise ValueError(f"{where}: the PointCloud2 has no {'/'.join(missing)} field (fields: "
                         f"{', '.join(fields) or 'none'})")
    intensity = next((n for n in _INTENSITY_NAMES if n in fields), None)
    names = ["x", "y", "z"] + ([intensity] if intensity else [])
    order = ">" if msg.is_bigendian else "<"
    step, width, height = int(msg.point_step), int(msg.width), int(msg.height)
    formats = []
    for n in names:
        f = fields[n]
        if f.datatype not in _FIELD_TYPES:
            raise ValueError(f"{where}: field {n} has unknown datatype {f.datatype}")
        if f.offset + np.dtype(_FIELD_TYPES[f.datatype]).itemsize > step:
            raise ValueError(f"{where}: field {n} at offset {f.offset} lies outside the point step {step}")
        formats.append(order + _FIELD_TYPES[f.datatype])
    dtype = np.dtype({"names": names, "formats": formats, "offsets": [fields[n].offset for n in names],
                      "itemsize": step})
    data = np.frombuffer(bytes(msg.data) if not isinstance(msg.data, np.ndarray) else msg.data, dtype=np.uint8)
    row_step = int(msg.row_step) if height > 1 else width * step
    if row_step < width * step or data.size < height * row_step:
        raise ValueError(f"{where}: the data holds {data.size} bytes, the header declares {height} rows of "
                         f"{width} points × {step} bytes (row step {row_step})")
    rows = data[: height * row_step].reshape(height, row_step)[:, : width * step]
    cloud = np.ascontiguousarray(rows).view(dtype).reshape(-1)
    out = np.zeros((cloud.size, 4), dtype=np.float32)
    for k, n in enumerate(names):
        out[:, k] = cloud[n]
    return out[np.isfinite(out[:, :3]).all(axis=1)]


class BagSource:
    """Iterates the frames of a bag's chosen topic; ``.info`` says what was chosen."""

    def __init__(self, paths: list[str], topic: Optional[str] = None):
        self.paths = paths
        available = topics(paths)
        self.kind, self.topic = _choose(paths, available, topic)
        self.info = {"format": "ros bag", "topic": self.topic, "sensor_model": "", "beams": 0,
                     "topics": available, "notes": []}
        if self.kind == "ouster":
            self._ouster = _ouster_decoder(paths, available)
            self.info.update(self._ouster.info, format="ouster bag", topic=self.topic)

    def __iter__(self) -> Iterator:
        return self._clouds() if self.kind == "cloud" else self._ouster_frames()

    def _clouds(self):
        with bag_reader(self.paths) as reader:
            conns = [c for c in reader.connections if c.topic == self.topic]
            for k, (c, t_ns, raw) in enumerate(reader.messages(connections=conns)):
                msg = reader.deserialize(raw, c.msgtype)
                where = f"{self.paths[0]}: {self.topic} message {k}"
                stamp = stamp_s(msg.header)
                yield BagFrame(cloud_points(msg, where), stamp if stamp > 0 else t_ns * 1e-9, self.paths[0], k)

    def _ouster_frames(self):
        imu_topics = {t["topic"] for t in self.info["topics"]
                      if t["type"] in OUSTER_PACKET_TYPES and "imu" in t["topic"]}
        with bag_reader(self.paths) as reader:
            conns = [c for c in reader.connections if c.topic == self.topic or c.topic in imu_topics]
            for c, t_ns, raw in reader.messages(connections=conns):
                buf = bytes(reader.deserialize(raw, c.msgtype).buf)
                if c.topic in imu_topics:
                    self._ouster.add_imu(buf, t_ns * 1e-9)
                    continue
                frame = self._ouster.add_packet(buf, t_ns * 1e-9)
                if frame is not None:
                    yield frame
        last = self._ouster.finish()
        if last is not None:
            yield last


def _ouster_decoder(paths: list[str], available: list[dict]):
    from ._native import core

    meta_topics = [t["topic"] for t in available if t["type"] == STRING and "metadata" in t["topic"]]
    if not meta_topics:
        raise ValueError(f"{paths[0]}: Ouster packets but no metadata topic (std_msgs/String named *metadata*)")
    with bag_reader(paths) as reader:
        conns = [c for c in reader.connections if c.topic == meta_topics[0]]
        for c, _, raw in reader.messages(connections=conns):
            text = reader.deserialize(raw, c.msgtype).data
            try:
                return core().OusterPacketDecoder(text, paths[0])
            except (RuntimeError, ValueError) as err:
                raise RuntimeError(f"{paths[0]}: {meta_topics[0]}: {err}") from None
    raise ValueError(f"{paths[0]}: the metadata topic {meta_topics[0]} holds no message")


def open_bag(inputs, topic: Optional[str] = None, **source_options) -> BagSource:
    """Frames of a bag (one drive; several paths: one ROS 2 bag's files). Source options of pcaps (``meta``
    and so on) do not apply and are refused."""
    given = {k: v for k, v in source_options.items() if v not in (None, "", 0, 0.0, False)}
    if given:
        raise ValueError(f"{_paths(inputs)[0]}: {', '.join(sorted(given))} do not apply to ROS bags")
    return BagSource(_paths(inputs), topic)


def motion_table(inputs, topic: Optional[str] = None, speed_mps: Optional[float] = None):
    """Motion of the drive from the bag: an Odometry topic gives speed (twist.linear.x) and yaw rate
    (twist.angular.z, base frame); an Imu topic gives the yaw rate (angular_velocity.z), the speed coming from
    ``speed_mps``. Returns a ``roadpreview.drive.MotionTable`` (at least two messages) in the bag's clock."""
    from .drive import MotionTable

    paths = _paths(inputs)
    available = topics(paths)
    odometry = [t["topic"] for t in available if t["type"] == ODOMETRY]
    imu = [t["topic"] for t in available if t["type"] == IMU]
    chosen = topic or (odometry or imu or [None])[0]
    if chosen is None:
        raise ValueError(f"{paths[0]}: no nav_msgs/Odometry or sensor_msgs/Imu topic to take the motion from")
    kind = next((t["type"] for t in available if t["topic"] == chosen), None)
    if kind not in (ODOMETRY, IMU):
        raise ValueError(f"{paths[0]}: topic {chosen} is not nav_msgs/Odometry or sensor_msgs/Imu")
    if kind == IMU and speed_mps is None:
        raise ValueError(f"{paths[0]}: {chosen} gives the yaw rate only: give the speed too")
    t, v, w = [], [], []
    with bag_reader(paths) as reader:
        for c, _, raw in reader.messages(connections=[c for c in reader.connections if c.topic == chosen]):
            msg = reader.deserialize(raw, c.msgtype)
            t.append(stamp_s(msg.header))
            if kind == ODOMETRY:
                v.append(msg.twist.twist.linear.x)
                w.append(msg.twist.twist.angular.z)
            else:
                v.append(speed_mps)
                w.append(msg.angular_velocity.z)
    return MotionTable.from_samples(t, v, w, f"{paths[0]}: {chosen}")
