# SPDX-License-Identifier: BSD-3-Clause
"""roadpreview batch on Dask: speedup of 2 workers over 1, and a worker's memory over a long drive.

Speedup: ``--recordings`` recordings (default 20) of ``--frames`` frames each (default 20; KITTI seq 00 frames
0-2 of tests/data repeated under consecutive names, so every frame is a real 124k-point HDL-64E scan), run by
``rp.batch.run_batch`` on a LocalCluster of 1 and of 2 single-threaded worker processes (both started, and one
warm-up task per worker, outside the timing), ``--repeat`` pairs of runs, 1 worker then 2 workers in each pair;
the table gives the median wall time, the workers' CPU time, frames/s and the speedup: the median over the pairs
of wall 1 worker / wall 2 workers (a pair sees the same machine; its speed drifts). Target ≥ 1.8×.

Memory: one recording of ``--long-frames`` frames (default 10,000) on one worker, unsplit (``chunk_frames=0``,
as a pcap or bag is run), the worker's RSS sampled every 0.5 s; the table gives RSS at 10 %, 50 % and 100 % of
the run and the spread after the first 10 % (target: within 10 %), over the whole run and while the drive's
frames were processed (until its part is written; the summary step reads it back after), after a 3-frame warm-up
batch on the same worker (module imports are a one-off, not growth). Also the single-worker throughput, which
docs/scale.md turns into a cost per hour of driving.

Segments: the summary step's stitching of each recording's profiles along the drive and its 10 / 100 m segments,
with the C++ RouteBuilder batch uses against the numpy reference Route it used before, on the same Parquet parts
(``--recordings`` × ``--frames``, written in this process), median seconds per recording.

Usage: ``python bench/batch.py [--recordings N] [--frames N] [--repeat N] [--long-frames N] [--quick]
[--skip-speedup | --skip-memory | --skip-segments]``
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
FRAMES = sorted((REPO / "tests" / "data" / "semantickitti").glob("00000[0-2].bin"))
RUN = {"config": {"sensor_height": 1.73}, "motion": (8.6, None), "frame_rate": 10.0}


def make_recording(folder: Path, frames: int) -> str:
    folder.mkdir(parents=True)
    for k in range(frames):
        (folder / f"{k:06d}.bin").symlink_to(FRAMES[k % len(FRAMES)])
    return str(folder)


def worker_pids(client) -> list[int]:
    return list(client.run(os.getpid).values())


def cpu_seconds(pids) -> float:
    import psutil

    total = 0.0
    for pid in pids:
        t = psutil.Process(pid).cpu_times()
        total += t.user + t.system
    return total


def cluster(workers: int):
    from distributed import Client

    from roadpreview import batch

    c = batch.local_cluster(workers)  # the cluster `roadpreview batch` starts
    client = Client(c)
    client.run(lambda: __import__("roadpreview.batch"))  # imports outside the timing
    return c, client


def time_batch(client, inputs: list[str], out: Path) -> tuple[float, float]:
    """Wall and workers' CPU seconds of one batch on `client`'s cluster."""
    from roadpreview import batch

    pids = worker_pids(client)
    cpu0, t0 = cpu_seconds(pids), time.perf_counter()
    report = batch.run_batch(inputs, out, client=client, quiet=True, **RUN)
    wall = time.perf_counter() - t0
    assert not report["failed"], report
    return wall, cpu_seconds(pids) - cpu0


def speedup_table(args, tmp: Path) -> str:
    """Both clusters live side by side; each repeat runs the 1-worker batch, then the 2-worker one, so that a pair
    sees the same machine (its speed drifts by up to 40 % from minute to minute): the speedup is the median of the
    pairs' ratios (the ratio of the medians beside it)."""
    from roadpreview import batch

    inputs = [make_recording(tmp / "in" / f"r{k:02d}", args.frames) for k in range(args.recordings)]
    total = args.recordings * args.frames
    load0 = os.getloadavg()[0]
    clusters = {workers: cluster(workers) for workers in (1, 2)}
    walls: dict[int, list[float]] = {1: [], 2: []}
    cpus: dict[int, list[float]] = {1: [], 2: []}
    try:
        for workers, (_, client) in clusters.items():  # warm-up: a task on every worker
            batch.run_batch(inputs[:workers], tmp / f"warm{workers}", client=client, quiet=True, **RUN)
        for k in range(args.repeat):
            for workers, (_, client) in clusters.items():
                wall, cpu = time_batch(client, inputs, tmp / f"out{workers}-{k}")
                walls[workers].append(wall)
                cpus[workers].append(cpu)
                print(f"  {workers} worker(s), run {k + 1}: {wall:.1f} s", file=sys.stderr)
    finally:
        for c, client in clusters.values():
            client.close()
            c.close()
    rows = []
    for workers in (1, 2):
        median = statistics.median(walls[workers])
        rows.append(f"| {workers} | {args.recordings} × {args.frames} | {median:.1f} "
                    f"({min(walls[workers]):.1f}–{max(walls[workers]):.1f}) | {statistics.median(cpus[workers]):.1f} | "
                    f"{total / median:.1f} |")
    ratios = [a / b for a, b in zip(walls[1], walls[2])]
    speedup = statistics.median(ratios)
    head = ["| workers | recordings × frames | wall s, median (min–max) | workers' CPU s | frames/s |",
            "|---|---|---|---|---|"]
    return "\n".join(head + rows) + (
        f"\n\nSpeedup 2 workers vs 1: **{speedup:.2f}×** (target ≥ 1.8×: {'met' if speedup >= 1.8 else 'not met'}): the "
        f"median of {len(ratios)} pairs' ratios ({min(ratios):.2f}–{max(ratios):.2f}), the ratio of the medians "
        f"{statistics.median(walls[1]) / statistics.median(walls[2]):.2f}×; 1-min load {load0:.1f} before, "
        f"{os.getloadavg()[0]:.1f} after.\n")


