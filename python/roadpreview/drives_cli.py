# SPDX-License-Identifier: BSD-3-Clause
"""``roadpreview-drives``: the commands of the Python package, reached through the ``roadpreview`` CLI.

    roadpreview batch INPUTS... -o OUT_DIR [--workers N | --scheduler ADDRESS] [--resume] [run options]
    roadpreview run DRIVE.bag [--topic T] (--speed V | --motion CSV | --motion-from lidar|bag) [-o OUT.jsonl]
    roadpreview run DRIVE.pcap --motion-from lidar [--poses-out POSES.txt] [--motion-out MOTION.csv] ...
    roadpreview info DRIVE.bag                  topics, message types and counts; the sensor of the chosen topic
    roadpreview-drives odometry INPUT... -o POSES.txt [--motion-out MOTION.csv] [--reference POSES_KITTI.txt]

The C++ ``roadpreview`` executable hands ``batch``, and ``run`` / ``info`` of bags or with ``--topic`` /
``--motion-from``, to this entry point unchanged.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import warnings
from typing import Optional, Sequence

from . import batch, drive


def _run_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="roadpreview run", description="One recording (a bag, or any input with "
                                "--motion-from) to JSON lines, one per frame")
    p.add_argument("inputs", nargs="+", metavar="INPUT")
    batch.add_run_options(p)
    p.add_argument("--frames", default="", help="frames A:B (0-based, B excluded)")
    p.add_argument("--poses-out", help="--motion-from lidar: the odometry's KITTI poses file")
    p.add_argument("--motion-out", help="--motion-from lidar: the odometry's t,speed,yaw_rate CSV")
    p.add_argument("-o", "--output", help="output JSON-lines file (default stdout)")
    p.add_argument("-q", "--quiet", action="store_true", help="no per-frame progress on stderr")
    return p


def _frames(text: str) -> tuple[int, Optional[int]]:
    if not text:
        return 0, None
    a, _, b = text.partition(":")
    try:
        first, last = int(a or 0), (int(b) if b else None) if ":" in text else int(a) + 1
    except ValueError:
        raise ValueError(f"--frames {text}: expected A, A:B, A: or :B") from None
    if first < 0 or (last is not None and last <= first):
        raise ValueError(f"--frames {text}: expected 0 <= A < B")
    return first, last


def run(argv: Sequence[str]) -> int:
    from .config import Config

    args = _run_parser().parse_args(argv)
    opts = batch.run_options_from(args)
    cfg = Config.from_dict(opts.pop("config"))
    kind = opts.pop("motion_from", None)
    if kind == "lidar":
        from . import odometry

        source = {k: v for k, v in opts.items() if k in ("topic", "meta")}
        odo = odometry.estimate(args.inputs, cfg, frame_rate=args.frame_rate or 10.0, quiet=args.quiet, **source)
        odo.write(args.poses_out, args.motion_out)
        opts["motion"] = odo.motion_table(f"{args.inputs[0]}: lidar odometry")
        if cfg.fusion.method != "none":
            opts["poses"] = odo.planar()
    elif kind == "bag":
        from . import io_bags

        speed = opts["motion"][0] if isinstance(opts.get("motion"), tuple) else None
        opts["motion"] = io_bags.motion_table(args.inputs, speed_mps=speed)
    out = open(args.output, "w", encoding="utf-8") if args.output else sys.stdout
    summary = _Summary()
    try:
        results = drive.run(args.inputs, cfg, frames=_frames(args.frames), **opts)
        told = 0
        while True:
            with warnings.catch_warnings(record=True) as caught:  # the runner's warnings, said as the CLI says them
                warnings.simplefilter("always")
                res = next(results, None)
            warned, notes = [str(w.message) for w in caught], results.notes[told:]
            for note in notes:
                print(f"roadpreview: {'warning: ' if note in warned else ''}{note}", file=sys.stderr)
            for other in (text for text in warned if text not in notes):  # a reader's own, e.g. a bag's
                print(f"roadpreview: warning: {other}", file=sys.stderr)
            told = len(results.notes)
            if res is None:
                break
            text = res.to_json()  # the C++ line, byte for byte as `roadpreview run` writes it
            out.write(text + "\n")
            line = json.loads(text)
            summary.add(line)
            if not args.quiet:
                print(f"[{summary.frames}] {_progress(line)}", file=sys.stderr)
    finally:
        if out is not sys.stdout:
            out.close()
    if not summary.frames:
        raise RuntimeError(f"{args.inputs[0]}: no frames in the input; nothing was written")
    print(f"roadpreview: {summary}", file=sys.stderr)
    return 0


def _class(roughness: dict) -> str:
    return roughness.get("class") or "-"


def _progress(line: dict) -> str:
    """A frame's progress line, as the C++ CLI prints it: points, ground, clusters, classes, time."""
    rough, points, profiles = line["roughness"], line["points"], line.get("profiles") or {}
    clusters = ""
    if line.get("obstacles") is not None:
        in_path = [len((profiles.get(w) or {}).get("obstacles") or []) for w in ("left", "right")]
        clusters = f", {len(line['obstacles'])} clusters (L {in_path[0]}, R {in_path[1]} in the paths)"
    reason = f" — {line['reason']}" if line.get("reason") else ""
    label = line["source"] if line.get("frame") is None else f"{line['source']} #{line['frame']}"
    return (f"{label}: {points['input']} points, {points['ground']} ground{clusters}, class "
            f"L={_class(rough['left'])} R={_class(rough['right'])} vehicle={_class(rough['vehicle'])}{reason}, "
            f"{line['timing_ms']['total']:.2f} ms")


