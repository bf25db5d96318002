# SPDX-License-Identifier: BSD-3-Clause
"""The driver: checks the arguments, plans the recordings, prepares OUT_DIR, submits the task graph (mounting,
chunks, one finish per recording) to the Dask client, follows its progress and records the recordings that
failed; then writes the tables over every finished recording."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from typing import Optional, Sequence

from .chunks import process_chunk
from .cluster import connect
from .mounting import find_mounting, needs_mounting
from .options import batch_options, bind_inputs, check_options
from .out_dir import part_path, remove_failed_frames, remove_stale_temporaries, summary_path, write_atomically
from .planning import DEFAULT_CHUNK_FRAMES, DEFAULT_OVERLAP_FRAMES, Recording, check_source_options, plan
from .summaries import SEGMENT_LENGTHS_M, finish_recording, route_builder, write_tables


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
    write_tables(out)
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
    write_atomically(out / "options.json", lambda tmp: tmp.write_text(json.dumps(options, indent=1) + "\n"))
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
