"""Temporal fusion benchmark: single frame vs the fused map (EMA, Kalman) on simulated sequences and on the
real OS1-128 recording with its poses, and what the fusion costs per frame.

Simulated suite (roadpreview.sim, every draw seeded; the accuracy benchmark's definitions, bench/accuracy.py):
  * ISO 8608 classes A–F × straight and curved (R = 50 m at 10 m/s) paths, OS1-128 1.8 m high, at 5 and 10 m/s;
  * speed bumps 2–10 cm (1 m long) on a class A road, OS1-128, at 5 and 10 m/s.
Each sequence is 10 frames at 10 Hz with exact speed, yaw rate and timestamps; scores are read on the
10th frame (the map then holds 10 frames):
  * coverage: fraction of the 0.1 m bins of both wheels backed by data (count > 0), first 30 m / 30–40 m;
  * profile RMSE (cm): detrended error against the truth over the backed bins (as accuracy.py);
  * bump height error (cm): crest minus the road around it, against the truth (as accuracy.py);
  * class: the vehicle's ISO 8608 class on the 10th frame, exact and within one class.
Long drive: coverage of the first 30 m by distance band after 10, 20 and 40 frames (class C, straight, Kalman).
Real recording: tests/data/ouster OS1-128, 3 frames, KITTI poses: coverage single vs fused per frame.
Timing: C++ total ms per frame and the fusion part (moving the map and fusing the frame) on the simulated
131,072-ray OS1-128 frames (median over all frames of --timing-repeat passes).

Usage: ``python bench/fusion.py [--quick] [--jobs N] [--plot PNG]`` (Markdown on stdout, progress on stderr).
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import roadpreview as rp
from roadpreview import sim

sys.path.insert(0, str(Path(__file__).resolve().parent))
from accuracy import BUMP_HEIGHTS_M, BUMP_X_M, CURVE_YAW_RATE_RPS, Scenario, bump_height, class_index, \
    detrended_rms, levelling_band_m, md_table, run_in_pool  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
OUSTER = REPO / "tests" / "data" / "ouster"
OS1_PCAP = OUSTER / "OS-1-128_v2.3.0_1024x10_lb_n3.pcap"
OS1_POSES = OUSTER / "OS-1-128_v2.3.0_1024x10_lb_n3_poses_kitti.txt"
OS1_HEIGHT_M = 1.97  # estimated from the ground in the first frame (tests/python/paths.py)
SENSOR_HEIGHT_M = 1.8
FRAMES = 10
METHODS = ("none", "ema", "kalman")
ALPHA = 0.3
SPEEDS_MPS = (5.0, 10.0)
NEAR_M, FAR_M = 30.0, 40.0
LONG_FRAMES = 40  # the long drive: coverage approaches its steady state


@dataclass(frozen=True)
class Sequence:
    """One of accuracy.py's scenarios (OS1-128), driven at `speed`."""

    scenario: Scenario
    speed: float

    @property
    def name(self) -> str:
        return self.scenario.name


def suite(quick: bool) -> list[Sequence]:
    if quick:
        return [Sequence(Scenario("classes", "class C, straight", "OS1-128", "C", seed=3, frames=4), 10.0),
                Sequence(Scenario("bumps", "bump 6 cm", "OS1-128", bump_height=0.06), 10.0)]
    out = []
    for speed in SPEEDS_MPS:
        for k, c in enumerate("ABCDEF"):
            for path, yaw_rate in (("straight", 0.0), ("curved", CURVE_YAW_RATE_RPS * speed / 10.0)):
                out.append(Sequence(Scenario("classes", f"class {c}, {path}", "OS1-128", c, 10 * k + 1, yaw_rate), speed))
        for h in BUMP_HEIGHTS_M:
            out.append(Sequence(Scenario("bumps", f"bump {h * 100:.0f} cm", "OS1-128", seed=50, bump_height=h), speed))
    return out


def coverage(res, lo: float, hi: float) -> float:
    parts = [np.asarray(getattr(res, w).count)[(np.asarray(getattr(res, w).s) >= lo) & (np.asarray(getattr(res, w).s) < hi)]
             for w in ("left", "right")]
    return float(np.mean(np.concatenate(parts) > 0))


def score(res, truth: dict, scenario: Scenario, pose, band_m) -> dict:
    out = {"near": coverage(res, 0.0, NEAR_M), "far": coverage(res, NEAR_M, FAR_M), "rms": [], "bump": [],
           "class": res.vehicle.iso_class, "ms": res.timing_ms["total"],
           "fusion_ms": res.fusion["time_ms"] if res.fusion else 0.0}
    for wheel in ("left", "right"):
        p = getattr(res, wheel)
        s, z, count = np.asarray(p.s), np.asarray(p.z), np.asarray(p.count)
        backed = (count > 0) & np.isfinite(z) & (s >= 0)
        out["rms"].append(detrended_rms(s[backed], (z - truth[wheel][: len(z)])[backed], band_m))
        if scenario.bump_height:
            out["bump"].append(bump_height(s, z, BUMP_X_M - pose.x_m) - scenario.bump_height)
    return out


