"""Benchmark of the obstacle stage on the real KITTI frames: the RANSAC ground-segmentation paper's metrics and
the clustering time, for both ground methods.

What it prints, as Markdown tables on stdout (progress on stderr):

1. The paper's metrics (Lee & Yi, "LiDAR based real-time ground segmentation algorithm for autonomous
   driving", Tables 3–4) next to ours, per frame and ground method:
   * points before and after ground removal, in the front region (the pipeline's ROI, x ∈ [1, 40] m,
     |y| ≤ 10 m) and in the whole frame;
   * clusters found on the ground in the front region before and after ground removal. Before: the
     pipeline's clustering (same voxels, tolerance and size limits) of every ROI point; after: the pipeline's
     own clusters of the non-ground ROI points. A cluster is "on the ground" — ground that would be taken for
     an object — when most of its labelled points carry a SemanticKITTI ground class (road, parking,
     sidewalk, other-ground, lane-marking, terrain); unlabelled points do not vote.
2. Time per frame, median (min–max) over ``--repeat`` runs after warm-up, single-threaded:
   * "clustering": the C++ stage function ``cluster_labels`` on the frame's non-ground front-region points
     (voxels, PCL Euclidean clustering of their centroids, ids), timed around the call;
   * "obstacle stage": ``Result.timing_ms["obstacles"]`` — clustering, boxes, local ground heights and the
     wheel-path crossings, measured inside C++ — and the pipeline total beside it.
3. Clustering variants on the same points (``pca`` ground): every point (``voxel_m`` = 0, PCL's Euclidean
   clustering as it is) against voxel centroids, time and number of clusters.

Usage: ``python bench/obstacles.py [--repeat N] [--quick]``
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import sys
import time

from bench import BUSY_LOAD, KITTI_SENSOR_HEIGHT_M, ROI_X_M, ROI_Y_ABS_M, cpu_model, kitti_frames, md_table, spread

import numpy as np  # noqa: E402  (bench sets the BLAS thread count before numpy is imported)

import roadpreview as rp  # noqa: E402
import roadpreview.native  # noqa: E402, F401  (the C++ stage functions)

SPEED_MPS = 5.0
YAW_RATE_RPS = 0.1
METHODS = ("pca", "ransac")
WARMUP = 3
TARGET_CLUSTERING_MS = 2.0
VOXEL_VARIANTS = (0.0, 0.25, 0.35)

# Lee & Yi: mean over 7,840 steps (200 s) of four VLP-16 and an Ibeo LUX, Tables 3 and 4.
PAPER_POINTS = (7288.01, 4326.54)
PAPER_GROUND_CLUSTERS = (4.7314, 1.7097)


def front_region(points: np.ndarray) -> np.ndarray:
    """The ROI in x, y (the base frame differs from the sensor frame only by the height)."""
    x, y = points[:, 0], points[:, 1]
    return (x >= ROI_X_M[0]) & (x <= ROI_X_M[1]) & (np.abs(y) <= ROI_Y_ABS_M)


def base_frame(points: np.ndarray) -> np.ndarray:
    base = np.ascontiguousarray(points[:, :3])
    base[:, 2] += np.float32(KITTI_SENSOR_HEIGHT_M)
    return base


def clusters_on_ground(labels: np.ndarray, truth: np.ndarray, scored: np.ndarray) -> tuple[int, int]:
    """(clusters whose labelled points are mostly ground, all clusters) for per-point cluster labels (−1: none)."""
    clustered = labels >= 0
    count = int(labels.max()) + 1 if clustered.any() else 0
    ground_votes = np.bincount(labels[clustered & scored & truth], minlength=count)
    votes = np.bincount(labels[clustered & scored], minlength=count)
    return int(np.count_nonzero(2 * ground_votes > votes)), count


def timed(call, repeat: int) -> list[float]:
    for _ in range(WARMUP):
        call()
    runs = []
    for _ in range(repeat):
        start = time.perf_counter()
        call()
        runs.append((time.perf_counter() - start) * 1e3)
    return runs


def measure(frame, method: str, repeat: int) -> dict:
    """The paper's metrics and the timings of one frame with one ground method."""
    cfg = rp.Config(sensor_height=frame.sensor_height, ground={"method": method})
    est = rp.Estimator(cfg)
    for _ in range(WARMUP):
        est.process(frame.points, SPEED_MPS, YAW_RATE_RPS)
    results = [est.process(frame.points, SPEED_MPS, YAW_RATE_RPS) for _ in range(repeat)]
    res = results[-1]
    base = base_frame(frame.points)
    front = front_region(frame.points) & np.isfinite(base).all(axis=1)
    non_ground = front & ~res.ground_mask
    before = np.full(len(base), -1, dtype=np.int32)
    before[front] = rp.native.cluster_labels(base[front], cfg)
    points_after = np.ascontiguousarray(base[non_ground])
    return {
        "frame": frame.name, "method": method,
        "front": (int(front.sum()), int(non_ground.sum())),
        "whole": (res.points["finite"], res.points["finite"] - res.points["ground"]),
        "ground_clusters": (clusters_on_ground(before, frame.truth, frame.scored),
                            clusters_on_ground(res.cluster_labels, frame.truth, frame.scored)),
        "clustering": [{"ms": ms} for ms in timed(lambda: rp.native.cluster_labels(points_after, cfg), repeat)],
        "stage": [{"ms": r.timing_ms["obstacles"]} for r in results],
        "total": [{"ms": r.timing_ms["total"]} for r in results],
        "points_after": points_after,
    }


