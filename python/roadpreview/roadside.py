# SPDX-License-Identifier: BSD-3-Clause
"""Roadside perception: 2-D laser scanners (and a pole camera) → classified, tracked objects in WGS84.

    import roadpreview as rp
    scans = rp.roadside.read_scans("lms511.pcapng.json")          # SICK dumps/captures, CARMEN, CSV
    scans = rp.roadside.read_rosbag_scans("people.bag")           # sensor_msgs/LaserScan (ROS 1/2 bags, MCAP)
    proc = rp.roadside.Processor("site.yaml")                      # or the YAML text
    cycles = proc.run(scans, detections=[(t, x, y, w, h, "car", 0.9), ...])
    detections = rp.roadside.detect_video("camera.mp4")            # HOG people (+ cascades): the same tuples
    cycles[-1]["objects"][0]["lat_deg"]                            # exactly the CLI's output line, as a dict

A scan is a dict: time_s, scanner (index into the site's scanners), counter, start_angle_rad, step_rad (scanner
frame: 0 = straight ahead, counter-clockwise), ranges_m (float32, NaN = no return), intensities, pose (None, or
x, y, yaw of a moving scanner in its log's world frame: such scans are classified against a world background
learned from the whole log, docs/method.md "Roadside"), source.
"""

from __future__ import annotations

import csv
import json
import math
import os
import re
import shutil
import subprocess
import sysconfig
import tempfile
import warnings
from pathlib import Path
from typing import Iterable, Optional, Sequence, Union

import numpy as np

from ._native import core

PathLike = Union[str, os.PathLike]


def _rs():
    return core().roadside


DEFAULT_SCAN_RATE_HZ = 37.5  #: a SICK LMS's scan rate, for logs whose scans carry no time


def read_scans(path: PathLike, scanner: Optional[int] = None, rate_hz: Optional[float] = None, skip_bad: bool = False,
               sensor_port: int = 2112) -> list[dict]:
    """Scans of a file by its extension: SICK ``.json`` dump, ``.pcap``/``.pcapng`` (TCP port `sensor_port`),
    CARMEN ``.log[.gz]`` (timed at `rate_hz` when its timestamps are 0: without it at 37.5 Hz, with a warning),
    scan ``.csv``, ROS bag / MCAP."""
    p = str(path)
    if p.endswith(".csv"):
        scans = _rs().read_scan_csv(p)
    elif p.endswith(".json"):
        scans = _rs().read_sick_json(p, skip_bad)
    elif p.endswith((".pcap", ".pcapng")):
        scans = _rs().read_sick_pcap(p, sensor_port, skip_bad)
    elif p.endswith((".log", ".log.gz", ".clf", ".clf.gz")):
        scans, untimed = _rs().read_carmen_log(p, DEFAULT_SCAN_RATE_HZ if rate_hz is None else rate_hz)
        if untimed and rate_hz is None:
            warnings.warn(f"{p}: the log's timestamps are all 0; its scans are timed at {DEFAULT_SCAN_RATE_HZ} Hz "
                          "(give rate_hz: a robot's log may be slower)", stacklevel=2)
    elif p.endswith((".bag", ".mcap", ".db3")) or Path(p).is_dir():
        scans = read_rosbag_scans(p)
    else:
        raise ValueError(f"{p}: unknown scan format (.csv, .json, .pcap, .pcapng, .log[.gz], .bag, .mcap)")
    if scanner is not None:
        for s in scans:
            s["scanner"] = scanner
    return scans


def read_rosbag_scans(path: PathLike, topic: Optional[str] = None, scanner: int = 0) -> list[dict]:
    """sensor_msgs/LaserScan messages of a ROS 1 bag, a ROS 2 bag (folder) or MCAP, with the `rosbags` package.
    Time: the message header's stamp. Ranges outside [range_min, range_max] or not finite are no return."""
    from .io_bags import bag_reader  # the rosbags package, optional: pip install roadpreview[roadside]

    out = []
    with bag_reader([os.fspath(path)]) as reader:  # an unreadable file: RuntimeError naming it
        conns = [c for c in reader.connections if c.msgtype.endswith("LaserScan") and (topic is None or c.topic == topic)]
        if not conns:
            raise ValueError(f"{path}: no sensor_msgs/LaserScan topic" + (f" named {topic}" if topic else ""))
        for conn, _, raw in _messages(reader, conns, path):
            msg = reader.deserialize(raw, conn.msgtype)
            r = np.asarray(msg.ranges, dtype=np.float32).copy()
            bad = ~np.isfinite(r) | (r < msg.range_min) | (r > msg.range_max)
            r[bad] = np.nan
            stamp = msg.header.stamp
            out.append(dict(time_s=stamp.sec + stamp.nanosec * 1e-9, scanner=scanner, counter=len(out),
                            start_angle_rad=float(msg.angle_min), step_rad=float(msg.angle_increment), ranges_m=r,
                            intensities=np.asarray(msg.intensities, np.float32) if len(msg.intensities) else None,
                            pose=None, source=f"{path}:{conn.topic}#{len(out)}"))
    return out


