# SPDX-License-Identifier: BSD-3-Clause
"""Planning a batch: one Recording per input, its id, and the frame ranges (Chunks) its tasks run; the checks
that refuse a batch before anything runs (missing inputs, mixed sensors, source options given with inputs they do
not apply to)."""

from __future__ import annotations

import os
import re
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional, Sequence

from .. import drive

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
    from .. import io as rp_io

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
    from .. import io as rp_io

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