def memory_table(args, tmp: Path) -> str:
    import psutil

    from roadpreview import batch

    drive = make_recording(tmp / "long" / "drive", args.long_frames)
    c, client = cluster(1)
    (pid,) = worker_pids(client)
    # warm-up: a 3-frame batch imports every module a task and a summary use, so the samples show growth only
    batch.run_batch([make_recording(tmp / "long" / "warm", 3)], tmp / "long-warm", client=client, quiet=True, **RUN)
    samples, done = [], threading.Event()
    every_s = 0.05 if args.quick else 0.5  # the quick drive takes about a second: sampled often enough to see it

    def sample():
        proc = psutil.Process(pid)
        while not done.is_set():
            samples.append((time.perf_counter(), proc.memory_info().rss / 2**20))
            if len(samples) % round(30 / every_s) == 0:  # every 30 s, to stderr: the trace of a long run
                print(f"  {samples[-1][0] - t0:.0f} s: worker RSS {samples[-1][1]:.0f} MB", file=sys.stderr, flush=True)
            done.wait(every_s)

    try:
        idle = psutil.Process(pid).memory_info().rss / 2**20
        thread = threading.Thread(target=sample)
        t0, epoch0 = time.perf_counter(), time.time()
        thread.start()
        report = batch.run_batch([drive], tmp / "long-out", client=client, quiet=True, chunk_frames=0, **RUN)
        wall = time.perf_counter() - t0
        done.set()
        thread.join()
        cpu = cpu_seconds([pid])
    finally:
        client.close()
        c.close()
    assert not report["failed"], report

    def at(fraction):
        t = t0 + fraction * wall
        return min(samples, key=lambda s: abs(s[0] - t))[1]

    steady = [r for t, r in samples if t >= t0 + 0.1 * wall]
    spread = 100.0 * (max(steady) - min(steady)) / min(steady)
    # The drive's frames end when its part is written (renamed into place); the summary step reads it back after.
    (part,) = (tmp / "long-out" / "frames").glob("recording=*/part-*.parquet")
    drive_end = t0 + part.stat().st_mtime - epoch0
    driving = [r for t, r in samples if t0 + 0.1 * wall <= t <= drive_end]
    if not driving:
        raise SystemExit(f"the drive's frames were processed in {drive_end - t0:.2f} s, between two memory samples "
                         f"(every {every_s} s): give more --long-frames")
    drive_spread = 100.0 * (max(driving) - min(driving)) / min(driving)
    head = ["| frames | wall s | frames/s (wall) | worker CPU s | frames/s per CPU s | RSS MB warmed up | at 10 % | "
            "at 50 % | at 100 % | spread after 10 % | met |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    row = (f"| {args.long_frames:,} | {wall:.0f} | {args.long_frames / wall:.1f} | {cpu:.0f} | "
           f"{args.long_frames / cpu:.1f} | {idle:.0f} | {at(0.1):.0f} | {at(0.5):.0f} | {at(1.0):.0f} | "
           f"{spread:.1f} % | {'yes' if spread <= 10 else 'no'} |")
    low = min((s for s in samples if s[0] >= t0 + 0.1 * wall), key=lambda s: s[1])
    high = max((s for s in samples if s[0] >= t0 + 0.1 * wall), key=lambda s: s[1])
    above = sum(r > 1.05 * statistics.median(steady) for r in steady)
    extremes = (f"Lowest sample after 10 %: {low[1]:.0f} MB at {low[0] - t0:.0f} s; highest {high[1]:.0f} MB at "
                f"{high[0] - t0:.0f} s; {above} of {len(steady)} samples (every {every_s} s) more than 5 % above their "
                f"median {statistics.median(steady):.0f} MB.")
    phases = (f"The drive's frames were processed until {drive_end - t0:.0f} s ({len(driving)} samples after 10 %): "
              f"spread {drive_spread:.1f} % ({min(driving):.0f}–{max(driving):.0f} MB); the summary step after it "
              f"({wall - (drive_end - t0):.0f} s) is in the whole-run spread above.")
    return ("\n".join(head + [row]) + f"\n\n{extremes}\n\n{phases}\n\n1-min load at the end "
            f"{os.getloadavg()[0]:.1f}.\n")


