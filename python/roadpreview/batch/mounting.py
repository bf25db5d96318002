# SPDX-License-Identifier: BSD-3-Clause
"""The mounting of a split recording: estimated once, by a run of the whole recording's first frames, for the
chunks that start after it, so that --chunk-frames changes no output line."""

from __future__ import annotations

from typing import Optional, Sequence

from .. import drive
from .planning import Chunk

# The runner's note when a frame's ground lies at the cloud's origin, level: the points are base-frame points already.
BASE_FRAME_NOTE = "lies at the cloud's origin ("


def find_mounting(inputs: list[str], run_options: dict, until: int) -> Optional[dict]:
    """The mounting a run of the whole recording settles on among frames [0, until), for the chunks that start
    after it: each chunk's runner would otherwise estimate its own from its first frame, and the lines would
    depend on --chunk-frames. {"frame": where it settled, "extrinsics": [x, y, z, roll, pitch, yaw], "source":
    "estimated"}, or "none" with zero extrinsics when the frame showed base-frame points; None when no frame before
    ``until`` settled it (every chunk then asks the same frames the whole run asks)."""
    import warnings

    from ..config import Config

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


def mounted_config(cfg, mounting: dict):
    """The config with the mounting a run of the whole recording found."""
    from ..config import Config, Extrinsics

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


def needs_mounting(run_options: dict, chunks: Sequence[Chunk]) -> bool:
    """Whether chunks to run start past frame 0 of a recording whose mounting the runner is to estimate."""
    config = run_options.get("config") or {}
    given = config.get("sensor_height") is not None or config.get("extrinsics") is not None
    return not given and any(c.first > 0 for c in chunks)
