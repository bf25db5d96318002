# SPDX-License-Identifier: BSD-3-Clause
"""The per-frame Parquet parts (OUT_DIR/frames/recording=ID/part-NNNNN.parquet): their columns, one row per
frame's Result, and reading them back."""

from __future__ import annotations

from pathlib import Path
from typing import Optional, Sequence


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