def variant_row(m: dict, voxel: float, repeat: int) -> list:
    cfg = rp.Config(obstacles={"voxel_m": voxel})
    labels = rp.native.cluster_labels(m["points_after"], cfg)
    runs = [{"ms": ms} for ms in timed(lambda: rp.native.cluster_labels(m["points_after"], cfg), repeat)]
    return [m["frame"], len(m["points_after"]), "every point" if voxel == 0 else f"{voxel:g} m",
            spread(runs, "ms"), int(labels.max()) + 1]


# ------------------------------------------------------------------------------------------------ output
def print_header(args, load_at_start: float) -> None:
    print("# roadpreview obstacle benchmark\n")
    print(f"- Machine: {cpu_model()}, {os.cpu_count()} logical cores; 1-min load average {load_at_start:.2f} at "
          f"start, {os.getloadavg()[0]:.2f} at end; Python {platform.python_version()}, numpy {np.__version__}, "
          f"roadpreview {rp.__version__}")
    if load_at_start > BUSY_LOAD:
        print("- **Other processes were busy when the run started**: expect inflated times; rerun on an idle "
              "machine for the record.")
    o = rp.Config().obstacles
    print(f"- Default obstacle config: voxels {o.voxel_m} m, tolerance {o.cluster_tolerance_m} m, "
          f"{o.min_cluster_points}–{o.max_cluster_points} points per cluster. Motion {SPEED_MPS} m/s, "
          f"{YAW_RATE_RPS} rad/s. Times: median (min–max) of {args.repeat} runs after {WARMUP} warm-up, ms.\n")


