"""Beam errors counted (docs/method.md §3, ``profile.beam_sigma_deg``): the classes real recordings read as each
beam's elevation error is counted in the profiles' noise, from not at all (0, the default) to 0.05°.

KITTI seq 00 frames 0–5 (the HDL-64E's beams numbered by scan order) uncalibrated and after a surface calibration
that did not see the frame (from the other half of the six, as in bench/calibration.py), and the bundled OS1-128
recording (its decoder's beams), uncalibrated and calibrated by its own three frames: per frame the left, right and
vehicle class ('·' declined), 5 m/s straight; then fused (kalman) with each recording's poses. The calibrated
recordings also with each beam's own σ as its calibration states it (``profile.beam_sigmas_deg`` from
``BeamCalibration.beam_sigmas_deg``; the beams it could not determine at 0). The README's "Beam self-calibration"
quotes the tables.

Usage: ``python bench/beam_errors.py [--shared DIR]``; prints Markdown, progress on stderr.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

import roadpreview as rp
from roadpreview.reference.surface_calibration import rings_in_scan_order
from calibration import KITTI_HEIGHT_M, OS1_HEIGHT_M, OS1_PCAP, SHARED, kitti_files, kitti_frames, log, md_table, \
    os1_frames

SIGMAS_DEG = (0.0, 0.005, 0.01, 0.02, 0.05)
SPEED_MPS = 5.0


def classes(frames, cfg: rp.Config, poses=None, speed_mps: float = SPEED_MPS) -> str:
    """'LRV' per frame ('·' declined), the frames through one estimator (fused with the poses when cfg fuses)."""
    est, out = rp.Estimator(cfg), []
    for k, (points, beams) in enumerate(frames):
        motion = {"pose": poses[k]} if poses is not None else {"timestamp": k / 10.0}
        r = est.process(points, speed_mps, 0.0, beams=beams, **motion)
        out.append("".join(c or "·" for c in (r.left.roughness.iso_class, r.right.roughness.iso_class,
                                              r.vehicle.iso_class)))
    return " ".join(out)


def kitti_numbered(files, calibration=None) -> list:
    """(points, beams) of each file, corrected by the beams file when given; beams by scan order either way."""
    out = []
    for path in files:
        if calibration is None:
            points = rp.io.read(path)
            out.append((points, rings_in_scan_order(points)))
        else:
            frame = next(iter(rp.io.open(path, beam_calibration=calibration)))
            out.append((frame.points.copy(), np.asarray(frame.beams).copy()))
    return out


def kitti_recordings(shared: Path, tmp: Path) -> list:
    """(name, frames, poses, height, speed) of the KITTI rows: uncalibrated; each half calibrated by the other;
    all six calibrated by all six (in sample, as the fused rows of bench/calibration.py)."""
    files = kitti_files(shared)
    frames, poses = kitti_frames(shared)
    if frames is None:
        return []
    cfg = rp.Config(sensor_height=KITTI_HEIGHT_M)
    halves = {"0–2": range(3), "3–5": range(3, 6), "0–5": range(6)}
    paths = {}
    for name, idx in halves.items():
        paths[name] = tmp / f"{name}.yaml"
        rp.calibrate_beams([frames[i] for i in idx], method="surface", config=cfg).save(str(paths[name]))
    crossed = kitti_numbered(files[:3], paths["3–5"]) + kitti_numbered(files[3:], paths["0–2"])
    stated = {name: rp.read_beam_calibration(path).beam_sigmas_deg(0.0) for name, path in paths.items()}
    return [("KITTI seq 00, frames 0–5, uncalibrated", kitti_numbered(files), poses, KITTI_HEIGHT_M, 8.6, None),
            ("KITTI seq 00, calibrated by the other half (single) / all six (fused)", crossed, poses,
             KITTI_HEIGHT_M, 8.6, {"single": [stated["3–5"]] * 3 + [stated["0–2"]] * 3, "fused": stated["0–5"],
                                   "fused_frames": kitti_numbered(files, paths["0–5"])})]


def os1_recordings(tmp: Path) -> list:
    """The OS1-128 rows: uncalibrated, and calibrated by its own three frames (motion method, its poses)."""
    points, poses = os1_frames()
    numbered = [(p, np.asarray(f.beams).copy()) for p, f in zip(points, rp.io.open(OS1_PCAP))]
    cfg = rp.Config(sensor_height=OS1_HEIGHT_M)
    source = rp.io.open(OS1_PCAP)
    c = rp.calibrate_beams(numbered, poses=poses, config=cfg, beam_count=source.info["beams"])
    c.sensor_model, c.serial = source.info["sensor_model"], source.info["serial"]
    path = tmp / "os1.yaml"
    c.save(str(path))
    corrected = [(f.points.copy(), np.asarray(f.beams).copy()) for f in rp.io.open(OS1_PCAP, beam_calibration=path)]
    sigmas = c.beam_sigmas_deg(0.0)
    return [("OS1-128 recording, uncalibrated", numbered, poses, OS1_HEIGHT_M, 2.5, None),
            ("OS1-128 recording, calibrated by its own frames", corrected, poses, OS1_HEIGHT_M, 2.5,
             {"single": [sigmas] * len(corrected), "fused": sigmas})]


def stated_classes(frames, per_frame_sigmas: list, height: float) -> str:
    """classes() of single frames, each with its own calibration's stated σ per beam."""
    return " ".join(classes([frame], rp.Config(sensor_height=height, profile={"beam_sigmas_deg": list(sigmas)}))
                    for frame, sigmas in zip(frames, per_frame_sigmas))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shared", type=Path, default=SHARED, help="the shared data folder (KITTI frames 3-5, poses)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        recordings = kitti_recordings(args.shared, Path(tmp)) + os1_recordings(Path(tmp))
    single, fused = [], []
    for name, frames, poses, height, speed, stated in recordings:
        log(name)
        fused_frames = (stated or {}).get("fused_frames", frames)
        for sigma in SIGMAS_DEG:
            cfg = rp.Config(sensor_height=height, profile={"beam_sigma_deg": sigma})
            kalman = rp.Config(sensor_height=height, profile={"beam_sigma_deg": sigma}, fusion={"method": "kalman"})
            single.append([name, f"{sigma:g}", classes(frames, cfg)])
            fused.append([name, f"{sigma:g}", classes(fused_frames, kalman, poses, speed)])
        if stated:
            kalman = rp.Config(sensor_height=height, profile={"beam_sigmas_deg": list(stated["fused"])},
                               fusion={"method": "kalman"})
            single.append([name, "each beam's stated", stated_classes(frames, stated["single"], height)])
            fused.append([name, "each beam's stated", classes(fused_frames, kalman, poses, speed)])
    print("# Beam errors counted\n")
    print(f"## Single frames, {SPEED_MPS:g} m/s straight: left, right, vehicle class per frame\n")
    print(md_table(["recording", "beam σ °", "classes"], single) + "\n")
    print("## Fused (kalman, the recording's poses and speed): left, right, vehicle class per frame\n")
    print(md_table(["recording", "beam σ °", "classes"], fused) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
