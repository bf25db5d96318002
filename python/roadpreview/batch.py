# SPDX-License-Identifier: BSD-3-Clause
"""Many recordings at once on Dask: ``roadpreview batch INPUTS... -o OUT_DIR [--workers N | --scheduler ADDRESS]``.

One task per recording (a long recording of frame files is split into frame ranges that start
``--overlap-frames`` early, so fusion has settled where each range's kept frames begin), then one task per
recording that writes its summary and segment table. Output (docs/output.md, "Batch outputs"):

    OUT_DIR/frames/recording=ID/part-00000.parquet   per-frame results, Hive-partitioned by recording (the key is
                                                     the folder's: not a column of the parts)
    OUT_DIR/recordings/ID/summary.json               frames, classes, median IRI, declined reasons
    OUT_DIR/recordings/ID/segments.parquet           class, G_d(n0), IRI per wheel per 10 / 100 m
    OUT_DIR/summary.csv, OUT_DIR/segments.parquet    all recordings, rewritten at the end of every batch
    OUT_DIR/errors.jsonl                             one line per recording that failed (its frames removed)
    OUT_DIR/options.json                             the options the results depend on: --resume refuses others

Every file is written under a temporary name and renamed, so a killed task leaves nothing half-written and
``--resume`` redoes exactly the parts and summaries that are missing.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import json
import math
import os
import re
import shutil
import sys
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from . import drive

SEGMENT_LENGTHS_M = (10.0, 100.0)
DEFAULT_CHUNK_FRAMES = 500
DEFAULT_OVERLAP_FRAMES = 20


@dataclass
class Chunk:
    """Frames [first, last) of a recording, of which those from ``keep_from`` on are written."""

    index: int
    first: int
    last: Optional[int]
    keep_from: int


@dataclass
class Recording:
    id: str
    inputs: list[str]
    chunks: list[Chunk] = field(default_factory=list)


# ---------------------------------------------------------------------------------------------------------
# Planning: which recordings, which frame ranges, what is already done.

def recording_id(path: str) -> str:
    """A file-system-safe name for a recording: its file or folder name without the recording suffix."""
    name = Path(path.rstrip("/")).name
    for suffix in (".pcapng", ".pcap", ".bag", ".mcap", ".db3"):
        if name.lower().endswith(suffix):
            name = name[: -len(suffix)]
            break
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name) or "recording"


def frame_count(path: str) -> Optional[int]:
    """Frames of a frame-file recording (a directory or file), None for recordings that must be decoded to count."""
    if input_kind(path) != "files":
        return None
    from . import io as rp_io

    return len(rp_io.expand([path]))


def split(frames: Optional[int], chunk_frames: int, overlap_frames: int) -> list[Chunk]:
    """Frame ranges of ``chunk_frames`` kept frames, each read from ``overlap_frames`` earlier."""
    if frames is None or chunk_frames <= 0 or frames <= chunk_frames:
        return [Chunk(0, 0, None, 0)]
    return [Chunk(k, max(0, start - overlap_frames), min(frames, start + chunk_frames), start)
            for k, start in enumerate(range(0, frames, chunk_frames))]


def sensor_of(path: str, source_options: dict) -> tuple:
    """What kind of sensor a recording comes from, to refuse a batch that mixes them."""
    if frame_count(path) is not None:
        files = drive_files(path)
        return ("files", Path(files[0]).suffix.lower() if files else "")
    info = drive.open_source([path], **source_options).info
    return (info.get("format", ""), info.get("sensor_model", ""), info.get("beams", 0))


def drive_files(path: str) -> list[str]:
    from . import io as rp_io

    return rp_io.expand([path])


def input_kind(path: str) -> str:
    if drive.is_bag(path):
        return "bag"
    return "pcap" if path.lower().endswith((".pcap", ".pcapng")) else "files"


# The inputs each source option applies to, as `roadpreview run` has them.
SOURCE_OPTION_INPUTS = {"topic": (("bag",), "ROS bags and MCAP files"), "meta": (("pcap",), "pcap recordings"),
                        "sensor_model": (("pcap",), "pcap recordings"), "calibration": (("pcap",), "pcap recordings"),
                        "columns": (("files",), "raw float32 .bin files"),
                        "beam_calibration": (("pcap", "files"), "pcap recordings and frame files")}


def check_source_options(inputs: Sequence[str], source_options: dict) -> None:
    """Refuses a source option given with an input it does not apply to: the options apply to every recording, so
    that is a usage error of the batch, not one error line per recording."""
    for name, value in source_options.items():
        kinds, what = SOURCE_OPTION_INPUTS.get(name, ((), ""))
        if value in (None, "", 0) or not kinds:
            continue
        for path in map(os.fspath, inputs):
            if input_kind(path) not in kinds:
                raise ValueError(f"{path}: --{name.replace('_', '-')} applies to {what} only")


def plan(inputs: Sequence[str], chunk_frames: int, overlap_frames: int, source_options: dict,
         unreadable: Optional[list] = None) -> list[Recording]:
    """One Recording per input, each with its chunks. Raises ValueError for a missing input, an input without
    frames, or recordings from different sensors. A recording that cannot even be opened (a corrupt pcap, a bag
    with no point cloud or several) is appended to ``unreadable`` as (Recording, error) when that list is given,
    else raises."""
    recordings, seen, sensors = [], Counter(), {}
    for path in map(os.fspath, inputs):
        if not os.path.exists(path):
            raise ValueError(f"{path}: no such recording")
        rid = recording_id(path)
        seen[rid] += 1
        if seen[rid] > 1:
            rid = f"{rid}-{seen[rid]}"
        try:
            frames = frame_count(path)
        except RuntimeError as err:  # a folder without frame files: a wrong argument, said before any run
            raise ValueError(str(err)) from None
        if frames == 0:
            raise ValueError(f"{path}: no frame files in this recording")
        try:
            sensor = sensor_of(path, source_options)
        except (RuntimeError, OSError, ValueError) as err:  # ValueError: a bag's topics (the options are checked)
            if unreadable is None:
                raise
            unreadable.append((Recording(rid, [path]), err))
            continue
        sensors.setdefault(sensor, path)
        if len(sensors) > 1:
            (a, pa), (b, pb) = list(sensors.items())[:2]
            raise ValueError(f"mixed sensors in one batch: {pa} is {'/'.join(map(str, a))}, {pb} is "
                             f"{'/'.join(map(str, b))}; run one batch per sensor (the config applies to all)")
        recordings.append(Recording(rid, [path], split(frames, chunk_frames, overlap_frames)))
    return recordings


FILE_OPTIONS = ("motion", "poses", "meta", "calibration", "beam_calibration", "gnss")


def batch_options(run_options: dict, chunk_frames: int, overlap_frames: int, segment_lengths_m: Sequence[float],
                  geo_options: dict) -> dict:
    """What a batch's results depend on, one flat mapping as OUT_DIR/options.json keeps it ("config.sensor_height",
    "motion", "segment_lengths_m", ...): the config in full (defaults filled in), the motion, poses and source
    options, the frame ranges (they decide what each part holds), the segment lengths and the map's options. Not
    the workers, the scheduler or the progress bar: they change no result."""
    from .config import Config

    options = {f"config.{name}": value for name, value in _flat(Config.from_dict(run_options.get("config") or {})
                                                                .to_dict()).items()}
    others = dict(run_options, chunk_frames=chunk_frames, overlap_frames=overlap_frames,
                  segment_lengths_m=[float(x) for x in segment_lengths_m], **geo_options)
    options.update((name, _comparable(name, value)) for name, value in others.items() if name != "config")
    return json.loads(json.dumps(options))  # tuples as lists, as the file gives them back


def _flat(tree: dict) -> dict:
    flat = {}
    for name, value in tree.items():
        if isinstance(value, dict):
            flat.update((f"{name}.{inner}", v) for inner, v in _flat(value).items())
        else:
            flat[name] = value
    return flat


def _comparable(name: str, value):
    """An option as options.json keeps it: a file by its content's sha256 (where it lies changes no result), poses
    and a motion table in memory by their numbers'."""
    if name in FILE_OPTIONS and isinstance(value, (str, os.PathLike)):
        try:
            content = Path(value).read_bytes()
        except OSError as err:
            option = f"--{name.replace('_', '-')} {os.fspath(value)}"
            raise ValueError(f"{option}: cannot be read ({err.strerror})") from None
        return f"file with sha256 {hashlib.sha256(content).hexdigest()}"
    if isinstance(value, drive.MotionTable):
        numbers = [np.asarray(column).tolist() for column in (value.t, value.speed, value.yaw_rate)]
        return f"motion table with sha256 {hashlib.sha256(json.dumps(numbers).encode()).hexdigest()}"
    if name == "poses" and value is not None:
        numbers = [[float(v) for v in pose] for pose in value]
        return f"{len(numbers)} poses with sha256 {hashlib.sha256(json.dumps(numbers).encode()).hexdigest()}"
    return value


