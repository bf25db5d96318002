# SPDX-License-Identifier: BSD-3-Clause
"""The chunk task a Dask worker runs: frames [first, last) of one recording through the runner (with the motion
taken from the recording, or the mounting the whole recording's run found), streamed into its Parquet part."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Optional

from .. import drive
from .frames import FRAME_SCHEMA, frame_row
from .mounting import mounted_config, with_mounting_source
from .out_dir import part_path, recording_dir, write_atomically
from .planning import Chunk

ROW_GROUP_FRAMES = 128  # a Parquet row group holds at most this many frames,
ROW_GROUP_BYTES = 2 << 20  # or this many bytes of output lines (a KITTI HDL-64E frame's line is ~59 kB: 36 frames)


def process_chunk(rid: str, inputs: list[str], chunk: Chunk, run_options: dict, out_dir: str,
                  mounting: Optional[dict] = None) -> dict:
    """Runs frames [first, last) of one recording and writes the kept frames to their Parquet part. ``mounting``:
    what :func:`find_mounting` found, used when the chunk starts after the frame that gave it."""
    from ..config import Config

    opts = dict(run_options)
    config = opts.pop("config", None)
    cfg = Config.from_dict(config) if config is not None else None
    mounting_source = None
    if mounting is not None and chunk.first > mounting["frame"]:
        cfg, mounting_source = mounted_config(cfg, mounting), mounting["source"]
    motion_from = opts.pop("motion_from", None)
    if motion_from:
        opts["motion"], opts["poses"] = _motion_from(motion_from, rid, inputs, cfg, opts, out_dir)
    if isinstance(opts.get("poses"), (str, os.PathLike)):
        opts["poses"] = drive.read_kitti_poses(opts["poses"])
    poses = opts.get("poses")
    path = part_path(Path(out_dir), rid, chunk)
    written = write_atomically(path, lambda tmp: _write_frames(tmp, inputs, cfg, chunk, opts, poses,
                                                               mounting_source))
    if not written and chunk.index == 0:
        path.unlink()
        raise RuntimeError(f"{inputs[0]}: no frames in this recording")
    return {"recording": rid, "chunk": chunk.index, "frames": written, "path": str(path)}


def _motion_from(kind: str, rid: str, inputs: list[str], cfg, opts: dict, out_dir: str):
    """(motion, poses) of a recording from its own data: KISS-ICP odometry (written beside its summary as a
    KITTI poses file and a motion CSV), or the bag's Odometry / Imu topic."""
    source_options = {k: v for k, v in opts.items() if k not in ("motion", "poses", "frame_rate")}
    if kind == "bag":
        from .. import io_bags

        speed = opts["motion"][0] if isinstance(opts.get("motion"), tuple) else None
        return io_bags.motion_table(inputs, speed_mps=speed), None
    from .. import odometry

    odo = odometry.estimate(inputs, cfg, frame_rate=opts.get("frame_rate") or 10.0, **source_options)
    folder = recording_dir(Path(out_dir), rid)
    folder.mkdir(parents=True, exist_ok=True)
    odo.write(str(folder / "odometry.poses.txt"), str(folder / "odometry.motion.csv"))
    return odo.motion_table(f"{inputs[0]}: lidar odometry"), odo.planar()


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
