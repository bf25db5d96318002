# SPDX-License-Identifier: BSD-3-Clause
"""The real recordings with poses, for bench/accuracy.py: classes frame by frame, single and fused (kalman), and
the repeatability of the single-frame profiles (docs/method.md §9) between the first and the last frame.

  * the bundled OS1-128 pcap (tests/data/ouster, 3 frames) with its KITTI-format poses, sensor 1.97 m high;
  * KITTI odometry seq 00 frames 0–5 (tests/data/semantickitti 000000–000002, the shared data's
    kitti/patchworkpp_seq00 000003–000005) with the seq 00 ground-truth poses and frame times
    (kitti/seq00_poses), HDL-64E 1.73 m high. The poses are the left camera's (x right, y down, z forward):
    T_velo = Tr⁻¹ · T_cam · Tr with seq 00's Velodyne-to-camera Tr (KITTI odometry calib.txt).
The shared data is looked for in $ROADPREVIEW_SHARED_DATA, else ../shared/data beside the repository; without
it the KITTI rows are left out. Usage: ``python bench/real_recordings.py``.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

import roadpreview as rp

REPO = Path(__file__).resolve().parents[1]
OUSTER = REPO / "tests" / "data" / "ouster"
SHARED = Path(os.environ.get("ROADPREVIEW_SHARED_DATA", REPO.parent / "shared" / "data"))
# Seq 00-02 Velodyne → left camera (KITTI odometry calib.txt, "Tr"), row-major 3×4.
KITTI_TR = np.array([4.276802385584e-04, -9.999672484946e-01, -8.084491683471e-03, -1.198459927713e-02,
                     -7.210626507497e-03, 8.081198471645e-03, -9.999413164504e-01, -5.403984729748e-02,
                     9.999738645903e-01, 4.859485810390e-04, -7.206933692422e-03, -2.921968648686e-01]).reshape(3, 4)
NEAR_M = (5.0, 15.0)


def homogeneous(m: np.ndarray) -> np.ndarray:
    return np.vstack([m, [0.0, 0.0, 0.0, 1.0]])


def planar(m: np.ndarray) -> tuple[float, float, float]:
    return float(m[0, 3]), float(m[1, 3]), math.atan2(m[1, 0], m[0, 0])


def read_poses(path: Path, count: int) -> list[np.ndarray]:
    lines = [line for line in path.read_text().splitlines() if line.strip()][:count]
    return [homogeneous(np.array(line.split(), float).reshape(3, 4)) for line in lines]


def os1_128() -> dict:
    frames = [f.points.copy() for f in rp.io.open(str(OUSTER / "OS-1-128_v2.3.0_1024x10_lb_n3.pcap"))]
    poses = [planar(m) for m in read_poses(OUSTER / "OS-1-128_v2.3.0_1024x10_lb_n3_poses_kitti.txt", len(frames))]
    return {"name": "OS1-128 pcap (3 frames)", "frames": frames, "poses": poses,
            "times": [0.1 * i for i in range(len(frames))], "height": 1.97}


def kitti_seq00() -> dict | None:
    files = [REPO / "tests" / "data" / "semantickitti" / f"{i:06d}.bin" for i in range(3)] + \
            [SHARED / "kitti" / "patchworkpp_seq00" / f"{i:06d}.bin" for i in range(3, 6)]
    poses_dir = SHARED / "kitti" / "seq00_poses"
    pose_file, times_file = poses_dir / "00.txt", poses_dir / "KITTI_00_gt_times.txt"
    if not all(f.exists() for f in files + [pose_file, times_file]):
        return None
    tr = homogeneous(KITTI_TR)
    poses = [planar(np.linalg.inv(tr) @ m @ tr) for m in read_poses(pose_file, len(files))]
    times = [float(t) for t in times_file.read_text().split()[:len(files)]]
    return {"name": "KITTI seq 00 frames 0–5", "frames": [np.fromfile(f, np.float32).reshape(-1, 4) for f in files],
            "poses": poses, "times": times, "height": 1.73}


def speed_of(rec: dict) -> float:
    (x0, y0, _), (x1, y1, _) = rec["poses"][0], rec["poses"][-1]
    return math.hypot(x1 - x0, y1 - y0) / (rec["times"][-1] - rec["times"][0])


def process(rec: dict, method: str) -> list:
    est = rp.Estimator(rp.Config(sensor_height=rec["height"], fusion={"method": method}))
    speed = speed_of(rec)
    return [est.process(p, speed, 0.0, timestamp=t, pose=pose if method != "none" else None)
            for p, t, pose in zip(rec["frames"], rec["times"], rec["poses"])]


def label(r) -> str:
    if r.iso_class:
        return r.iso_class
    return "noise" if r.reason == "noise dominates the band" else "–"


def classes(result) -> str:
    return " / ".join(label(getattr(result, w).roughness) for w in ("left", "right")) + f" / {label(result.vehicle)}"


def repeatability(rec: dict, results: list) -> list:
    """Per wheel: the last frame's profile NEAR_M ahead against the first frame's view of that stretch."""
    (x0, y0, _), (x1, y1, _) = rec["poses"][0], rec["poses"][-1]
    travelled = math.hypot(x1 - x0, y1 - y0)
    grid = np.arange(*NEAR_M, 0.1) + 0.05 + travelled
    out = []
    for wheel in ("left", "right"):
        first, last = getattr(results[0], wheel), getattr(results[-1], wheel)
        out.append(rp.repeatability(rp.world_profile(first.s, first.z, 0.0, grid),
                                    rp.world_profile(last.s, last.z, travelled, grid), 0.1))
    return out


def md_table(headers: list[str], rows: list[list]) -> str:
    return "\n".join(["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)] +
                     ["| " + " | ".join(map(str, r)) + " |" for r in rows])


def print_tables(quick: bool = False) -> None:
    """The tables; `quick` (the smoke test): the OS1-128 recording only."""
    recordings = [r for r in (os1_128(), None if quick else kitti_seq00()) if r is not None]
    rows, reps = [], []
    for rec in recordings:
        single, fused = process(rec, "none"), process(rec, "kalman")
        for i, (a, b) in enumerate(zip(single, fused)):
            rows.append([rec["name"], i, classes(a), classes(b), f"{b.fusion['coverage'] * 100:.0f}"])
        travelled = math.hypot(rec["poses"][-1][0] - rec["poses"][0][0], rec["poses"][-1][1] - rec["poses"][0][1])
        for wheel, x in zip(("left", "right"), repeatability(rec, single)):
            reps.append([rec["name"], wheel, f"{travelled:.2f}",
                         f"{x.correlation:.3f}" if x.correlation is not None else f"– ({x.reason})",
                         f"{x.rms_m * 100:.2f}" if x.rms_m is not None else "–", f"{x.length_m:.1f}"])
    print("## Real recordings with poses: classes frame by frame (left / right / vehicle)\n")
    print(md_table(["recording", "frame", "single frame", "fused (kalman, poses)", "fused coverage 0–40 m %"], rows))
    print(f"\n## Real recordings: repeatability of single frames, last frame {NEAR_M[0]:g}–{NEAR_M[1]:g} m ahead vs "
          "the first frame's view\n")
    print(md_table(["recording", "wheel", "travelled m", "correlation", "RMS difference cm", "stretch m"], reps) + "\n")


if __name__ == "__main__":
    print_tables()