def check_options(out_dir: Path, options: dict) -> None:
    """Refuses to resume a batch made with other options, naming those that differ: its finished recordings would
    be mixed with ones made otherwise. A batch from before options.json was kept is not checked."""
    path = out_dir / "options.json"
    if not path.exists():
        return
    made_with = json.loads(path.read_text())
    differ = [name for name in sorted(set(made_with) | set(options)) if made_with.get(name) != options.get(name)]
    if differ:
        said = "; ".join(f"{name} {json.dumps(made_with.get(name))} there, {json.dumps(options.get(name))} now"
                         for name in differ)
        raise ValueError(f"{out_dir}: the earlier batch there ran with other options ({said}): give the options it "
                         f"ran with to --resume it, or choose another -o")


def part_path(out_dir: Path, rid: str, chunk: Chunk) -> Path:
    return out_dir / "frames" / f"recording={rid}" / f"part-{chunk.index:05d}.parquet"


def recording_dir(out_dir: Path, rid: str) -> Path:
    return out_dir / "recordings" / rid


def summary_path(out_dir: Path, rid: str) -> Path:
    return recording_dir(out_dir, rid) / "summary.json"


def bind_inputs(out_dir: Path, recordings: Sequence[Recording], resume: bool) -> None:
    """Each recording id keeps the inputs it was made from (recordings/ID/inputs.json, real paths): ids come
    from folder names and the order of the arguments, so a resumed batch given its inputs in another order, or
    another folder of the same name, would take one recording's finished parts for another's. Refused."""
    for rec in recordings:
        path = recording_dir(out_dir, rec.id) / "inputs.json"
        given = [os.path.realpath(p) for p in rec.inputs]
        if resume and path.exists():
            made_from = json.loads(path.read_text())
            if made_from != given:
                raise ValueError(f"{out_dir}: recording {rec.id} there was made from {', '.join(made_from)}, not "
                                 f"{', '.join(given)}: give the inputs as the earlier batch did (in the same order) "
                                 f"or choose another -o")
            continue
        _write_atomically(path, lambda tmp: tmp.write_text(json.dumps(given) + "\n"))