def reference_route(out_dir: Path, rid: str):
    """The stitching batch did before it used the C++ RouteBuilder: the numpy reference over the stored lines."""
    import json

    from roadpreview import batch
    from roadpreview.config import Config
    from roadpreview.reference.route import Route

    route = Route(Config.from_dict(RUN["config"]))
    for row in batch.frame_rows(out_dir, rid, ("line", "pose_x_m", "pose_y_m", "pose_yaw_rad")):
        route.add(json.loads(row["line"]), None if row["pose_x_m"] is None else
                  (row["pose_x_m"], row["pose_y_m"], row["pose_yaw_rad"]))
    return route


def segments_table(args, tmp: Path) -> str:
    from roadpreview import batch

    out = tmp / "segments"
    rids = []
    for k in range(args.recordings):
        rid = f"r{k:02d}"
        recording = make_recording(tmp / "segments-in" / rid, args.frames)
        batch.process_chunk(rid, [recording], batch.Chunk(0, 0, None, 0), dict(RUN), str(out))
        rids.append(rid)
    load0 = os.getloadavg()[0]
    times = {"reference": [], "C++": []}
    for rid in rids:
        t0 = time.perf_counter()
        ref_rows = batch.segment_rows(rid, reference_route(out, rid), batch.SEGMENT_LENGTHS_M)
        t1 = time.perf_counter()
        route, _ = batch.stitch(out, rid, RUN["config"])
        rows = batch.segment_rows(rid, route, batch.SEGMENT_LENGTHS_M)
        t2 = time.perf_counter()
        classes = [r["class_vehicle"] for r in rows]
        assert len(rows) == len(ref_rows) and classes == [r["class_vehicle"] for r in ref_rows], rid
        times["reference"].append(t1 - t0)
        times["C++"].append(t2 - t1)
    ref, cpp = statistics.median(times["reference"]), statistics.median(times["C++"])
    head = ["| stitching | recordings × frames | s per recording, median (min–max) |", "|---|---|---|"]
    size = f"{args.recordings} × {args.frames}"
    named = (("numpy reference Route", times["reference"]), ("C++ RouteBuilder", times["C++"]))
    rows = [f"| {name} | {size} | {statistics.median(t):.3f} ({min(t):.3f}–{max(t):.3f}) |" for name, t in named]
    return "\n".join(head + rows) + (f"\n\nTime per recording, reference / C++ RouteBuilder: **{ref / cpp:.1f}×** "
                                     f"(the same segment classes); 1-min load {load0:.1f} before, "
                                     f"{os.getloadavg()[0]:.1f} after.\n")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--recordings", type=int, default=20)
    p.add_argument("--frames", type=int, default=20)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--long-frames", type=int, default=10_000)
    p.add_argument("--quick", action="store_true", help="4 recordings × 3 frames, 1 run, a 60-frame drive")
    p.add_argument("--skip-memory", action="store_true")
    p.add_argument("--skip-speedup", action="store_true")
    p.add_argument("--skip-segments", action="store_true")
    args = p.parse_args()
    if args.quick:
        args.recordings, args.frames, args.repeat, args.long_frames = 4, 3, 1, 60
    tmp = Path(tempfile.mkdtemp(prefix="rp-bench-batch-"))
    try:
        if not args.skip_speedup:
            print(f"## Speedup ({os.cpu_count()} cores)\n")
            print(speedup_table(args, tmp))
        if not args.skip_segments:
            print("## Segments step: stitching a recording\n")
            print(segments_table(args, tmp))
        if not args.skip_memory:
            print("## Worker memory over a long drive\n")
            print(memory_table(args, tmp))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