def _messages(reader, connections, path):
    """The reader's messages; a bag that breaks off midway raises RuntimeError naming it (rosbags' own errors name
    no file)."""
    try:
        yield from reader.messages(connections=connections)
    except Exception as err:  # rosbags raises its own error classes per format
        raise RuntimeError(f"{path}: the bag breaks off ({err})") from None


def write_scan_csv(scans: Iterable[dict], path: PathLike) -> None:
    """Scans to the CLI's CSV (t,scanner,angle_deg,range_m), one row per beam; no return is an empty cell."""
    with open(path, "w") as f:
        f.write("t,scanner,angle_deg,range_m\n")
        for s in scans:
            angles = np.degrees(s["start_angle_rad"] + s["step_rad"] * np.arange(len(s["ranges_m"])))
            for a, r in zip(angles, s["ranges_m"]):
                f.write(f"{s['time_s']:.6f},{s['scanner']},{a:.6f},{'' if not np.isfinite(r) else f'{r:.4f}'}\n")


def detect_video(path: PathLike, *, cascades: Optional[dict] = None, people: bool = True,
                 people_threshold: float = 0.0, process_width: int = 720, stride: int = 1, start_s: float = 0.0,
                 expect_size: Optional[tuple[int, int]] = None) -> list[tuple]:
    """Camera detections from a video by the helper program `roadpreview-video` (OpenCV's HOG people detector,
    class "pedestrian", and Viola–Jones `cascades` {class: cascade XML}): (t, x, y, w, h, class, score) tuples,
    px, t = the frame's time in the video + `start_s`. Raises RuntimeError with the helper's message."""
    helper = shutil.which("roadpreview-video", path=os.pathsep.join([sysconfig.get_path("scripts"),
                                                                     os.environ.get("PATH", "")]))
    if helper is None:
        raise RuntimeError("roadpreview-video is not installed (it comes with the package: pip install .)")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "detections.csv"
        args = [helper, os.fspath(path), "-o", str(out), "-q", "--process-width", str(int(process_width)),
                "--stride", str(int(stride)), "--start", repr(float(start_s)),
                "--people-threshold", repr(float(people_threshold))]
        for cls, xml in (cascades or {}).items():
            args += ["--cascade", f"{cls}={os.fspath(xml)}"]
        if not people:
            args.append("--no-people")
        if expect_size:
            args += ["--expect-size", f"{int(expect_size[0])}x{int(expect_size[1])}"]
        proc = subprocess.run(args, capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(proc.stderr.strip().removeprefix("roadpreview-video: error: "))
        with open(out) as f:
            return [(float(r["t"]), float(r["x"]), float(r["y"]), float(r["w"]), float(r["h"]), r["class"],
                     float(r["score"])) for r in csv.DictReader(f)]


def decode_telegram(data: bytes) -> Optional[dict]:
    """Every field of one framed SICK LMDscandata telegram (CoLa-A or CoLa-B); None for other telegrams."""
    return _rs().decode_telegram(data)


def site_to_wgs84(site: str, x_m: float, y_m: float) -> tuple[float, float]:
    """(lat, lon) in degrees of a site-frame ground point; `site` is the YAML text of a site file."""
    return _rs().site_to_wgs84(_site_text(site), x_m, y_m)


def wgs84_to_site(site: str, lat_deg: float, lon_deg: float) -> tuple[float, float]:
    return _rs().wgs84_to_site(_site_text(site), lat_deg, lon_deg)


def _native_scan(scan: dict) -> dict:
    """The keys the C++ processor reads, typed (a scan dict may come from any reader or the simulator)."""
    pose = scan.get("pose")
    return dict(time_s=float(scan["time_s"]), scanner=int(scan["scanner"]),
                start_angle_rad=float(scan["start_angle_rad"]), step_rad=float(scan["step_rad"]),
                ranges_m=np.asarray(scan["ranges_m"], np.float32), source=str(scan.get("source") or "python scan"),
                pose=None if pose is None else tuple(float(v) for v in pose))


def _site_text(site: PathLike) -> str:
    """The YAML text of a site given as a file path or as the text itself (a text has a line break, or a colon
    followed by a space or a brace: a path like `dir/my:site.yaml` has neither, and must exist)."""
    s = str(site)
    if "\n" in s or (not isinstance(site, os.PathLike) and re.search(r":[ {]", s) and not Path(s).exists()):
        return s
    if not Path(s).is_file():
        raise FileNotFoundError(f"{s or repr(s)}: no such site file")
    return Path(s).read_text()


class Processor:
    """The roadside cycle processor of the C++ library. `site`: a site file path or its YAML text."""

    def __init__(self, site: PathLike):
        self._site_text = _site_text(site)
        self._p = _rs().Processor(self._site_text, str(site) if "\n" not in str(site) else "site")

    def add_detections(self, detections: Sequence[tuple]) -> None:
        """Camera boxes (t, x, y, w, h, class, score) in px, on the camera clock."""
        self._p.add_detections([(float(t), float(x), float(y), float(w), float(h), str(c), float(s))
                                for t, x, y, w, h, c, s in detections])

    def push(self, scan: dict) -> list[dict]:
        """Adds one scan; returns the cycles it completed (each exactly the CLI's output line, as a dict)."""
        return [json.loads(line) for line in self._p.push(_native_scan(scan))]

    def learn_world(self, scans: Iterable[dict]) -> None:
        """Learns the world background of the scans with a pose (a moving scanner, e.g. a CARMEN log): call
        before pushing them; `run` does when any scan has one."""
        self._p.learn_world([_native_scan(s) for s in scans if s.get("pose") is not None])

    def world_foreground(self, scan: dict) -> np.ndarray:
        """Per beam of a scan with a pose: foreground against the learned world background (bool array)."""
        return self._p.world_foreground(_native_scan(scan))

    def finish(self) -> list[dict]:
        return [json.loads(line) for line in self._p.finish()]

    def run(self, scans: Iterable[dict], detections: Optional[Sequence[tuple]] = None,
            time_offsets_s: Optional[Sequence[float]] = None) -> list[dict]:
        """All cycles of the scans, pushed in the order of their times on the site clock — each scan's time plus
        its scanner's `time_offset_s` from the site file, as the CLI orders them. `time_offsets_s` (one per site
        scanner) orders by other offsets instead, for scans whose clocks the site file does not yet describe."""
        if detections:
            self.add_detections(detections)
        scans = list(scans)
        if any(s.get("pose") is not None for s in scans):
            self.learn_world(scans)
        offsets = list(self._p.time_offsets_s if time_offsets_s is None else time_offsets_s)

        def site_time(scan):  # an unknown scanner index sorts as is: push() names it
            k = int(scan["scanner"])
            return float(scan["time_s"]) + (offsets[k] if 0 <= k < len(offsets) else 0.0)

        cycles = []
        for s in sorted(scans, key=site_time):
            cycles += self.push(s)
        cycles += self.finish()
        for warning in [self._p.detections_outside_warning()] + self._scanners_without_scans(scans):
            if warning and cycles:
                warnings.warn(warning, RuntimeWarning, stacklevel=2)
        return cycles

    def _scanners_without_scans(self, scans: list) -> list[str]:
        """A warning per site scanner no scan came from (as the CLI gives one)."""
        given = {int(s["scanner"]) for s in scans}
        return [f"site scanner '{name}' has no scans in the inputs" for k, name in enumerate(self._p.scanner_names)
                if k not in given]

    @property
    def detections_outside_scans(self) -> int:
        """How many of the camera detections given lie more than a second (the time a track keeps a detection)
        before the first scan or after the last, on the site clock: on another clock, most likely; in no output."""
        return self._p.detections_outside_scans


def label_points(xy: np.ndarray, cell_m: float = 0.1, dilation_cells: int = 2) -> tuple[np.ndarray, int]:
    """Component label (1…n) of each point after gridding and dilation (the C++ stage, for cross-checks)."""
    labels, n, _ = _rs().label_points(np.asarray(xy, np.float64), cell_m, dilation_cells)
    return labels, n


def fit_l_shape(xy: np.ndarray) -> tuple[float, float, float, float, float]:
    """(x, y, length, width, heading) of the rectangle fitted to an object's visible sides."""
    return _rs().fit_l_shape(np.asarray(xy, np.float64))


def assign(cost: Sequence[Sequence[float]], gate: float) -> list[tuple[int, int]]:
    """Minimum-cost (row, column) pairs with cost ≤ gate (dlib's Hungarian solver)."""
    rows = [[float(c) for c in row] for row in cost]
    if len({len(row) for row in rows}) > 1:
        raise ValueError(f"assign: the cost matrix must be rectangular, got rows of {sorted({len(r) for r in rows})} "
                         f"columns")
    return [tuple(p) for p in _rs().assign(rows, gate)]


def estimate_clock_offsets(scans: Sequence[dict], site: PathLike, reference: int = 0, max_offset_s: float = 0.5
                           ) -> list[float]:
    """Each scanner's clock offset to the `reference` scanner's, from moving objects both see.

    Every scanner is tracked alone (the site with only that scanner); a moving object seen at the same place by
    two scanners at times t_a and t_b means their clocks differ by t_b − t_a. For each pair of tracks that run
    side by side, the offset δ minimising Σ |p_b(t) − p_a(t + δ)|² is found on a grid of δ (1 ms steps) with the
    reference's positions interpolated; the median over object pairs is returned (0 where nothing moved)."""
    import yaml  # PyYAML: read the site to split it per scanner

    text = _site_text(site)
    doc = yaml.safe_load(text)
    if not isinstance(doc, dict) or not doc.get("scanners"):
        raise ValueError(f"{site}: a site needs a list of scanners")
    if not 0 <= reference < len(doc["scanners"]):
        raise ValueError(f"reference scanner {reference}: the site has scanners 0 to {len(doc['scanners']) - 1}")
    tracks = []
    for i in range(len(doc["scanners"])):
        single = dict(doc)
        single["scanners"] = [dict(doc["scanners"][i], time_offset_s=0.0)]
        single.pop("camera", None)
        # Only well-seen objects: one scanner's sparse far returns bias its track more than they help here.
        single["processing"] = dict(doc.get("processing") or {}, min_points=3, confirm_hits=3, max_coast_s=0.6)
        proc = Processor(yaml.safe_dump(single))
        cycles = proc.run([dict(s, scanner=0) for s in scans if s["scanner"] == i])
        tracks.append(_tracks_of(cycles))
    offsets = []
    for i in range(len(tracks)):
        if i == reference:
            offsets.append(0.0)
            continue
        found = [d for a in tracks[reference].values() for b in tracks[i].values()
                 if (d := _pair_offset(a, b, max_offset_s)) is not None]
        offsets.append(float(np.median(found)) if found else 0.0)
    return offsets


def _tracks_of(cycles: Sequence[dict], min_speed_mps: float = 1.0, settled_s: float = 1.0) -> dict:
    """Moving tracks past their start-up transient: id → (t, x, y) arrays."""
    rows: dict = {}
    for c in cycles:
        for o in c["objects"]:
            if o["source"] != "camera" and o["speed_mps"] > min_speed_mps and o["age_s"] >= settled_s:
                rows.setdefault(o["id"], []).append((c["t_s"], o["x_m"], o["y_m"]))
    return {k: np.array(v) for k, v in rows.items() if len(v) >= 20}


def _pair_offset(a: np.ndarray, b: np.ndarray, max_offset_s: float) -> Optional[float]:
    deltas = np.arange(-max_offset_s, max_offset_s + 1e-9, 0.001)
    best, best_cost = None, math.inf
    for d in deltas:
        t = b[:, 0] - d  # b's clock − δ = the reference's clock
        inside = (t >= a[0, 0]) & (t <= a[-1, 0])
        if inside.sum() < 10:
            continue
        xa, ya = np.interp(t[inside], a[:, 0], a[:, 1]), np.interp(t[inside], a[:, 0], a[:, 2])
        cost = np.mean((xa - b[inside, 1]) ** 2 + (ya - b[inside, 2]) ** 2)
        if cost < best_cost:
            best, best_cost = d, cost
    return best if best_cost < 1.0 else None  # not the same object when still > 1 m apart on average