def _write_atomically(path: Path, write):
    """``write(tmp_path)`` then rename, so readers and --resume never see a half-written file; returns what
    ``write`` returns. A failed write leaves nothing behind."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        result = write(tmp)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    os.replace(tmp, path)
    return result


# ---------------------------------------------------------------------------------------------------------
# Tasks (run on the Dask workers; plain functions of plain arguments).

def frame_row(index: int, result, pose=None) -> dict:
    """One Parquet row of a Result: the columns people filter on, and the whole output line (without timing: it
    must repeat from run to run) as JSON. ``frame`` is the frame's index in its recording, also where a task
    started the estimator later. Read from the Result's fields: parsing and re-encoding the ~60 kB line of a KITTI
    frame cost as much as a third of a batch task."""
    row = {"frame": index, "source": result.source, "timestamp": result.timestamp,
           "speed_mps": result.speed_mps, "yaw_rate_rps": result.yaw_rate_rps, "reason": result.reason}
    for side, rough in (("left", result.left.roughness), ("right", result.right.roughness),
                        ("vehicle", result.vehicle)):
        row[f"{side}_class"] = rough.iso_class
        row[f"{side}_gd_n0_m3"] = rough.gd_n0
        row[f"{side}_iri_m_per_km"] = rough.iri.value
    row["pose_x_m"], row["pose_y_m"], row["pose_yaw_rad"] = pose if pose is not None else (None, None, None)
    row["line"] = result.to_json(frame=index, timing=False)
    row["timing_total_ms"] = result.timing_ms["total"]
    row["timing_fusion_ms"] = result.fusion["time_ms"] if result.fusion else None
    return row


def _motion_from(kind: str, rid: str, inputs: list[str], cfg, opts: dict, out_dir: str):
    """(motion, poses) of a recording from its own data: KISS-ICP odometry (written beside its summary as a
    KITTI poses file and a motion CSV), or the bag's Odometry / Imu topic."""
    source_options = {k: v for k, v in opts.items() if k not in ("motion", "poses", "frame_rate")}
    if kind == "bag":
        from . import io_bags

        speed = opts["motion"][0] if isinstance(opts.get("motion"), tuple) else None
        return io_bags.motion_table(inputs, speed_mps=speed), None
    from . import odometry

    odo = odometry.estimate(inputs, cfg, frame_rate=opts.get("frame_rate") or 10.0, **source_options)
    folder = recording_dir(Path(out_dir), rid)
    folder.mkdir(parents=True, exist_ok=True)
    odo.write(str(folder / "odometry.poses.txt"), str(folder / "odometry.motion.csv"))
    return odo.motion_table(f"{inputs[0]}: lidar odometry"), odo.planar()


# The runner's note when a frame's ground lies at the cloud's origin, level: the points are base-frame points already.
BASE_FRAME_NOTE = "lies at the cloud's origin ("


def find_mounting(inputs: list[str], run_options: dict, until: int) -> Optional[dict]:
    """The mounting a run of the whole recording settles on among frames [0, until), for the chunks that start
    after it: each chunk's runner would otherwise estimate its own from its first frame, and the lines would
    depend on --chunk-frames. {"frame": where it settled, "extrinsics": [x, y, z, roll, pitch, yaw], "source":
    "estimated"}, or "none" with zero extrinsics when the frame showed base-frame points; None when no frame before
    ``until`` settled it (every chunk then asks the same frames the whole run asks)."""
    import warnings

    from .config import Config

    opts = {k: v for k, v in run_options.items() if k not in ("config", "motion", "poses", "motion_from")}
    found = drive.run(inputs, Config.from_dict(run_options.get("config") or {}), motion=(0.0, 0.0),
                      frames=(0, until), **opts)  # the mounting needs no motion; a stopped vehicle costs least
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the chunks' runs warn of the same frames
        for index, result in enumerate(found):
            if result.mounting["source"] == "estimated":
                return {"frame": index, "extrinsics": list(result.mounting["extrinsics"]), "source": "estimated"}
            if any(BASE_FRAME_NOTE in note for note in found.notes):
                return {"frame": index, "extrinsics": [0.0] * 6, "source": "none"}
    return None


