# SPDX-License-Identifier: BSD-3-Clause
"""What --resume binds a batch to: the options its results depend on (OUT_DIR/options.json) and the inputs each
recording id was made from (recordings/ID/inputs.json). A resume given others is refused, naming them."""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Sequence

import numpy as np

from .. import drive
from .out_dir import recording_dir, write_atomically
from .planning import Recording

FILE_OPTIONS = ("motion", "poses", "meta", "calibration", "beam_calibration", "gnss")


def batch_options(run_options: dict, chunk_frames: int, overlap_frames: int, segment_lengths_m: Sequence[float],
                  geo_options: dict) -> dict:
    """What a batch's results depend on, one flat mapping as OUT_DIR/options.json keeps it ("config.sensor_height",
    "motion", "segment_lengths_m", ...): the config in full (defaults filled in), the motion, poses and source
    options, the frame ranges (they decide what each part holds), the segment lengths and the map's options. Not
    the workers, the scheduler or the progress bar: they change no result."""
    from ..config import Config

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
        write_atomically(path, lambda tmp: tmp.write_text(json.dumps(given) + "\n"))
