# SPDX-License-Identifier: BSD-3-Clause
"""Beam offsets on real recordings: each beam's road height across the lane, its repeat with the beam index, and
its persistence from frame to frame.

1. The first frame of each Ouster capture (default: the bundled OS-0-128 and OS1-128; mounting: the sensor height
   given, level): the default pipeline's ground points 3.5–15 m ahead in three strips — the left wheel's (y 0.5–1.1
   m), the centre (|y| ≤ 0.3 m), the right wheel's (y −1.1…−0.5 m). Per beam with at least 3 points in every strip:
   the median height above the frame's ground plane, less a quadratic trend in the beam's range (what levelling
   takes out). Printed: their RMS, their correlation between strips, the elevation error the strips share (mean
   covariance between strips of residual / range: an upper bound of the beams' own, since relief that runs across
   the lane is shared too), and the share of their spread the beam index modulo 4 explains (a detector of four
   azimuth columns), against 2,000 random orderings of the beams. A road does not repeat with the beam index.
2. The same frames with each column's offset taken out (the median over its beams of residual / range; every point
   of the column lowered by its horizontal range times it): classes and G_d(n0) before and after.
3. What no road can do: from frame to frame of a drive each ring falls on other road, so the correlation of the
   beams' residual angles between consecutive frames is the beams' own share — KITTI seq 00 frames 0–2 (0.86 m
   apart, beams numbered in scan order) and the OS1-128 capture's three frames (0.25 m apart).
4. ``--simulated``: the shared error of one simulated frame per ISO 8608 class A–F (OS1-128 and HDL-64E 1.8 m up,
   10 m/s), without beam errors and with 0.03° — how much of it a road's own relief gives.

The README's "Accuracy: what a single frame can and cannot tell" quotes the tables.

Usage: ``python bench/beam_pattern.py [--recording CAPTURE META HEIGHT_M]... [--simulated]``; prints Markdown.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import roadpreview as rp
from roadpreview import sim
from roadpreview.reference.surface_calibration import rings_in_scan_order

DATA = Path(__file__).resolve().parents[1] / "tests" / "data"
OUSTER = DATA / "ouster"
KITTI_FRAMES = [DATA / "semantickitti" / f"00000{k}.bin" for k in range(3)]  # seq 00 frames 0–2, 0.1 s apart
KITTI_HEIGHT_M = 1.73
RECORDINGS = (  # capture, metadata, sensor height (m): the heights the CLI estimates from their ground
    ("OS-0-128-U1_v2.3.0_1024x10.pcap", "OS-0-128-U1_v2.3.0_1024x10.json", 1.97),
    ("OS-1-128_v2.3.0_1024x10_lb_n3.pcap", "OS-1-128_v2.3.0_1024x10.json", 1.97),
)
STRIPS_M = {"left": (0.5, 1.1), "centre": (-0.3, 0.3), "right": (-1.1, -0.5)}
AHEAD_M = (3.5, 15.0)
MIN_POINTS = 3
MIN_BEAMS = 5  # a quadratic trend and the groups of the index modulo 4 need a few beams more than 3
PERMUTATIONS = 2000
SIM_HEIGHT_M = 1.8
SIM_CLASSES = "ABCDEF"


def first_frame(pcap: Path, meta: Path):
    return next(iter(rp.io.open(pcap, meta)))


def beam_residuals(pcap: Path, meta: Path, height_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(beam ids, their ranges in m, residuals in m: one row per beam, one column per strip) of the first frame."""
    return frame_residuals(first_frame(pcap, meta), height_m, str(pcap))