def _mounted(cfg, mounting: dict):
    """The config with the mounting a run of the whole recording found."""
    from .config import Config, Extrinsics

    cfg = Config.from_dict(cfg.to_dict()) if cfg is not None else Config()
    cfg.sensor_height, cfg.extrinsics = None, Extrinsics(*mounting["extrinsics"])
    return cfg


def with_mounting_source(line: str, source: str, where: str) -> str:
    """The output line as the whole recording's run writes it: a chunk run with the mounting that run found says
    "given" where it says "estimated" (or "none": base-frame points). Edited as text: the line is the C++ one, byte
    for byte, and parsing and re-encoding ~60 kB per frame would cost a third of a task."""
    given = '"source":"given","ground_offset"'
    if line.count(given) != 1:
        raise RuntimeError(f"{where}: the output line has no mounting.source \"given\" to restore as {source!r}")
    return line.replace(given, f'"source":"{source}","ground_offset"')


def process_chunk(rid: str, inputs: list[str], chunk: Chunk, run_options: dict, out_dir: str,
                  mounting: Optional[dict] = None) -> dict:
    """Runs frames [first, last) of one recording and writes the kept frames to their Parquet part. ``mounting``:
    what :func:`find_mounting` found, used when the chunk starts after the frame that gave it."""
    from .config import Config

    opts = dict(run_options)
    config = opts.pop("config", None)
    cfg = Config.from_dict(config) if config is not None else None
    mounting_source = None
    if mounting is not None and chunk.first > mounting["frame"]:
        cfg, mounting_source = _mounted(cfg, mounting), mounting["source"]
    motion_from = opts.pop("motion_from", None)
    if motion_from:
        opts["motion"], opts["poses"] = _motion_from(motion_from, rid, inputs, cfg, opts, out_dir)
    if isinstance(opts.get("poses"), (str, os.PathLike)):
        opts["poses"] = drive.read_kitti_poses(opts["poses"])
    poses = opts.get("poses")
    path = part_path(Path(out_dir), rid, chunk)
    written = _write_atomically(path, lambda tmp: _write_frames(tmp, inputs, cfg, chunk, opts, poses,
                                                                mounting_source))
    if not written and chunk.index == 0:
        path.unlink()
        raise RuntimeError(f"{inputs[0]}: no frames in this recording")
    return {"recording": rid, "chunk": chunk.index, "frames": written, "path": str(path)}


ROW_GROUP_FRAMES = 128  # a Parquet row group holds at most this many frames,
ROW_GROUP_BYTES = 2 << 20  # or this many bytes of output lines (a KITTI HDL-64E frame's line is ~59 kB: 36 frames)