def run(seq: Sequence) -> dict:
    lidar = sim.os1_128(height_m=SENSOR_HEIGHT_M)
    sc, speed = seq.scenario, seq.speed
    scene = sc.scene()
    frames = sim.drive(scene, lidar, speed, sc.yaw_rate, sc.frames, seed=sc.seed)
    truth = sim.truth_profiles(scene, frames[-1].pose, speed, sc.yaw_rate)
    out = {"sequence": seq}
    for method in METHODS:
        est = rp.Estimator(rp.Config(extrinsics=lidar.extrinsics(), fusion={"method": method, "alpha": ALPHA}))
        for f in frames:
            res = est.process(f.points, speed, sc.yaw_rate, timestamp=f.time_s)
        out[method] = score(res, truth, sc, frames[-1].pose, levelling_band_m(est.config))
    return out


def pct(values) -> str:
    return f"{100 * np.mean(values):.1f}" if len(values) else "–"


def accuracy_rows(results: list[dict]) -> list[list[str]]:
    rows = []
    for speed in sorted({r["sequence"].speed for r in results}):
        for group in ("classes", "bumps"):
            chosen = [r for r in results if r["sequence"].speed == speed and r["sequence"].scenario.group == group]
            if not chosen:
                continue
            for method in METHODS:
                m = [r[method] for r in chosen]
                rms = [v for x in m for v in x["rms"] if np.isfinite(v)]
                bumps = [v for x in m for v in x["bump"] if np.isfinite(v)]
                classified = [(x["class"], r["sequence"].scenario.iso_class) for x, r in zip(m, chosen) if x["class"]]
                exact = sum(c == t for c, t in classified)
                within = sum(abs(class_index(c) - class_index(t)) <= 1 for c, t in classified)
                cls = f"{exact}/{len(chosen)} · {within}/{len(chosen)}" if group == "classes" else "–"
                rows.append([f"{group} ({len(chosen)})", f"{speed:g}", method, pct([x["near"] for x in m]),
                             pct([x["far"] for x in m]), f"{np.median(rms) * 100:.2f}" if rms else "–",
                             f"{np.sqrt(np.mean(np.square(bumps))) * 100:.2f} (n = {len(bumps)})" if bumps else "–",
                             f"{max(abs(b) for b in bumps) * 100:.2f}" if bumps else "–", cls])
    return rows


def long_drive(quick: bool) -> list[list[str]]:
    """Coverage of the first 30 m by distance band as a longer drive goes on (class C, straight, Kalman)."""
    lidar = sim.os1_128(height_m=SENSOR_HEIGHT_M)
    scene = Scenario("classes", "class C", "OS1-128", "C", seed=3).scene()
    frames, marks = (4, (2, 4)) if quick else (LONG_FRAMES, (10, 20, LONG_FRAMES))
    rows = []
    for speed in (SPEEDS_MPS[:1] if quick else SPEEDS_MPS):
        est = rp.Estimator(rp.Config(extrinsics=lidar.extrinsics(), fusion={"method": "kalman"}))
        for k, f in enumerate(sim.drive(scene, lidar, speed, 0.0, frames, seed=3), start=1):
            res = est.process(f.points, speed, 0.0, timestamp=f.time_s)
            if k in marks:
                rows.append([f"{speed:g}", str(k)] + [f"{100 * coverage(res, lo, hi):.0f}"
                                                      for lo, hi in ((0, 10), (10, 20), (20, 30), (0, NEAR_M))])
    return rows


def real_recording(plot: str | None) -> list[list[str]]:
    """Coverage per frame of the OS1-128 recording, single vs fused with its KITTI poses."""
    poses = [np.array(line.split(), float).reshape(3, 4) for line in OS1_POSES.read_text().splitlines() if line.strip()]
    frames = list(rp.io.open(OS1_PCAP))
    results = {}
    for method in METHODS:
        est = rp.Estimator(rp.Config(sensor_height=OS1_HEIGHT_M, fusion={"method": method, "alpha": ALPHA}))
        results[method] = [est.process(f.points, 2.5, 0.0, timestamp=f.timestamp,
                                       pose=(m[0, 3], m[1, 3], math.atan2(m[1, 0], m[0, 0])))
                           for f, m in zip(frames, poses)]
    rows = []
    for i in range(len(frames)):
        rows.append([str(i)] + [f"{100 * coverage(results[m][i], 0, NEAR_M):.1f} / {100 * coverage(results[m][i], 0, FAR_M):.1f}"
                                for m in METHODS])
    if plot:
        draw(results, plot)
    return rows


