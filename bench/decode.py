"""Decode throughput of the pcap readers, next to each sensor's real-time rate.

For every bundled Ouster and Velodyne recording (``tests/data/ouster``, ``tests/data/velodyne``) it times
``rp.io.open(path)`` (metadata, XYZ lookup table; "open") and then the iteration over all frames (pcap
records → libtins → packet decoder → points; "decode"), ``--repeat`` times after one warm-up, single-threaded,
and prints a Markdown table on stdout (progress on stderr):

* decode ms per frame, median (min–max) over the runs (the iteration time divided by the frames);
* frames/s and MB/s (pcap bytes) of the median run;
* the sensor's rate: Ouster from the metadata's lidar_mode, Velodyne from the recording (how fast the
  azimuth of the points turns with their firing times);
* real time ×: how many times faster than the sensor produces frames (sensor period / decode ms per frame).

Frames of recordings that start or end mid-sweep are counted like whole ones. The target from the issue:
decoding an OS1-128 frame takes well under 5 ms.

Usage: ``python bench/decode.py [--repeat N] [--quick]``
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import roadpreview as rp

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "tests" / "data"
# (pcap, metadata when it is not found by name)
RECORDINGS = [(p, None) for p in sorted((DATA / "ouster").glob("*.pcap")) if "fw20" not in p.name] + [
    (DATA / "ouster" / "OS-1-64_1024x10_fw20.pcap", DATA / "ouster" / "OS-1-64_sensor_config_reduced.json"),
    (DATA / "ouster" / "rust-lidar-utils" / "ouster_example.pcap", None),
] + [(p, None) for p in sorted((DATA / "velodyne").glob("*.pcap"))]
TARGET_MS = 5.0


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def velodyne_rate_hz(frames) -> float:
    """Turns per second from the points of the longest sweep: unwrapped azimuth against firing time."""
    f = max(frames, key=lambda fr: len(fr.points))
    order = np.argsort(f.point_times, kind="stable")
    az = np.unwrap(np.arctan2(-f.points[order, 1], f.points[order, 0]).astype(np.float64))
    t = f.point_times[order].astype(np.float64)
    slope = np.polyfit(t, az, 1)[0]  # rad/s, clockwise positive in the manual's convention
    return abs(slope) / (2 * np.pi)


def measure(path: Path, meta, repeat: int):
    opened = rp.io.open(path, meta=meta)
    frames = list(opened)  # warm-up, and the frames for the table
    info = opened.info
    open_ms, decode_ms = [], []
    for _ in range(repeat):
        t0 = time.perf_counter()
        src = rp.io.open(path, meta=meta)
        t1 = time.perf_counter()
        n = sum(1 for _ in src)
        t2 = time.perf_counter()
        open_ms.append(1e3 * (t1 - t0))
        decode_ms.append(1e3 * (t2 - t1) / n)
    rate = info["frame_rate_hz"] or velodyne_rate_hz(frames)
    return info, frames, open_ms, decode_ms, rate


def fmt(values) -> str:
    return f"{statistics.median(values):.2f} ({min(values):.2f}–{max(values):.2f})"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=20, help="timed runs per recording (default 20)")
    ap.add_argument("--quick", action="store_true", help="3 runs per recording (smoke test)")
    args = ap.parse_args()
    repeat = 3 if args.quick else args.repeat

    load = os.getloadavg()[0]
    print(f"# Decode throughput ({platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"1-min load {load:.2f}{' — busy machine, expect noise' if load > 0.5 else ''}; "
          f"{repeat} runs per recording, single-threaded)\n")
    print("| recording | sensor | profile | frames | points/frame | MB | open ms | decode ms/frame | frames/s "
          "| MB/s | sensor Hz | real time × |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    worst_os1 = 0.0
    for path, meta in RECORDINGS:
        log(f"decoding {path.name} ×{repeat}")
        info, frames, open_ms, decode_ms, rate = measure(path, meta, repeat)
        mb = path.stat().st_size / 1e6
        per_frame = statistics.median(decode_ms)
        points = int(np.median([len(f.points) for f in frames]))
        fps = 1e3 / per_frame
        print(f"| {path.name} | {info['sensor_model']} | {info['profile']} | {len(frames)} | {points} | {mb:.2f} "
              f"| {fmt(open_ms)} | {fmt(decode_ms)} | {fps:.0f} | {mb * fps / len(frames):.0f} | {rate:.1f} "
              f"| {1e3 / rate / per_frame:.0f} |")
        if info["sensor_model"] == "OS-1-128":
            worst_os1 = max(worst_os1, per_frame)
    verdict = "met" if worst_os1 < TARGET_MS else "NOT met"
    print(f"\nTarget: an OS1-128 frame decodes in well under {TARGET_MS:.0f} ms — {verdict} "
          f"(slowest OS1-128 recording: {worst_os1:.2f} ms per frame, median).")


if __name__ == "__main__":
    main()