def _write_frames(tmp: Path, inputs, cfg, chunk: Chunk, opts: dict, poses, mounting_source=None) -> int:
    """Streams the chunk's kept frames into a Parquet file, a row group at a time. A row group's rows, their
    Arrow table and its encoding are what a worker holds beyond one frame: bounding it by bytes keeps the
    worker's memory flat whatever the sensor (128 KITTI frames per group swung the RSS by 15 %, README "Drives")."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    schema, rows, row_bytes, written = FRAME_SCHEMA(), [], 0, 0
    with pq.ParquetWriter(tmp, schema) as writer:
        for k, result in enumerate(drive.run(inputs, cfg, frames=(chunk.first, chunk.last), **opts)):
            index = chunk.first + k
            if index >= chunk.keep_from:
                rows.append(frame_row(index, result, poses[index] if poses else None))
                if mounting_source:
                    rows[-1]["line"] = with_mounting_source(rows[-1]["line"], mounting_source,
                                                            f"{inputs[0]}: frame {index}")
                row_bytes += len(rows[-1]["line"])
            if len(rows) == ROW_GROUP_FRAMES or row_bytes >= ROW_GROUP_BYTES:
                writer.write_table(pa.Table.from_pylist(rows, schema=schema))
                written, rows, row_bytes = written + len(rows), [], 0
        if rows:
            writer.write_table(pa.Table.from_pylist(rows, schema=schema))
    return written + len(rows)


def FRAME_SCHEMA():  # noqa: N802 (a constant built lazily: pyarrow is imported only where it is used)
    """The columns of a per-frame part. Not ``recording``: a Hive reader (pandas, pyarrow, Polars, DuckDB) takes
    the partition key from the folder name and refuses a file column of the same name but another type."""
    import pyarrow as pa

    cols = [("frame", pa.int64()), ("source", pa.string()), ("timestamp", pa.float64()),
            ("speed_mps", pa.float64()), ("yaw_rate_rps", pa.float64()), ("reason", pa.string())]
    for side in ("left", "right", "vehicle"):
        cols += [(f"{side}_class", pa.string()), (f"{side}_gd_n0_m3", pa.float64()),
                 (f"{side}_iri_m_per_km", pa.float64())]
    cols += [("pose_x_m", pa.float64()), ("pose_y_m", pa.float64()), ("pose_yaw_rad", pa.float64()),
             ("line", pa.string()), ("timing_total_ms", pa.float64()), ("timing_fusion_ms", pa.float64())]
    return pa.schema(cols)


def SEGMENT_SCHEMA():  # noqa: N802 (as FRAME_SCHEMA)
    """The columns of ``roadpreview run --segments`` after ``recording``, then lat/lon (null without a map)."""
    import pyarrow as pa

    cols = [("recording", pa.string()), ("segment_length_m", pa.float64()), ("start_m", pa.float64()),
            ("end_m", pa.float64())]
    cols += [(f"{axis}_{end}_m", pa.float64()) for end in ("start", "end") for axis in ("x", "y")]
    for side in ("left", "right", "vehicle"):
        cols += [(f"class_{side}", pa.string()), (f"gd_n0_m3_{side}", pa.float64()),
                 (f"iri_m_per_km_{side}", pa.float64()), (f"backed_fraction_{side}", pa.float64()),
                 (f"class_reason_{side}", pa.string()), (f"iri_reason_{side}", pa.string()),
                 (f"iri_noise_m_per_km_{side}", pa.float64())]
    cols += [(f"{q}_{end}", pa.float64()) for end in ("start", "end") for q in ("lat", "lon")]
    return pa.schema(cols)


def read_frames(out_dir, rid: Optional[str] = None, columns: Optional[Sequence[str]] = None):
    """The per-frame table of a batch (one recording, or all; some columns, or all), in frame order."""
    import pyarrow.parquet as pq

    root = Path(out_dir) / "frames"
    paths = sorted((root / f"recording={rid}").glob("part-*.parquet")) if rid else sorted(root.glob("*/part-*.parquet"))
    if not paths:
        raise FileNotFoundError(f"{root}: no per-frame results{' for ' + rid if rid else ''}")
    import pyarrow as pa

    keys = ["recording", "frame"]
    stored = None if columns is None else list(dict.fromkeys(["frame"] + [c for c in columns if c != "recording"]))

    def part(path: Path):
        table = pq.read_table(path, schema=FRAME_SCHEMA(), columns=stored)
        recording = path.parent.name.removeprefix("recording=")
        return table.add_column(0, "recording", pa.array([recording] * table.num_rows, pa.string()))

    table = pa.concat_tables([part(p) for p in paths]).sort_by([(k, "ascending") for k in keys])
    return table if columns is None else table.select(list(columns))


def frame_rows(out_dir, rid: str, columns: Sequence[str]):
    """The rows of one recording's per-frame parts in frame order, a row group at a time."""
    import pyarrow.parquet as pq

    for path in sorted((Path(out_dir) / "frames" / f"recording={rid}").glob("part-*.parquet")):
        parts = pq.ParquetFile(path)
        for group in range(parts.num_row_groups):  # iter_batches buffers far ahead: 0.3 GB for 5,000 frames
            yield from parts.read_row_group(group, columns=list(columns)).to_pylist()


class Summary:
    """Frames, vehicle classes, median vehicle IRI and the reasons of every declined class of one recording."""

    def __init__(self, rid: str):
        self.rid, self.frames, self.classes, self.declined, self.iri = rid, 0, Counter(), Counter(), []

    def add(self, line: dict) -> None:
        self.frames += 1
        rough = line.get("roughness") or {}
        self.classes[(rough.get("vehicle") or {}).get("class") or "-"] += 1
        value = ((rough.get("vehicle") or {}).get("iri") or {}).get("value")
        if value is not None:
            self.iri.append(value)
        for side in ("left", "right", "vehicle"):
            r = rough.get(side) or {}
            if not r.get("class"):
                self.declined[r.get("reason") or "no reason given"] += 1

    def to_dict(self) -> dict:
        return {"recording": self.rid, "frames": self.frames, "vehicle_classes": dict(sorted(self.classes.items())),
                "vehicle_iri_median_m_per_km": float(np.median(self.iri)) if self.iri else None,
                "vehicle_iri_frames": len(self.iri), "declined": dict(sorted(self.declined.items()))}


def route_builder(config: Optional[dict]):
    """The C++ RouteBuilder of ``roadpreview run --segments`` for a batch's config."""
    from ._native import core
    from .config import Config

    return core().RouteBuilder((Config.from_dict(config) if config else Config()).to_json())