def draw(results: dict, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    fig, axes = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    for ax, wheel in zip(axes, ("left", "right")):
        for method, style in (("none", dict(color="0.5", lw=1.5)), ("kalman", dict(color="tab:blue", lw=1))):
            p = getattr(results[method][-1], wheel)
            backed = np.asarray(p.count) > 0
            ax.plot(p.s, np.where(backed, p.z, np.nan), ".", ms=3, label=f"{method}: backed bins", **style)
        ax.set_ylabel(f"{wheel} wheel z (m)")
        ax.legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("s ahead (m)")
    cov = [f"{m} {100 * coverage(results[m][-1], 0, FAR_M):.0f} %" for m in ("none", "kalman")]
    fig.suptitle(f"OS1-128 recording, frame 2 with KITTI poses: bins backed by data ({', '.join(cov)})")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def timing(results_frames: int, repeat: int) -> list[list[str]]:
    lidar = sim.os1_128(height_m=SENSOR_HEIGHT_M)
    scene = Scenario("classes", "class C", "OS1-128", "C", seed=3).scene()
    frames = sim.drive(scene, lidar, 10.0, 0.0, results_frames, seed=3)
    rows, base = [], None
    for method in METHODS:
        total, fusion = [], []
        for _ in range(repeat):
            est = rp.Estimator(rp.Config(extrinsics=lidar.extrinsics(), fusion={"method": method}))
            for f in frames:
                res = est.process(f.points, 10.0, 0.0, timestamp=f.time_s)
                total.append(res.timing_ms["total"])
                fusion.append(res.fusion["time_ms"] if res.fusion else 0.0)
        median = float(np.median(total))
        base = base or median
        rows.append([method, str(len(frames[0].points)), f"{median:.2f}", f"{np.min(total):.2f}–{np.max(total):.2f}",
                     f"{np.median(fusion):.2f}", f"{median / base:.2f}", "yes" if median <= 3.0 else "no"])
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="two short sequences (smoke test)")
    parser.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1), help="worker processes")
    parser.add_argument("--timing-repeat", type=int, default=3, help="passes over the timing sequence")
    parser.add_argument("--plot", help="write the OS1-128 recording's profiles, single vs fused, to this PNG")
    args = parser.parse_args(argv)
    if args.jobs < 1 or args.timing_repeat < 1:
        parser.error("--jobs and --timing-repeat must be at least 1")
    sequences = suite(args.quick)
    start = time.perf_counter()
    results = run_in_pool(run, sequences, args.jobs, lambda r: f"{r['sequence'].speed:g} m/s {r['sequence'].name}")
    load = os.getloadavg()[0]
    print("# roadpreview temporal fusion benchmark\n")
    print(f"- {len(sequences)} simulated sequences of {sequences[0].scenario.frames} frames at 10 Hz, OS1-128 "
          f"{SENSOR_HEIGHT_M} m high, EMA α = {ALPHA}; {time.perf_counter() - start:.0f} s on {args.jobs} worker(s); "
          f"1-min load {load:.1f}{' (busy machine: timings are noisy)' if load > 0.5 else ''}; Python "
          f"{platform.python_version()}, numpy {np.__version__}, roadpreview {rp.__version__}\n")
    print(f"## Simulated sequences, scored on their last frame ({FRAMES} frames; --quick: 4 for the classes)\n")
    print(md_table(["sequences", "speed m/s", "fusion", f"coverage 0–{NEAR_M:g} m %", f"coverage {NEAR_M:g}–{FAR_M:g} m %",
                    "median profile RMSE cm", "bump height RMSE cm", "bump max abs error cm",
                    "class exact · within one"], accuracy_rows(results)) + "\n")
    print("## Coverage % of the first 30 m as a longer drive goes on (class C, straight, Kalman)\n")
    print(md_table(["speed m/s", "frames", "0–10 m", "10–20 m", "20–30 m", "0–30 m"], long_drive(args.quick)) + "\n")
    print("## Real OS1-128 recording with its KITTI poses (coverage % 0–30 m / 0–40 m)\n")
    print(md_table(["frame", *METHODS], real_recording(args.plot)) + "\n")
    print("## Time per frame, 131,072-ray OS1-128 frames (C++, ms)\n")
    print(md_table(["fusion", "points", "total median", "total min–max", "fusion part median", "ratio to none",
                    "≤ 3 ms"], timing(4 if args.quick else FRAMES, 1 if args.quick else args.timing_repeat)) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
