# SPDX-License-Identifier: BSD-3-Clause
"""Latency of the live path: the bundled OS1-128 recording replayed over loopback into ``roadpreview run
udp://...`` with the default pipeline (``rp.Config`` defaults but the sensor height: zone ground, obstacles on).

For each replay rate it starts the live run, replays the capture ``--loops`` times (3 frames a loop; the frame ids
jump back at each loop, as after a sensor restart) and reads the run's summary line: the latency of every frame
from the kernel's receive time of the datagram that completed it to its output line written (p50, p99, max), the
pipeline's time per frame (``timing_ms.total`` of the output lines: median and p99, so that a latency tail can be
told from the pipeline's own), the medians of the parts outside it (the frame complete after its last datagram's
arrival: the queue, that datagram's decode, the frame's build; the output line written after the result),
datagrams received and dropped by the full receive queue, frames affected by lost packets. Beside it the 1-min
load average before and after (the machine is shared).
Each rate runs twice: frames of the whole rotation, and with ``--roi-columns`` frames of the columns that can see
the region of interest, which end at the region's last column; "after the rotation's end" moves the latter's
latency to the rotation's last packet (negative: the result came before it). Each of those runs with the reader
waiting for datagrams both ways: sleeping until woken (the default) and ``--busy-wait`` (a core kept busy).
Prints a Markdown table on stdout, progress on stderr. The issue's target: p99 ≤ 5 ms at 1×.

Usage: ``python bench/live.py [--loops N] [--rates 1,10] [--threads 1,2] [--waits sleep,busy] [--quick]``
"""

from __future__ import annotations

import argparse
import json
import os
import re
import socket
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
PCAP = REPO / "tests/data/ouster/OS-1-128_v2.3.0_1024x10_lb_n3.pcap"
META = REPO / "tests/data/ouster/OS-1-128_v2.3.0_1024x10.json"
HEIGHT_M, SPEED_MPS = "1.97", "2.5"
TARGET_P99_MS = 5.0
ROTATION_MS = 100.0  # the recording's 1024x10 mode


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def cli() -> str:
    beside = Path(sys.executable).parent / "roadpreview"
    return str(beside) if beside.exists() else "roadpreview"


def free_port_pair() -> int:
    """A loopback port that is free, and its successor too (Ouster lidar and IMU)."""
    for _ in range(50):
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as a, \
                socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as b:
            a.bind(("127.0.0.1", 0))
            port = a.getsockname()[1]
            try:
                b.bind(("127.0.0.1", port + 1))
            except OSError:
                continue
            return port
    raise RuntimeError("no free pair of loopback ports")


def pipeline_times(output: Path) -> list[float]:
    with output.open() as lines:
        return [json.loads(line)["timing_ms"]["total"] for line in lines]


def measure(rate: str, loops: int, roi_columns: bool, threads: int, busy: bool) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        output = Path(tmp) / "live.jsonl"
        out = run_live(rate, loops, roi_columns, threads, busy, output)
        times = pipeline_times(output)
    # Nearest rank (the ⌈q·n⌉-th smallest), the rule of the CLI's latency percentiles.
    out["pipeline_p99_ms"] = float(np.percentile(times, 99, method="inverted_cdf"))
    return out