def stitch(out_dir, rid: str, config: Optional[dict]):
    """(route, summary) of one recording read from its parts: the frames' profiles stitched along the drive
    (the C++ RouteBuilder of ``roadpreview run --segments``), placed by the frames' poses when they have them,
    else by speed × time."""
    route = route_builder(config)
    summary = Summary(rid)
    for row in frame_rows(out_dir, rid, ("frame", "line", "pose_x_m", "pose_y_m", "pose_yaw_rad")):
        pose = None if row["pose_x_m"] is None else (row["pose_x_m"], row["pose_y_m"], row["pose_yaw_rad"])
        route.add_line(row["line"], pose, where=f"{rid}: frame {row['frame']}")
        summary.add(json.loads(row["line"]))
    return route, summary


def segment_rows(rid: str, route, lengths_m: Sequence[float]) -> list[dict]:
    """The stitched route's segments (class, G_d(n0), IRI per wheel and for the vehicle) per segment length,
    with the columns of ``roadpreview run --segments``."""
    rows = []
    for length in lengths_m:
        for seg in route.segments(length):
            row = {"recording": rid, "segment_length_m": length, "start_m": seg["start_m"], "end_m": seg["end_m"]}
            for end in ("start", "end"):
                pose = seg[end]
                row[f"x_{end}_m"], row[f"y_{end}_m"] = (pose[0], pose[1]) if pose else (None, None)
            for side in ("left", "right", "vehicle"):
                rough, iri = seg[side]["roughness"], seg[side]["iri"]
                cls = getattr(rough, "iso_class", None)
                row[f"class_{side}"] = cls
                row[f"gd_n0_m3_{side}"] = getattr(rough, "gd_n0", None) if cls else None
                row[f"iri_m_per_km_{side}"] = getattr(iri, "value", None)
                row[f"backed_fraction_{side}"] = seg[side]["backed_fraction"]
                row[f"class_reason_{side}"] = None if cls else getattr(rough, "reason", None)
                row[f"iri_reason_{side}"] = getattr(iri, "reason", None)
                row[f"iri_noise_m_per_km_{side}"] = getattr(iri, "noise", None)
            rows.append(row)
    return rows


def finish_recording(rid: str, out_dir: str, config: Optional[dict], lengths_m: Sequence[float],
                     geo_options: dict, *chunks_done) -> dict:
    """Summary and segment table of one recording from its Parquet parts (after all its chunks)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    route, summary = stitch(out_dir, rid, config)
    if summary.frames == 0:
        raise RuntimeError(f"{rid}: no per-frame results to summarise")
    rows = segment_rows(rid, route, lengths_m)
    if geo_options.get("origin") or geo_options.get("gnss"):
        from . import geo

        rows = geo.locate_segments(rows, read_frames(out_dir, rid, ("timestamp", "speed_mps")), **geo_options)
    summary = summary.to_dict()
    summary["segments"] = len(rows)
    folder = recording_dir(Path(out_dir), rid)
    table = pa.Table.from_pylist(rows, schema=SEGMENT_SCHEMA())
    _write_atomically(folder / "segments.parquet", lambda tmp: pq.write_table(table, tmp))
    _write_atomically(summary_path(Path(out_dir), rid),
                      lambda tmp: tmp.write_text(json.dumps(summary, indent=1, sort_keys=True) + "\n"))
    return summary


# ---------------------------------------------------------------------------------------------------------
# The driver: a Dask client, the task graph, progress, errors.

# Dask's housekeeping, made rarer for a batch's long single-threaded tasks. With the defaults (an event-loop tick
# every 20 ms, system and memory monitors every 0.5 s and 0.1 s, a statistical profiler sampling each worker every
# 10 ms) the scheduler's and nannies' event loop used 0.7 s of CPU per 40-task batch of 400 KITTI frames, and on a
# machine with as many workers as cores that time is taken from the workers (README, "Drives").
LOCAL_CLUSTER_CONFIG = {"distributed.admin.tick.interval": "500ms", "distributed.admin.system-monitor.interval": "5s",
                        "distributed.worker.memory.monitor-interval": "1s", "distributed.worker.profile.enabled": False}


def local_cluster(workers: int):
    """A LocalCluster of ``workers`` single-threaded worker processes with LOCAL_CLUSTER_CONFIG. The worker
    processes ignore SIGINT: a terminal's Ctrl-C reaches the whole process group, and each worker printed a
    KeyboardInterrupt traceback; the client (main) stops them."""
    import dask
    from distributed import LocalCluster

    with dask.config.set(LOCAL_CLUSTER_CONFIG), _sigint_ignored():  # the nannies hand both to their workers
        return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)


@contextlib.contextmanager
def _sigint_ignored():
    """SIGINT ignored meanwhile (in the main thread only: elsewhere signals cannot be set, nor arrive). A process
    started meanwhile keeps ignoring it (Python installs its KeyboardInterrupt handler only over the default)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, before)


