# SPDX-License-Identifier: BSD-3-Clause
"""Summaries and segment tables: the task that stitches one recording's parts into its summary.json and
segments.parquet (after all its chunks), and the tables over every finished recording (summary.csv,
segments.parquet, the map)."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from .frames import frame_rows, read_frames
from .out_dir import recording_dir, summary_path, write_atomically

SEGMENT_LENGTHS_M = (10.0, 100.0)


def SEGMENT_SCHEMA():  # noqa: N802 (as frames.FRAME_SCHEMA)
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
    from .._native import core
    from ..config import Config

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
        from .. import geo

        rows = geo.locate_segments(rows, read_frames(out_dir, rid, ("timestamp", "speed_mps")), **geo_options)
    summary = summary.to_dict()
    summary["segments"] = len(rows)
    folder = recording_dir(Path(out_dir), rid)
    table = pa.Table.from_pylist(rows, schema=SEGMENT_SCHEMA())
    write_atomically(folder / "segments.parquet", lambda tmp: pq.write_table(table, tmp))
    write_atomically(summary_path(Path(out_dir), rid),
                     lambda tmp: tmp.write_text(json.dumps(summary, indent=1, sort_keys=True) + "\n"))
    return summary


def write_tables(out: Path) -> None:
    """summary.csv and segments.parquet over every finished recording in OUT_DIR."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    summaries = [json.loads(p.read_text()) for p in sorted((out / "recordings").glob("*/summary.json"))]
    lines = ["recording,frames,vehicle_classes,vehicle_iri_median_m_per_km,segments"]
    for s in summaries:
        classes = " ".join(f"{k}x{v}" for k, v in s["vehicle_classes"].items())
        iri = "" if s["vehicle_iri_median_m_per_km"] is None else f"{s['vehicle_iri_median_m_per_km']:.3f}"
        lines.append(f"{s['recording']},{s['frames']},{classes},{iri},{s['segments']}")
    write_atomically(out / "summary.csv", lambda tmp: tmp.write_text("\n".join(lines) + "\n"))
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

    write_atomically(out / "segments.parquet", combine)
    if with_map:
        import pyarrow.compute as pc

        from .. import geo

        table = pq.read_table(out / "segments.parquet")
        geo.write_geo(table.filter(pc.is_valid(table.column("lat_start"))), str(out))
