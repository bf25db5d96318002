# SPDX-License-Identifier: BSD-3-Clause
"""Moving objects seen from a moving robot: the Freiburg campus CARMEN log against its world background.

    python bench/roadside_carmen.py                       # the table
    python bench/roadside_carmen.py --picture docs/roadside_carmen_campus.png

The log (GPL-3.0) is read in place from the shared data. Its scans carry corrected poses but no times; the site file
(tests/data/roadside/carmen_freiburg_campus_site.yaml) explains the 0.8 Hz used, an upper bound: speeds scale with it.
A moving track: at least 4 reports and at least 2 m between its first and last position. "Beside the robot": its
mean velocity within 0.3 m/s of the robot's over the same scans (a person walking with it, or something that moves
with the scanner)."""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

import roadpreview as rp

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests" / "python"))
from paths import SHARED_DATA  # noqa: E402

LOG = SHARED_DATA / "laserscan2d" / "carmen_freiburg_campus" / "freiburg-campus-corrected.log.gz"
SITE = REPO / "tests" / "data" / "roadside" / "carmen_freiburg_campus_site.yaml"
RATE_HZ = 0.8


def moving_tracks(cycles: list[dict]) -> dict[int, np.ndarray]:
    """Per moving track: rows (t, x, y, speed)."""
    tracks: dict[int, list] = {}
    for c in cycles:
        for o in c["objects"]:
            tracks.setdefault(o["id"], []).append((c["t_s"], o["x_m"], o["y_m"], o["speed_mps"]))
    out = {}
    for k, v in tracks.items():
        v = np.array(v)
        if len(v) >= 4 and math.hypot(*(v[-1, 1:3] - v[0, 1:3])) >= 2.0:
            out[k] = v
    return out


def beside_robot(track: np.ndarray, times: np.ndarray, poses: np.ndarray) -> bool:
    i0, i1 = np.searchsorted(times, [track[0, 0] - 0.5 / RATE_HZ, track[-1, 0] - 0.5 / RATE_HZ])
    i1 = min(i1, len(times) - 1)
    dt = track[-1, 0] - track[0, 0]
    robot = (poses[i1, :2] - poses[i0, :2]) / dt
    mover = (track[-1, 1:3] - track[0, 1:3]) / dt
    return bool(np.hypot(*(robot - mover)) < 0.3)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--picture", type=Path, help="write the map of the moving tracks (PNG)")
    args = ap.parse_args()
    if not LOG.exists():
        sys.exit(f"{LOG}: the shared data is absent (ROADPREVIEW_SHARED_DATA)")
    scans = rp.roadside.read_scans(LOG, scanner=0, rate_hz=RATE_HZ)
    times = np.array([s["time_s"] for s in scans])
    poses = np.array([s["pose"] for s in scans])
    proc = rp.roadside.Processor(SITE)
    start = time.perf_counter()
    proc.learn_world(scans)
    learn_s = time.perf_counter() - start
    flags = [proc.world_foreground(s) for s in scans]
    near = sum(int((s["ranges_m"] <= 30.0).sum()) for s in scans)
    fg = sum(int(f.sum()) for f in flags)
    cycles = rp.roadside.Processor(SITE).run(scans)
    tracks = {o["id"] for c in cycles for o in c["objects"]}
    moving = moving_tracks(cycles)
    paces = [float(np.median(v[:, 3])) for v in moving.values()]
    beside = sum(beside_robot(v, times, poses) for v in moving.values())
    path_m = float(np.hypot(*np.diff(poses[:, :2], axis=0).T).sum())
    print("| scans | robot path m | returns ≤ 30 m | foreground | world background learned s | confirmed tracks | "
          "moving tracks | median pace m/s (10–90 %) | beside the robot |")
    print("|---|---|---|---|---|---|---|---|---|")
    p10, p50, p90 = np.percentile(paces, [10, 50, 90]) if paces else (math.nan,) * 3
    print(f"| {len(scans)} | {path_m:.0f} | {near} | {fg} ({100 * fg / near:.2f} %) | {learn_s:.2f} | {len(tracks)} | "
          f"{len(moving)} | {p50:.2f} ({p10:.2f}–{p90:.2f}) | {beside} |")
    if args.picture:
        draw(args.picture, scans, flags, poses, moving)


def draw(path: Path, scans: list[dict], flags: list[np.ndarray], poses: np.ndarray, moving: dict) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from roadpreview.reference.roadside import scan_points
    background = np.concatenate([scan_points(s["ranges_m"], s["start_angle_rad"], s["step_rad"], s["pose"],
                                             (s["ranges_m"] <= 30.0) & ~f) for s, f in zip(scans, flags)])
    fig, ax = plt.subplots(figsize=(11, 9))
    ax.scatter(background[::3, 0], background[::3, 1], s=0.05, c="0.55", rasterized=True)
    ax.plot(poses[:, 0], poses[:, 1], "-", color="0.2", lw=0.6, label="robot path")
    for v in moving.values():
        ax.plot(v[:, 1], v[:, 2], "-", lw=1.4)
        ax.plot(v[-1, 1], v[-1, 2], "o", ms=2.5, color="k")
    ax.set_aspect("equal")
    ax.set_xlabel("x m (the log's world frame)")
    ax.set_ylabel("y m")
    ax.set_title(f"Freiburg campus CARMEN log: {len(moving)} moving tracks (colour; dot = last position) "
                 "against the world background (grey)")
    ax.legend(loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
