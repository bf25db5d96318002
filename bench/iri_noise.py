"""How much of an IRI is the sensor's (docs/method.md §6, ``iri.noise``): the IRI of the bins' errors alone against
the measured and the true IRI on the simulator, and on the bundled real frames.

Simulated: ISO 8608 roads of classes A–E (seed 5), straight at the accuracy benchmark's speed, four single frames
each of an OS1-128 and an HDL-64E (bench/accuracy.py's sensors, 1.8 m high); per wheel stretch of at least 11 m
the true IRI (the road's relief on the same bins), the measured one, its ``noise``, and √(measured² − noise²),
what the measurement says of the road once its noise is taken out (medians over the wheels). Then the same roads
fused (kalman, 10 frames, the last five scored).

Real: the KITTI seq 00 frames 0–5 (beams numbered by scan order) and the OS1-128 recording's three frames, 5 m/s
straight, with the beams' elevation errors not counted and counted at 0.01° and 0.02° (``profile.beam_sigma_deg``):
per wheel the class, the IRI and its noise.

Usage: ``python bench/iri_noise.py [--shared DIR] [--quick]``; prints Markdown.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import roadpreview as rp
from roadpreview import sim
from roadpreview.reference.iri import iri
from roadpreview.reference.runs import longest_valid_stretch
from accuracy import SENSOR_HEIGHT_M, SENSORS, SPEED_MPS
from beam_errors import kitti_numbered
from calibration import KITTI_HEIGHT_M, OS1_HEIGHT_M, OS1_PCAP, SHARED, kitti_files, md_table

DS_M = 0.1
MIN_STRETCH_BINS = 110  # 11 m: the IRI's shortest stretch


def simulated_rows(quick: bool, fusion: str = "none") -> list:
    """Single frames (4 per road), or fused (kalman: 10 frames, the last 5 scored, the map has filled)."""
    frames, scored_from = (10, 5) if fusion != "none" else (1 if quick else 4, 0)
    rows = []
    for sensor in ("OS1-128",) if quick else ("OS1-128", "HDL-64E"):
        for iso_class in "C" if quick else "ABCDE":
            scene = sim.Scene(sim.Road.iso8608(iso_class, seed=5))
            lidar = SENSORS[sensor](height_m=SENSOR_HEIGHT_M)
            est = rp.Estimator(rp.Config(extrinsics=lidar.extrinsics(), fusion={"method": fusion}))
            wheels = []
            for k, frame in enumerate(sim.drive(scene, lidar, SPEED_MPS, 0.0, frames, seed=5)):
                res = est.process(frame.points, SPEED_MPS, 0.0, timestamp=frame.time_s)
                if k < scored_from:
                    continue
                truth = sim.truth_profiles(scene, frame.pose, SPEED_MPS, 0.0)
                for wheel in ("left", "right"):
                    p = getattr(res, wheel)
                    z = np.asarray(p.z)
                    a, b = longest_valid_stretch(z)
                    if b - a < MIN_STRETCH_BINS or p.roughness.iri.noise is None:
                        continue
                    measured, noise = iri(z[a:b], DS_M), p.roughness.iri.noise
                    wheels.append((iri(np.asarray(truth[wheel])[a:b], DS_M), measured, noise,
                                   np.sqrt(max(0.0, measured ** 2 - noise ** 2))))
            median = np.median(np.array(wheels), axis=0)
            rows.append([sensor, iso_class, *(f"{v:.2f}" for v in median), str(len(wheels))])
    return rows


def wheel_cell(roughness) -> str:
    """'C 10.6/2.9': class ('·' declined), IRI ('–' declined) / its noise, m/km."""
    i = roughness.iri
    value = "–" if i.value is None else f"{i.value:.1f}"
    noise = "–" if i.noise is None else f"{i.noise:.1f}"
    return f"{roughness.iso_class or '·'} {value}/{noise}"


def real_rows(shared: Path) -> list:
    files = kitti_files(shared)
    frames = [(f"KITTI seq 00 {path.stem}", points, beams, KITTI_HEIGHT_M)
              for path, (points, beams) in zip(files, kitti_numbered(files))]
    frames += [(f"OS1-128 recording, frame {k}", f.points.copy(), np.asarray(f.beams).copy(), OS1_HEIGHT_M)
               for k, f in enumerate(rp.io.open(OS1_PCAP))]
    rows = []
    for name, points, beams, height in frames:
        cells = []
        for sigma in (0.0, 0.01, 0.02):
            cfg = rp.Config(sensor_height=height, profile={"beam_sigma_deg": sigma})
            res = rp.Estimator(cfg).process(points, 5.0, 0.0, beams=beams)
            cells.append(f"{wheel_cell(res.left.roughness)} \\| {wheel_cell(res.right.roughness)}")
        rows.append([name, *cells])
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", type=Path, default=SHARED, help="the shared data folder (KITTI frames 3-5)")
    parser.add_argument("--quick", action="store_true", help="one simulated frame of a class C road (smoke test)")
    args = parser.parse_args(argv)
    print("# The IRI of the bins' errors alone\n")
    print("## Simulated single frames: medians over the wheels, m/km\n")
    headers = ["sensor", "class", "true IRI", "measured", "noise", "√(measured² − noise²)", "wheels"]
    print(md_table(headers, simulated_rows(args.quick)) + "\n")
    if not args.quick:
        print("## Simulated, fused (kalman, frames 6–10 of 10): medians over the wheels, m/km\n")
        print(md_table(headers, simulated_rows(False, "kalman")) + "\n")
    print("## Real single frames, 5 m/s straight: class IRI/noise per wheel, left \\| right\n")
    print(md_table(["frame", "beams not counted", "beam σ 0.01°", "beam σ 0.02°"], real_rows(args.shared)) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
