"""Drives, not frames: ``rp.run`` turns a recording into per-frame results with the policy ``roadpreview run``
follows (the C++ ``DriveRunner``; docs/method.md, "Drives")."""

from __future__ import annotations

import os
from typing import Iterator, Optional, Sequence, Union

from ._native import core
from .config import Config

PathLike = Union[str, "os.PathLike[str]"]


class Drive:
    """Iterates a recording's results (``roadpreview.Result``), one frame at a time with constant memory.

    ``.notes``: what the run told the user so far (e.g. the mounting estimated from the first frame with ground;
    warnings are also issued as RuntimeWarning). ``.config``: the config in force (with an estimated mounting once
    a frame gave it). ``.frame``: the frame of the last result. ``.mounting_disagreements``: frames whose ground
    disagreed with the mounting (given, estimated, or none: base-frame points).
    """

    def __init__(self, source, runner, first_frame: int = 0, name: str = "the input"):
        self._source = source  # kept alive: the runner reads from it
        self._runner = runner
        self._first, self._name, self._results = first_frame, name, 0
        self.notes: list[str] = []
        self.frame = None

    def __iter__(self) -> Iterator:
        return self

    def __next__(self):
        step = self._runner.next(self.notes)
        if step is None:
            if self._results == 0 and self._first > 0:  # as `roadpreview run --frames A:B` says
                raise ValueError(f"{self._name}: no frames from index {self._first} on (the input has "
                                 f"{self.frames_read})")
            raise StopIteration
        self._results += 1
        self.frame, result = step
        return result

    @property
    def config(self) -> Config:
        import json

        return Config.from_dict(json.loads(self._runner.config_json))

    @property
    def mounting_disagreements(self) -> int:
        return self._runner.mounting_disagreements

    @property
    def frames_read(self) -> int:
        """Frames read from the recording so far, those skipped by ``frames`` included."""
        return self._runner.frames_read


def run(inputs: Union[PathLike, Sequence[PathLike], object], config: Optional[Config] = None, *,
        motion: Optional[Union[PathLike, object]] = None, poses: Optional[Union[PathLike, Sequence]] = None,
        speed: Optional[float] = None, yaw_rate: Optional[float] = None, frame_rate: float = 0.0,
        frames: Optional[tuple[int, Optional[int]]] = None, **source_options) -> Drive:
    """The results of a recording's frames, as ``roadpreview run`` computes them.

    inputs: what :func:`roadpreview.io.open` reads (pcaps, frame files, directories) or a ROS bag / MCAP file
    (``topic`` among ``source_options``), with ``source_options`` passed to the reader, or a source either (or
    ``rp.io.open_stereo``) returned. config: ``roadpreview.Config``.
    Motion per frame (m/s, rad/s): ``motion`` (a CSV t,speed,yaw_rate or an ``rp.drive.MotionTable``, looked up
    at each frame's time) wins over ``yaw_rate``, which wins over the recording's IMU, which wins over 0;
    ``speed`` is needed without ``motion``. ``poses``: one per frame, a KITTI poses file (moves the fusion map:
    needs ``config.fusion.method``) or a list of (x, y, yaw) (moves the map when there is one, else places the
    frames).
    ``frame_rate``: Hz, timestamps index / rate for frames without their own. ``frames``: (first, last) indices,
    last excluded (None: to the end); a first index past the input's end raises ValueError when iterated.
    Without ``sensor_height``/``extrinsics`` the first frame's ground gives the
    mounting. A file frame that does not continue the previous file's sequence resets the fusion map.
    Bad input raises ValueError (options) or RuntimeError naming the file.
    """
    from . import drive

    cfg = config if config is not None else Config()
    if not isinstance(cfg, Config):
        raise TypeError(f"config must be a roadpreview.Config, got {type(cfg).__name__}")
    first, last = frames if frames is not None else (0, None)
    source = inputs if drive.is_source(inputs) else drive.open_source(inputs, **source_options)
    in_memory = motion is not None and not isinstance(motion, (str, os.PathLike))
    if in_memory and not isinstance(motion, core().MotionTable):
        raise TypeError(f"motion must be a CSV path or an rp.drive.MotionTable, got {type(motion).__name__} "
                        "(a constant motion is speed= and yaw_rate=)")
    runner = core().DriveRunner(
        source, cfg.to_json(), speed_mps=None if speed is None else float(speed),
        yaw_rate_rps=None if yaw_rate is None else float(yaw_rate), motion_file="" if in_memory else _path(motion),
        motion=motion if in_memory else None, poses_file=_path(poses) if _is_path(poses) else "",
        poses=None if poses is None or _is_path(poses) else [tuple(map(float, p)) for p in poses],
        frame_rate_hz=float(frame_rate), first_frame=int(first), last_frame=2**63 - 1 if last is None else int(last))
    name = os.fspath(inputs) if _is_path(inputs) else "the input"
    return Drive(source, runner, int(first), name)


def _is_path(p) -> bool:
    return isinstance(p, (str, os.PathLike))


def _path(p: Optional[PathLike]) -> str:
    return os.fspath(p) if p is not None else ""