def run_live(rate: str, loops: int, roi_columns: bool, threads: int, busy: bool, output: Path) -> dict:
    port = free_port_pair()
    load_before = os.getloadavg()[0]
    run = subprocess.Popen([cli(), "run", f"udp://127.0.0.1:{port}", "--meta", str(META), "--speed", SPEED_MPS,
                            "--sensor-height", HEIGHT_M, "--timeout", "3", "--threads", str(threads), "-o", str(output),
                            *(["--roi-columns"] if roi_columns else []), *(["--busy-wait"] if busy else [])],
                           stderr=subprocess.PIPE, text=True)
    try:
        first = run.stderr.readline()
        if "listening on" not in first:
            raise RuntimeError(first + run.stderr.read())
        sender = subprocess.run([cli(), "replay", str(PCAP), "--to", f"127.0.0.1:{port}", "--rate", rate,
                                 "--loop", str(loops)], capture_output=True, text=True, timeout=3600)
        if sender.returncode:
            raise RuntimeError(sender.stderr)
        _, err = run.communicate(timeout=600)
    finally:
        run.kill()
    if run.returncode:
        raise RuntimeError(err)
    summary = re.search(r"(\d+) frame\(s\), pipeline median ([\d.]+) ms", err)
    live = re.search(r"live: (\d+) datagrams received, (\d+) dropped by a full queue; (\d+) of (\d+) frames affected"
                     r".*p50 ([\d.]+) ms, p99 ([\d.]+) ms, max ([\d.]+) ms", err)
    if not summary or not live:
        raise RuntimeError("no summary in the run's stderr:\n" + err[-2000:])
    # With --roi-columns a frame ends at the region's last column: the rotation's later columns still take time.
    outside = re.search(r"frame complete ([\d.]+) ms after its last packet, output line ([\d.]+) ms", err)
    window = re.search(r"columns \d+–(\d+) decoded, \d+ of the (\d+)", err)
    before_end_ms = (int(window[2]) - 1 - int(window[1])) / int(window[2]) * ROTATION_MS if window else 0.0
    return {"rate": rate, "roi_columns": roi_columns, "threads": threads, "busy": busy, "frames": int(summary[1]),
            "expected": 3 * loops,
            "pipeline_ms": float(summary[2]), "received": int(live[1]), "dropped": int(live[2]),
            "affected": int(live[3]), "p50": float(live[5]), "p99": float(live[6]), "max": float(live[7]),
            "completing": float(outside[1]) if outside else float("nan"),
            "output": float(outside[2]) if outside else float("nan"),
            "before_end_ms": before_end_ms, "load": (load_before, os.getloadavg()[0])}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--loops", type=int, default=100, help="times through the 3-frame capture (default 100)")
    parser.add_argument("--rates", default="1,10", help="replay rates, comma-separated ('max' allowed)")
    parser.add_argument("--threads", default="1", help="threads a frame may use (the run's --threads), comma-separated")
    parser.add_argument("--waits", default="sleep,busy",
                        help="how the reader waits for datagrams: sleep (the default) and/or busy (--busy-wait)")
    parser.add_argument("--quick", action="store_true", help="5 loops at 1x (smoke test)")
    args = parser.parse_args()
    waits = args.waits.split(",")
    if not set(waits) <= {"sleep", "busy"}:
        parser.error(f"--waits {args.waits}: expected sleep, busy or both")
    loops, rates = (5, ["1"]) if args.quick else (args.loops, args.rates.split(","))
    rows = []
    for rate in rates:
        for threads in (int(t) for t in args.threads.split(",")):
            for busy in (w == "busy" for w in waits):
                for roi_columns in (False, True):
                    log(f"replaying {PCAP.name} {loops} times at {rate}x, {threads} thread(s)"
                        f"{', --roi-columns' if roi_columns else ''}{', --busy-wait' if busy else ''}")
                    rows.append(measure(rate, loops, roi_columns, threads, busy))
    print(f"Live latency, {PCAP.name} ({META.name}), default pipeline, sensor height {HEIGHT_M} m, "
          f"{os.cpu_count()} cores\n")
    print("| rate | threads | reader waits | frame | frames (of) | latency p50 ms | p99 ms | max ms "
          "| p50 after the rotation's end ms | pipeline median ms | pipeline p99 ms | frame complete after ms "
          "| output line ms | datagrams | dropped by the queue | frames affected | 1-min load before / after | p99 ≤ 5 ms |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        met = "yes" if r["p99"] <= TARGET_P99_MS else "no"
        frame = "region's columns" if r["roi_columns"] else "whole rotation"
        wait = "busy" if r["busy"] else "sleeping"
        print(f"| {r['rate']}× | {r['threads']} | {wait} | {frame} | {r['frames']} ({r['expected']}) "
              f"| {r['p50']:.2f} | {r['p99']:.2f} "
              f"| {r['max']:.2f} | {r['p50'] - r['before_end_ms']:.2f} | {r['pipeline_ms']:.2f} "
              f"| {r['pipeline_p99_ms']:.2f} | {r['completing']:.2f} | {r['output']:.2f} | {r['received']} "
              f"| {r['dropped']} | {r['affected']} | {r['load'][0]:.1f} / {r['load'][1]:.1f} "
              f"| {met if r['rate'] == '1' else '–'} |")


if __name__ == "__main__":
    main()
