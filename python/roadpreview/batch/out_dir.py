# SPDX-License-Identifier: BSD-3-Clause
"""Where each output of a batch lies in OUT_DIR, and how it is written: under a temporary name, then renamed, so
that a killed writer leaves nothing half-written (and --resume removes what it left)."""

from __future__ import annotations

import os
import re
import shutil
from pathlib import Path

from .planning import Chunk


def part_path(out_dir: Path, rid: str, chunk: Chunk) -> Path:
    return out_dir / "frames" / f"recording={rid}" / f"part-{chunk.index:05d}.parquet"


def recording_dir(out_dir: Path, rid: str) -> Path:
    return out_dir / "recordings" / rid


def summary_path(out_dir: Path, rid: str) -> Path:
    return recording_dir(out_dir, rid) / "summary.json"


def write_atomically(path: Path, write):
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


def remove_failed_frames(out: Path, rid: str) -> None:
    """Removes the per-frame parts of a recording that failed (after all its tasks ended), so that the frames/
    dataset holds only recordings with a summary; --resume runs it again from its start. A recording finished by
    an earlier batch keeps its frames."""
    if not summary_path(out, rid).exists():
        shutil.rmtree(out / "frames" / f"recording={rid}", ignore_errors=True)


def remove_stale_temporaries(out: Path) -> None:
    """Removes what write_atomically's writers left when killed (``.NAME.PID.tmp``): on --resume no task of
    this batch has started yet, so none of them is being written."""
    for tmp in out.rglob(".*.tmp"):
        if re.fullmatch(r"\..+\.\d+\.tmp", tmp.name):
            tmp.unlink(missing_ok=True)