def print_paper_metrics(measured: list[dict]) -> None:
    rows = []
    for m in measured:
        (before, before_all), (after, after_all) = m["ground_clusters"]
        rows.append([m["frame"], m["method"], f"{m['front'][0]} → {m['front'][1]}", f"{m['whole'][0]} → {m['whole'][1]}",
                     f"{before} → {after}", f"{before_all} → {after_all}"])
    for method in METHODS:
        mine = [m for m in measured if m["method"] == method]
        mean = lambda f: np.mean([f(m) for m in mine])  # noqa: E731
        rows.append([f"**mean of {len(mine)} frames**", method,
                     f"{mean(lambda m: m['front'][0]):.0f} → {mean(lambda m: m['front'][1]):.0f}",
                     f"{mean(lambda m: m['whole'][0]):.0f} → {mean(lambda m: m['whole'][1]):.0f}",
                     f"{mean(lambda m: m['ground_clusters'][0][0]):.2f} → {mean(lambda m: m['ground_clusters'][1][0]):.2f}",
                     f"{mean(lambda m: m['ground_clusters'][0][1]):.1f} → {mean(lambda m: m['ground_clusters'][1][1]):.1f}"])
    rows.append(["**paper** (4 × VLP-16 + LUX, 7,840 steps)", "RANSAC plane", "–",
                 f"{PAPER_POINTS[0]:,.0f} → {PAPER_POINTS[1]:,.0f}",
                 f"{PAPER_GROUND_CLUSTERS[0]:.2f} → {PAPER_GROUND_CLUSTERS[1]:.2f}", "–"])
    print(f"## The paper's metrics: before → after ground removal (front region x ∈ [{ROI_X_M[0]:g}, "
          f"{ROI_X_M[1]:g}] m, |y| ≤ {ROI_Y_ABS_M:g} m)\n")
    print(md_table(["frame", "ground", "points, front region", "points, whole frame", "clusters on the ground",
                    "all clusters"], rows) + "\n")
    print("A cluster is on the ground when most of its labelled points are SemanticKITTI ground classes; "
          "\"before\" clusters every front-region point, \"after\" is the pipeline's clustering of the "
          "non-ground ones. The paper counts points of its whole sensor set and does not define its front "
          "region; its sensors (VLP-16) see far fewer points than an HDL-64E.\n")


def print_timing(measured: list[dict]) -> None:
    rows = [[m["frame"], m["method"], m["front"][1], spread(m["clustering"], "ms"), spread(m["stage"], "ms"),
             spread(m["total"], "ms")] for m in measured]
    print("## Time per frame (ms)\n")
    print(md_table(["frame", "ground", "non-ground front-region points", "clustering", "obstacle stage",
                    "pipeline total"], rows) + "\n")
    met = [f"{m['frame']} {m['method']}" for m in measured
           if float(np.median([r["ms"] for r in m["clustering"]])) <= TARGET_CLUSTERING_MS]
    print(f"Target: clustering ≤ {TARGET_CLUSTERING_MS:g} ms on a KITTI frame's front region — met on "
          f"{len(met)} of {len(measured)} frame × method runs ({', '.join(met) or 'none'}).\n")


def print_variants(rows: list[list]) -> None:
    print("## Clustering variants (pca ground): PCL's Euclidean clustering of every point vs of voxel centroids\n")
    print(md_table(["frame", "points", "clustered", "ms", "clusters"], rows) + "\n")


# ------------------------------------------------------------------------------------------------ main
def parse_args(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=30, help="timed runs per frame and method")
    parser.add_argument("--quick", action="store_true", help="3 runs (smoke test)")
    args = parser.parse_args(argv)
    if args.quick:
        args.repeat = 3
    if args.repeat < 1:
        parser.error("--repeat must be at least 1")
    return args


def main(argv=None) -> int:
    args = parse_args(argv)
    load_at_start = os.getloadavg()[0]
    frames = [f for f in kitti_frames() if f.truth is not None]
    measured = []
    for frame in frames:
        for method in METHODS:
            print(f"{frame.name}: {method} ×{args.repeat}", file=sys.stderr)
            measured.append(measure(frame, method, args.repeat))
    variants = [variant_row(m, voxel, max(3, args.repeat // 6) if voxel == 0 else args.repeat)
                for m in measured if m["method"] == "pca" for voxel in VOXEL_VARIANTS]
    print_header(args, load_at_start)
    print_paper_metrics(measured)
    print_timing(measured)
    print_variants(variants)
    return 0


if __name__ == "__main__":
    sys.exit(main())
