"""How right the route's segments are (docs/method.md §10): a simulated drive's frames stitched by the C++
RouteBuilder (as ``roadpreview run --segments 10``), each 10 m segment's vehicle class and G_d(n0) against the true
road's over the same stretch, and the single frames' classes against the road's class.

Simulated: ISO 8608 roads of classes B, C and D (two seeds each), an HDL-64E 1.73 m high (KITTI's), straight at
8.6 m/s and 10 Hz, exact extrinsics, the default pipeline (obstacles off: the scene has none). Segments from the
drive's start to 60 m are scored; those beyond are backed only by the last frames' far rings.

Usage: ``python bench/route.py [--frames N] [--classes BCD]``; prints Markdown.
"""

from __future__ import annotations

import argparse

import numpy as np

import roadpreview as rp
from roadpreview import sim
from roadpreview._native import core
from calibration import md_table

CLASSES = "ABCDEFGH"
SPEED_MPS, HEIGHT_M, SEGMENT_M, SCORED_TO_M = 8.6, 1.73, 10.0, 60.0


def drive(iso_class: str, seed: int, frames: int):
    """(single frames' vehicle classes, [(true class, true G_d, stitched class, stitched G_d)] per scored segment)."""
    scene = sim.Scene(sim.Road.iso8608(iso_class, seed=seed))
    lidar = sim.hdl_64e(height_m=HEIGHT_M)
    cfg = rp.Config(extrinsics=rp.Extrinsics(**lidar.extrinsics()), obstacles={"enabled": False})
    estimator, route = rp.Estimator(cfg), core().RouteBuilder(cfg.to_json())
    singles = []
    for frame in sim.drive(scene, lidar, speed_mps=SPEED_MPS, frames=frames, seed=seed):
        result = estimator.process(frame.points, SPEED_MPS, 0.0, timestamp=frame.time_s)
        route.add(result, None)
        singles.append(result.vehicle.iso_class)
    segments = []
    for s in route.segments(SEGMENT_M):
        if s["start_m"] >= SCORED_TO_M:
            continue
        x = np.arange(s["start_m"] + 0.05, s["end_m"], 0.1)  # the drive's bin centres: the straight path's x
        truth = rp.reference.vehicle_roughness(scene.road.relief(x, np.full_like(x, 0.8)),
                                               scene.road.relief(x, np.full_like(x, -0.8)), 0.1, cfg)
        stitched = s["vehicle"]["roughness"]
        segments.append((truth.iso_class, truth.gd_n0, stitched.iso_class, stitched.gd_n0))
    return singles, segments


def row(iso_class: str, frames: int) -> list:
    singles, segments = [], []
    for seed in (3, 4):
        s, g = drive(iso_class, seed, frames)
        singles += s
        segments += [x for x in g if x[0] is not None]
    classed = [(t, tg, c, cg) for t, tg, c, cg in segments if c is not None]
    same = sum(c == t for t, _, c, _ in classed)
    near = sum(abs(CLASSES.index(c) - CLASSES.index(t)) <= 1 for t, _, c, _ in classed)
    ratio = [cg / tg for _, tg, _, cg in classed]
    single = [c for c in singles if c]
    return [iso_class, f"{len(segments)}", f"{len(classed)}", f"{same}", f"{near}",
            f"{np.median(ratio):.2f} ({min(ratio):.2f}–{max(ratio):.2f})" if ratio else "–",
            f"{len(single)} of {len(singles)}, {sum(c == iso_class for c in single)} right"]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--frames", type=int, default=80, help="frames per drive (80: 68.8 m)")
    p.add_argument("--classes", default="BCD")
    a = p.parse_args()
    print(md_table(["road", "segments to 60 m", "classed", "same class", "within one class",
                    "G_d(n0) stitched / true, median (range)", "single frames classed"],
                   [row(c, a.frames) for c in a.classes]))


if __name__ == "__main__":
    main()
