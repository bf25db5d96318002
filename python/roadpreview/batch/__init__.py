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

The modules, by concern:

    planning.py    recordings, their ids and frame ranges (chunks); the checks of the inputs
    options.py     what --resume binds: options.json, and each recording's inputs
    out_dir.py     where each output lies in OUT_DIR; files written under a temporary name, then renamed
    chunks.py      the chunk task: a frame range through the runner into its Parquet part
    mounting.py    the mounting a split recording's later chunks take from a run of its first frames
    frames.py      the per-frame Parquet parts: columns, rows, reading them back
    summaries.py   the finish task (summary.json, segments.parquet) and the tables over all recordings
    cluster.py     the Dask client: an existing scheduler, or a LocalCluster
    driver.py      run_batch: the task graph, progress, errors
    cli.py         main: the command line
"""

# The package's names, as the single module batch.py had them. A constant is read where it lives: patch
# ROW_GROUP_FRAMES on roadpreview.batch.chunks, not here.
from .chunks import ROW_GROUP_BYTES, ROW_GROUP_FRAMES, process_chunk
from .cli import add_decoder_options, add_run_options, decoder_options_from, main, parser, run_options_from
from .cluster import LOCAL_CLUSTER_CONFIG, connect, local_cluster
from .driver import check_origin_has_poses, run_batch
from .frames import FRAME_SCHEMA, frame_row, frame_rows, read_frames
from .mounting import BASE_FRAME_NOTE, find_mounting, needs_mounting, with_mounting_source
from .options import FILE_OPTIONS, batch_options, bind_inputs, check_options
from .out_dir import part_path, recording_dir, remove_failed_frames, remove_stale_temporaries, summary_path
from .planning import (DEFAULT_CHUNK_FRAMES, DEFAULT_OVERLAP_FRAMES, SOURCE_OPTION_INPUTS, Chunk, Recording,
                       check_source_options, drive_files, frame_count, input_kind, plan, recording_id, sensor_of,
                       split)
from .summaries import (SEGMENT_LENGTHS_M, SEGMENT_SCHEMA, Summary, finish_recording, route_builder, segment_rows,
                        stitch, write_tables)