def frame_residuals(frame, height_m: float, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """beam_residuals of a decoded frame."""
    return residuals_of(np.asarray(frame.points[:, :3], np.float32), np.asarray(frame.beams), height_m, name)


def residuals_of(points: np.ndarray, beams: np.ndarray, height_m: float, name: str):
    """beam_residuals of a frame's sensor-frame points (the sensor level, height_m up) and their beams."""
    res = rp.Estimator(rp.Config(sensor_height=height_m)).process(points, 5.0, 0.0)
    ground = np.asarray(res.ground_mask, bool)
    xyz = np.asarray(points, float) + [0.0, 0.0, height_m]  # base frame
    height = xyz @ np.asarray(res.plane[:3]) + res.plane[3]
    ahead = ground & (xyz[:, 0] > AHEAD_M[0]) & (xyz[:, 0] < AHEAD_M[1])
    table = {}  # beam → [(median height, median x) per strip]
    for lo, hi in STRIPS_M.values():
        strip = ahead & (xyz[:, 1] >= lo) & (xyz[:, 1] < hi)
        for beam in np.unique(beams[strip]):
            mine = strip & (beams == beam)
            if mine.sum() >= MIN_POINTS:
                table.setdefault(int(beam), []).append((np.median(height[mine]), np.median(xyz[mine, 0])))
    ids = np.array(sorted(b for b, per_strip in table.items() if len(per_strip) == len(STRIPS_M)))
    if len(ids) < MIN_BEAMS:
        raise ValueError(f"{name}: {len(ids)} beams hold {MIN_POINTS} road points in each strip {AHEAD_M[0]:g}–"
                         f"{AHEAD_M[1]:g} m ahead, {MIN_BEAMS} needed (is the sensor height right?)")
    z = np.array([[h for h, _ in table[b]] for b in ids])
    ranges = np.array([np.mean([x for _, x in table[b]]) for b in ids])
    for k in range(z.shape[1]):
        z[:, k] -= np.polyval(np.polyfit(ranges, z[:, k], 2), ranges)
    return ids, ranges, z


def explained_by_index(ids: np.ndarray, values: np.ndarray, period: int) -> float:
    """Share of Σ values² that the means of the groups of beam index modulo `period` explain."""
    groups = [values[ids % period == k] for k in range(period)]
    return float(sum(len(g) * np.mean(g) ** 2 for g in groups if len(g)) / np.sum(values**2))


def chance_share(ids: np.ndarray, values: np.ndarray, period: int, quantile: float) -> float:
    """The share `explained_by_index` reaches by chance: its quantile over random orderings of the beams."""
    rng = np.random.default_rng(0)
    return float(np.quantile([explained_by_index(ids, rng.permutation(values), period) for _ in range(PERMUTATIONS)],
                             quantile))


def shared_sigma_deg(ranges: np.ndarray, z: np.ndarray) -> float:
    """The beams' elevation error that all strips share: √(mean covariance between strips of residual / range)."""
    c = np.cov((z / ranges[:, None]).T)
    return float(np.degrees(np.sqrt(max(np.mean(c[np.triu_indices(len(c), 1)]), 0.0))))


def column_offsets_rad(ids: np.ndarray, ranges: np.ndarray, z: np.ndarray, columns: int = 4) -> np.ndarray:
    """Each detector column's elevation offset: the median over its beams of the residual / range (rad)."""
    angle = z.mean(axis=1) / ranges
    return np.array([np.median(angle[ids % columns == k]) for k in range(columns)])


def without_column_offsets(points: np.ndarray, beams: np.ndarray, offsets_rad: np.ndarray) -> np.ndarray:
    """The points, each lowered by its horizontal range times its beam's column offset."""
    out = np.array(points, np.float32)
    column = np.where(beams >= 0, beams % len(offsets_rad), 0)
    out[:, 2] -= (np.hypot(out[:, 0], out[:, 1]) * offsets_rad[column] * (beams >= 0)).astype(np.float32)
    return out


def classes(points: np.ndarray, height_m: float) -> str:
    rough = rp.Estimator(rp.Config(sensor_height=height_m)).process(points, 5.0, 0.0).to_dict()["roughness"]
    return " / ".join(f"{rough[w]['class'] or '·'} ({rough[w]['gd_n0'] * 1e6:.0f})" if rough[w]["gd_n0"] else "·"
                      for w in ("left", "right", "vehicle"))


def simulated_shared_sigma_deg(sensor: str, iso_class: str, error_deg: float) -> float:
    """shared_sigma_deg of one simulated frame."""
    lidar = getattr(sim, sensor)(height_m=SIM_HEIGHT_M, elevation_error_deg=error_deg, calibration_seed=3)
    frame = sim.drive(sim.Scene(sim.Road.iso8608(iso_class, seed=5)), lidar, 10.0, 0.0, 1, seed=5)[0]
    points = np.asarray(frame.points, np.float32)[:, :3]
    _, ranges, z = residuals_of(points, lidar.beam_index(), SIM_HEIGHT_M, f"simulated {sensor}, class {iso_class}")
    return shared_sigma_deg(ranges, z)


def drive_beam_angles() -> dict:
    """Per drive: the frames' {beam: mean residual / range (rad)}, for the beams every frame holds."""
    kitti = [np.fromfile(f, np.float32).reshape(-1, 4)[:, :3] for f in KITTI_FRAMES]
    os1 = list(rp.io.open(OUSTER / RECORDINGS[1][0], OUSTER / RECORDINGS[1][1]))
    drives = {"KITTI seq 00 frames 0–2": [(p, rings_in_scan_order(p), KITTI_HEIGHT_M, "KITTI") for p in kitti],
              RECORDINGS[1][0]: [(np.asarray(f.points[:, :3], np.float32), np.asarray(f.beams), RECORDINGS[1][2],
                                  RECORDINGS[1][0]) for f in os1]}
    out = {}
    for name, frames in drives.items():
        per_frame = []
        for args in frames:
            ids, ranges, z = residuals_of(*args)
            per_frame.append(dict(zip(ids.tolist(), z.mean(axis=1) / ranges)))
        shared = sorted(set.intersection(*(set(p) for p in per_frame)))
        out[name] = np.array([[p[b] for b in shared] for p in per_frame])
    return out


def frame_to_frame_correlations(angles: np.ndarray) -> np.ndarray:
    """Correlations of the beams' angles between consecutive frames (rows)."""
    return np.array([np.corrcoef(angles[k], angles[k + 1])[0, 1] for k in range(len(angles) - 1)])


def print_persistence() -> None:
    print("From frame to frame (each ring on other road): the beams' residual angles, correlation between consecutive "
          "frames\n")
    print("| drive | beams in every frame | RMS ° per frame | correlation, frame k and k + 1 |")
    print("|---|---|---|---|")
    for name, angles in drive_beam_angles().items():
        rms = ", ".join(f"{np.degrees(np.sqrt(np.mean(a**2))):.3f}" for a in angles)
        corr = ", ".join(f"{c:.2f}" for c in frame_to_frame_correlations(angles))
        print(f"| {name} | {angles.shape[1]} | {rms} | {corr} |")


def print_simulated() -> None:
    print("Shared elevation error ° of one simulated frame per ISO 8608 class (no beam error / beams off by 0.03°):\n")
    print("| sensor | beam error ° | " + " | ".join(SIM_CLASSES) + " |")
    print("|---|---|" + "---|" * len(SIM_CLASSES))
    for sensor in ("os1_128", "hdl_64e"):
        for error in (0.0, 0.03):
            cells = " | ".join(f"{simulated_shared_sigma_deg(sensor, c, error):.3f}" for c in SIM_CLASSES)
            print(f"| {sensor} | {error:g} | {cells} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--simulated", action="store_true", help="also the measure on simulated frames, classes A–F")
    parser.add_argument("--recording", nargs=3, action="append", metavar=("CAPTURE", "META", "HEIGHT_M"),
                        help="an Ouster capture, its metadata JSON and the sensor's height above the road in m")
    args = parser.parse_args()
    recordings = [(Path(c), Path(m), float(h)) for c, m, h in args.recording] if args.recording else \
        [(OUSTER / c, OUSTER / m, h) for c, m, h in RECORDINGS]
    print("| recording | beams | range m | RMS mm left / centre / right | correlation l–c, l–r, c–r "
          "| shared elevation error ° | share explained by index mod 4 | by chance (95th / 99th percentile) "
          "| group means mm |")
    print("|---|---|---|---|---|---|---|---|---|")
    measured = []  # (capture, height, frame, its beam residuals): each frame decoded and measured once
    for pcap, meta, height in recordings:
        frame = first_frame(pcap, meta)
        measured.append((pcap, height, frame, frame_residuals(frame, height, str(pcap))))
    for pcap, _, _, (ids, ranges, z) in measured:
        c = np.corrcoef(z.T)
        mean = z.mean(axis=1)
        groups = [1000 * np.mean(mean[ids % 4 == k]) for k in range(4)]
        rms = " / ".join(f"{1000 * v:.1f}" for v in np.sqrt(np.mean(z**2, axis=0)))
        print(f"| {pcap.name} | {len(ids)} | {ranges.min():.1f}–{ranges.max():.1f} | {rms} "
              f"| {c[0, 1]:.2f}, {c[0, 2]:.2f}, {c[1, 2]:.2f} | {shared_sigma_deg(ranges, z):.3f} "
              f"| {explained_by_index(ids, mean, 4):.2f} "
              f"| {chance_share(ids, mean, 4, 0.95):.2f} / {chance_share(ids, mean, 4, 0.99):.2f} "
              f"| {', '.join(f'{g:+.1f}' for g in groups)} |")
    print("\nThe same frames with each detector column's offset taken out (classes left / right / vehicle, G_d(n0) in "
          "10⁻⁶ m³; · declined):\n")
    print("| recording | column offsets ° | as decoded | column offsets taken out |")
    print("|---|---|---|---|")
    for pcap, height, frame, residuals in measured:
        offsets = column_offsets_rad(*residuals)
        corrected = without_column_offsets(frame.points[:, :3], np.asarray(frame.beams), offsets)
        print(f"| {pcap.name} | {', '.join(f'{np.degrees(a):+.3f}' for a in offsets)} "
              f"| {classes(np.asarray(frame.points[:, :3], np.float32), height)} | {classes(corrected, height)} |")
    print()
    print_persistence()
    if args.simulated:
        print()
        print_simulated()


if __name__ == "__main__":
    main()