def connect(workers: Optional[int], scheduler: Optional[str], timeout_s: float = 10.0):
    """A Dask client: to the scheduler at ``scheduler``, else a LocalCluster of ``workers`` single-threaded
    processes (default: one per core)."""
    from distributed import Client

    if scheduler:
        try:
            return Client(scheduler, timeout=f"{timeout_s}s")
        except (OSError, TimeoutError) as err:
            raise RuntimeError(f"{scheduler}: cannot reach the Dask scheduler ({err})") from None
    return Client(local_cluster(workers or os.cpu_count() or 1))


def _progress(total: int, quiet: bool):
    if quiet:
        return None
    from tqdm import tqdm

    return tqdm(total=total, unit="task", desc="roadpreview batch", file=sys.stderr)


def _record_failure(out: Path, rec: Recording, err: BaseException, report: dict) -> None:
    """One line of errors.jsonl for a recording that failed; the batch goes on with the others."""
    report["failed"].append(rec.id)
    line = {"recording": rec.id, "inputs": rec.inputs, "error": f"{type(err).__name__}: {err}",
            "time": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
    with open(out / "errors.jsonl", "a", encoding="utf-8") as f:
        f.write(json.dumps(line) + "\n")


def run_batch(inputs: Sequence[str], out_dir, *, workers: Optional[int] = None, scheduler: Optional[str] = None,
              client=None, resume: bool = False, chunk_frames: int = DEFAULT_CHUNK_FRAMES,
              overlap_frames: int = DEFAULT_OVERLAP_FRAMES, segment_lengths_m=SEGMENT_LENGTHS_M, quiet: bool = False,
              geo_options: Optional[dict] = None, **run_options) -> dict:
    """Runs every recording; returns {"done": [...], "skipped": [...], "failed": [...], "tasks_run": n}.

    run_options: those of :func:`roadpreview.drive.run` (``config`` as a dict, ``motion``, ``poses``,
    ``frame_rate``, source options, ``topic``). With ``resume``, parts and summaries already on disk are kept
    and only what is missing runs; without it, OUT_DIR must not hold an earlier batch.
    """
    out = Path(out_dir)
    geo_options = geo_options or {}
    source_options = {k: v for k, v in run_options.items()
                      if k not in ("config", "motion", "poses", "frame_rate", "motion_from")}
    _check_arguments(inputs, out, resume, run_options, source_options, geo_options, segment_lengths_m)
    if run_options.get("motion_from"):
        chunk_frames = 0  # odometry and a bag's motion topics read the whole recording: one task each
    options = batch_options(run_options, chunk_frames, overlap_frames, segment_lengths_m, geo_options)
    if resume:
        check_options(out, options)
    unreadable = []
    recordings = plan(inputs, chunk_frames, overlap_frames, source_options, unreadable)
    _prepare_out_dir(out, options, recordings, resume)
    report = {"done": [], "skipped": [], "failed": [], "tasks_run": 0}
    for rec, err in unreadable:
        _record_failure(out, rec, err, report)
    own_client = client is None
    if own_client:
        client = connect(workers, scheduler)
    try:
        _run_graph(client, recordings, out, resume, segment_lengths_m, geo_options, run_options, report, quiet)
    finally:
        if own_client:
            cluster = getattr(client, "cluster", None)
            client.close()
            if cluster is not None:
                cluster.close()
    for rid in report["failed"]:
        remove_failed_frames(out, rid)
    _write_tables(out)
    return report


def _check_arguments(inputs, out: Path, resume: bool, run_options: dict, source_options: dict, geo_options: dict,
                     segment_lengths_m) -> None:
    """The usage errors that the arguments alone show, refused before anything is read or written."""
    for length in segment_lengths_m:  # as `roadpreview run --segments` refuses them
        route_builder(run_options.get("config")).check_segment_length(length)
    check_origin_has_poses(geo_options, run_options)
    if not resume and (out / "frames").exists():
        raise ValueError(f"{out}: holds an earlier batch; give --resume to complete it or choose another -o")
    check_source_options(inputs, source_options)


def _prepare_out_dir(out: Path, options: dict, recordings: Sequence[Recording], resume: bool) -> None:
    """OUT_DIR with the batch's options and each recording's inputs bound, without what an earlier run of it
    left behind: its error lines (a batch's errors are those of its last run), its killed writers' files."""
    out.mkdir(parents=True, exist_ok=True)
    _write_atomically(out / "options.json", lambda tmp: tmp.write_text(json.dumps(options, indent=1) + "\n"))
    bind_inputs(out, recordings, resume)
    if resume:
        remove_stale_temporaries(out)
    (out / "errors.jsonl").unlink(missing_ok=True)


def check_origin_has_poses(geo_options: dict, run_options: dict) -> None:
    """--origin places the frames' poses on the map: refused before any work when no option gives poses (--poses,
    or --motion-from lidar, whose odometry does; a bag's motion topics give none)."""
    if geo_options.get("origin") and not run_options.get("poses") and run_options.get("motion_from") != "lidar":
        raise ValueError(f"--origin {','.join(f'{v:g}' for v in geo_options['origin'])} places poses on the map, and "
                         "no option gives the frames poses: give --poses or --motion-from lidar, or a --gnss file")


def remove_failed_frames(out: Path, rid: str) -> None:
    """Removes the per-frame parts of a recording that failed (after all its tasks ended), so that the frames/
    dataset holds only recordings with a summary; --resume runs it again from its start. A recording finished by
    an earlier batch keeps its frames."""
    if not summary_path(out, rid).exists():
        shutil.rmtree(out / "frames" / f"recording={rid}", ignore_errors=True)


def remove_stale_temporaries(out: Path) -> None:
    """Removes what _write_atomically's writers left when killed (``.NAME.PID.tmp``): on --resume no task of
    this batch has started yet, so none of them is being written."""
    for tmp in out.rglob(".*.tmp"):
        if re.fullmatch(r"\..+\.\d+\.tmp", tmp.name):
            tmp.unlink(missing_ok=True)


def needs_mounting(run_options: dict, chunks: Sequence[Chunk]) -> bool:
    """Whether chunks to run start past frame 0 of a recording whose mounting the runner is to estimate."""
    config = run_options.get("config") or {}
    given = config.get("sensor_height") is not None or config.get("extrinsics") is not None
    return not given and any(c.first > 0 for c in chunks)


def _run_graph(client, recordings, out, resume, lengths, geo_options, run_options, report, quiet) -> None:
    from distributed import as_completed

    finishes, chunk_futures = {}, []
    for rec in recordings:
        if resume and summary_path(out, rec.id).exists() and all(part_path(out, rec.id, c).exists()
                                                                  for c in rec.chunks):
            report["skipped"].append(rec.id)
            continue
        deps = []
        missing = [c for c in rec.chunks if not (resume and part_path(out, rec.id, c).exists())]
        mounting = None
        if needs_mounting(run_options, missing):
            mounting = client.submit(find_mounting, rec.inputs, run_options, max(c.first for c in rec.chunks),
                                     pure=False, key=f"mounting-{rec.id}")
        for chunk in missing:
            f = client.submit(process_chunk, rec.id, rec.inputs, chunk, run_options, str(out),
                              mounting if chunk.first > 0 else None, pure=False, key=f"chunk-{rec.id}-{chunk.index}")
            deps.append(f)
            chunk_futures.append(f)
        finish = client.submit(finish_recording, rec.id, str(out), run_options.get("config"), tuple(lengths),
                               geo_options, *deps, pure=False, key=f"finish-{rec.id}")
        finishes[finish.key] = (rec, finish)
    bar = _progress(len(chunk_futures) + len(finishes), quiet)
    try:
        for future in as_completed(chunk_futures + [f for _, f in finishes.values()]):
            report["tasks_run"] += 1
            if bar is not None:
                bar.update(1)
            if future.key not in finishes:
                continue
            rec, _ = finishes[future.key]
            err = future.exception()
            if err is None:
                report["done"].append(rec.id)
            else:
                _record_failure(out, rec, err, report)
                if bar is not None:
                    bar.write(f"roadpreview batch: {rec.id}: {err}", file=sys.stderr)
    finally:
        if bar is not None:
            bar.close()


def _write_tables(out: Path) -> None:
    """summary.csv and segments.parquet over every finished recording in OUT_DIR."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    summaries = [json.loads(p.read_text()) for p in sorted((out / "recordings").glob("*/summary.json"))]
    lines = ["recording,frames,vehicle_classes,vehicle_iri_median_m_per_km,segments"]
    for s in summaries:
        classes = " ".join(f"{k}x{v}" for k, v in s["vehicle_classes"].items())
        iri = "" if s["vehicle_iri_median_m_per_km"] is None else f"{s['vehicle_iri_median_m_per_km']:.3f}"
        lines.append(f"{s['recording']},{s['frames']},{classes},{iri},{s['segments']}")
    _write_atomically(out / "summary.csv", lambda tmp: tmp.write_text("\n".join(lines) + "\n"))
    # one recording's segments at a time: memory stays flat with 10⁴ recordings
    paths = [out / "recordings" / s["recording"] / "segments.parquet" for s in summaries]
    with_map = False

    def combine(tmp):
        nonlocal with_map
        with pq.ParquetWriter(tmp, SEGMENT_SCHEMA()) as writer:
            for path in paths:
                table = pq.read_table(path, schema=SEGMENT_SCHEMA())
                with_map = with_map or table.column("lat_start").null_count < table.num_rows
                writer.write_table(table)

    _write_atomically(out / "segments.parquet", combine)
    if with_map:
        import pyarrow.compute as pc

        from . import geo

        table = pq.read_table(out / "segments.parquet")
        geo.write_geo(table.filter(pc.is_valid(table.column("lat_start"))), str(out))


# ---------------------------------------------------------------------------------------------------------
# Command line.

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
    p = argparse.ArgumentParser(prog="roadpreview batch", description=__doc__.split("\n\n")[0])
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
    from .config import Config, Extrinsics

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


if __name__ == "__main__":
    sys.exit(main())
