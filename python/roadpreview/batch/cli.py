# SPDX-License-Identifier: BSD-3-Clause
"""The command line ``roadpreview batch`` (also ``roadpreview-batch`` and ``python -m roadpreview.batch``): its
arguments, parsed into :func:`run_batch`'s, and its exit status. The run options are shared with ``roadpreview
run`` of bags (drives_cli.py)."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Optional, Sequence

from . import __doc__ as BATCH_DOC  # the package's: its first paragraph describes the command
from .driver import run_batch
from .planning import DEFAULT_CHUNK_FRAMES, DEFAULT_OVERLAP_FRAMES


def _pair(text: str, name: str, count=(2, 3)) -> list[float]:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) not in count or not all(math.isfinite(v) for v in values):
        raise ValueError(f"{name} {text}: expected {' or '.join(map(str, count))} comma-separated "
                                         "numbers")
    return values


def add_run_options(p: argparse.ArgumentParser) -> None:
    """The options of ``roadpreview run`` that batches and bag runs share (same names as the C++ CLI's)."""
    motion = p.add_mutually_exclusive_group()
    motion.add_argument("--speed", type=float, help="vehicle speed, m/s (with --yaw-rate, else IMU, else 0)")
    motion.add_argument("--motion", metavar="CSV", help="t,speed,yaw_rate per time (one file for every recording)")
    p.add_argument("--motion-from", choices=["lidar", "bag"],
                   help="lidar: KISS-ICP odometry of each recording; bag: its Odometry/Imu topic (Imu: with --speed)")
    p.add_argument("--yaw-rate", type=float, help="yaw rate, rad/s, positive turning left")
    p.add_argument("--poses", metavar="KITTI_POSES", help="one pose per frame: moves the fusion map, places segments")
    p.add_argument("--sensor-height", type=float, help="m (default: estimated from each recording's first frame)")
    p.add_argument("--extrinsics", help="x,y,z,roll,pitch,yaw (m, rad)")
    p.add_argument("--config", help="JSON or YAML config with the fields of rp.Config")
    p.add_argument("--frame-rate", type=float, default=0.0, help="frame files: frames per second")
    p.add_argument("--fusion", choices=["none", "ema", "kalman"], help="temporal fusion (default none)")
    p.add_argument("--topic", help="bags: the point-cloud or packet topic (roadpreview info lists them)")
    p.add_argument("--meta", help="Ouster metadata JSON (default: found beside each pcap)")


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="roadpreview batch", description=BATCH_DOC.split("\n\n")[0])
    p.add_argument("inputs", nargs="+", metavar="INPUT", help="recordings: pcaps, bags, frame-file folders")
    p.add_argument("-o", "--output", required=True, metavar="OUT_DIR", help="output directory")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, help="local worker processes (default: one per core)")
    where.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask scheduler, e.g. tcp://host:8786")
    p.add_argument("--resume", action="store_true", help="complete only what an earlier batch in OUT_DIR is missing")
    add_run_options(p)
    p.add_argument("--segments", default="10,100", help="segment lengths, m (default 10,100)")
    p.add_argument("--chunk-frames", type=int, default=DEFAULT_CHUNK_FRAMES,
                   help=f"frames per task of a long frame-file recording (default {DEFAULT_CHUNK_FRAMES})")
    p.add_argument("--overlap-frames", type=int, default=DEFAULT_OVERLAP_FRAMES,
                   help=f"frames read before each range for fusion to settle (default {DEFAULT_OVERLAP_FRAMES})")
    add_decoder_options(p)
    p.add_argument("--origin", help="lat,lon[,alt] (deg, m) of the poses' origin: segments carry lat/lon")
    p.add_argument("--gnss", help="GNSS CSV t,lat,lon[,alt]: segments carry lat/lon (one recording per batch)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    return p


def add_decoder_options(p: argparse.ArgumentParser) -> None:
    """The decoder options of ``roadpreview run`` (same names and meanings), applied to every recording."""
    p.add_argument("--columns", type=int, help="raw float32 .bin files: values per point, x y z first "
                                               "(default 5 for *.pcd.bin, else 4)")
    p.add_argument("--sensor-model", help="Velodyne model: VLP-16, VLP-32C, HDL-32E, HDL-64E (default: from the "
                                          "packets)")
    p.add_argument("--calibration", help="Velodyne calibration YAML (ROS velodyne_pointcloud format; HDL-64E needs "
                                         "one)")
    p.add_argument("--beam-calibration", help="beams file (roadpreview calibrate) applied while decoding; .bin/.pcd "
                                              "points find their beam by scan order or elevation")


def decoder_options_from(args) -> dict:
    if args.columns is not None and not 3 <= args.columns <= 64:
        raise ValueError(f"--columns {args.columns}: expected 3 to 64 values per point")
    given = {"columns": args.columns, "sensor_model": args.sensor_model, "calibration": args.calibration,
             "beam_calibration": args.beam_calibration}
    return {name: value for name, value in given.items() if value is not None}


def _config(args) -> Optional[dict]:
    from ..config import Config, Extrinsics

    cfg = Config.from_file(args.config) if args.config else Config()
    if args.sensor_height is not None:
        cfg.sensor_height, cfg.extrinsics = args.sensor_height, None
    if args.extrinsics:
        cfg.extrinsics, cfg.sensor_height = Extrinsics(*_pair(args.extrinsics, "--extrinsics", (6,))), None
    if args.fusion:
        cfg.fusion.method = args.fusion
    cfg.to_json()  # validates: non-finite values are refused here, not on a worker
    return cfg.to_dict()


def run_options_from(args) -> dict:
    opts: dict = {"config": _config(args), "frame_rate": args.frame_rate}
    if args.poses:
        opts["poses"] = args.poses
    if args.motion_from:
        if args.motion or args.poses:
            raise ValueError("--motion-from takes the motion from the recording: not with --motion or --poses")
        opts["motion_from"] = args.motion_from
        if args.speed is not None:  # an Imu topic gives the yaw rate only
            opts["motion"] = (args.speed, None)
    elif args.motion:
        opts["motion"] = args.motion
    elif args.speed is not None:
        opts["motion"] = (args.speed, args.yaw_rate)
    else:
        raise ValueError("give the vehicle's motion: --speed (and --yaw-rate), --motion CSV or --motion-from lidar|bag")
    if args.topic:
        opts["topic"] = args.topic
    if args.meta:
        opts["meta"] = args.meta
    return opts


def main(argv: Optional[Sequence[str]] = None) -> int:
    args = parser().parse_args(argv)
    try:
        if args.workers is not None and args.workers < 1:
            raise ValueError(f"--workers {args.workers}: at least 1")
        lengths = _pair(args.segments, "--segments", range(1, 20))
        geo_options = {}
        if args.origin:
            geo_options["origin"] = _pair(args.origin, "--origin")
        if args.gnss:
            geo_options["gnss"] = args.gnss
        report = run_batch(args.inputs, args.output, workers=args.workers, scheduler=args.scheduler,
                           resume=args.resume, chunk_frames=args.chunk_frames, overlap_frames=args.overlap_frames,
                           segment_lengths_m=lengths, quiet=args.quiet, geo_options=geo_options,
                           **run_options_from(args), **decoder_options_from(args))
    except (ValueError, RuntimeError, OSError) as err:
        print(f"roadpreview batch: error: {err}", file=sys.stderr)
        return 2 if isinstance(err, ValueError) else 1
    except KeyboardInterrupt:  # what is finished is on disk under its final name
        print(f"roadpreview batch: interrupted; the same command with --resume continues it in {args.output}",
              file=sys.stderr)
        return 130
    print(f"roadpreview batch: {len(report['done'])} recording(s) done, {len(report['skipped'])} already done, "
          f"{len(report['failed'])} failed" + (f" (see {Path(args.output) / 'errors.jsonl'})" if report["failed"]
                                               else ""), file=sys.stderr)
    return 1 if report["failed"] else 0