class _Summary(batch.Summary):
    """The run's last line, as the C++ CLI's: a batch summary's counts (vehicle classes, IRI, the reasons of every
    declined class) with the pipeline times and the IRI of the bins' errors alone, when known."""

    def __init__(self):
        super().__init__("")
        self.ms, self.iri_noise = [], []

    def add(self, line: dict) -> None:
        super().add(line)
        self.ms.append(line["timing_ms"]["total"])
        iri = line["roughness"]["vehicle"].get("iri") or {}
        if iri.get("value") is not None and iri.get("noise") is not None:
            self.iri_noise.append(iri["noise"])

    def __str__(self) -> str:
        classes = " ".join(f"{c}×{n}" for c, n in sorted(self.classes.items()))
        noise = f"; the bins' errors alone {statistics.median(self.iri_noise):.2f}" if self.iri_noise else ""
        iri = (f"vehicle IRI median {statistics.median(self.iri):.2f} m/km ({len(self.iri)} of {self.frames} "
               f"frames{noise})" if self.iri else "vehicle IRI: none")
        declined = ("; declined classes (L, R, vehicle): " +
                    ", ".join(f"{r} ×{n}" for r, n in sorted(self.declined.items()))) if self.declined else ""
        return (f"{self.frames} frame(s), pipeline median {statistics.median(self.ms):.2f} ms, max "
                f"{max(self.ms):.2f} ms; vehicle classes: {classes}; {iri}{declined}")


def info(argv: Sequence[str]) -> int:
    p = argparse.ArgumentParser(prog="roadpreview info", description="Topics of a ROS bag or MCAP file")
    p.add_argument("inputs", nargs="+", metavar="INPUT")
    p.add_argument("--topic", help="the point-cloud or packet topic to describe")
    args = p.parse_args(argv)
    from . import io_bags

    topics = io_bags.topics(args.inputs)
    for entry in topics:
        print(f"{entry['topic']}\t{entry['type']}\t{entry['messages']} messages")
    try:
        src = drive.open_source(args.inputs, topic=args.topic)
    except (ValueError, RuntimeError) as err:  # the listing is the answer; what `run` would refuse, said beside it
        if args.topic:
            raise  # a topic asked for by name that cannot be read is an error
        scans = any(e["type"].endswith("LaserScan") for e in topics)
        print(f"note: {err}" + ("; 2-D scans are read by `roadpreview roadside`" if scans else ""))
        return 0
    for key, value in src.info.items():  # as the C++ `info` prints a recording: one "name: value" per line
        if key != "topics" and value not in ("", 0, [], None):
            print(f"{key.replace('_', ' ')}: {value}")
    return 0


def odometry_command(argv: Sequence[str]) -> int:
    from . import odometry
    from .config import Config

    p = argparse.ArgumentParser(prog="roadpreview-drives odometry", description=odometry.__doc__.split("\n\n")[0])
    p.add_argument("inputs", nargs="+", metavar="INPUT")
    p.add_argument("-o", "--output", required=True, help="KITTI poses file to write (base frame)")
    p.add_argument("--motion-out", help="t,speed,yaw_rate CSV to write")
    p.add_argument("--reference", help="KITTI poses of the same frames: print speed error and drift")
    p.add_argument("--sensor-height", type=float)
    p.add_argument("--frame-rate", type=float, default=10.0)
    p.add_argument("--topic")
    args = p.parse_args(argv)
    cfg = Config(sensor_height=args.sensor_height)
    odo = odometry.estimate(args.inputs, cfg, frame_rate=args.frame_rate, topic=args.topic)
    odo.write(args.output, args.motion_out)
    if args.reference:
        print(json.dumps(odometry.compare(odo.poses, odometry.read_kitti_matrices(args.reference), odo.times_s)))
    return 0


COMMANDS = {"batch": batch.main, "run": run, "info": info, "odometry": odometry_command}


def main(argv: Optional[Sequence[str]] = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] not in COMMANDS:
        print(f"usage: roadpreview-drives {{{','.join(COMMANDS)}}} ...", file=sys.stderr)
        return 2
    command, rest = argv[0], argv[1:]
    try:
        if command == "batch":
            return batch.main(rest)
        return COMMANDS[command](rest)
    except ModuleNotFoundError as err:  # an optional dependency of these commands
        package = (err.name or "").partition(".")[0] or str(err)
        print(f"roadpreview: error: `{command}` needs the Python package {package!r}, which is not installed: "
              "pip install 'roadpreview[drives]'", file=sys.stderr)
        return 1
    except (ValueError, RuntimeError, OSError) as err:
        print(f"roadpreview: error: {err}", file=sys.stderr)
        return 2 if isinstance(err, ValueError) else 1


if __name__ == "__main__":
    sys.exit(main())
