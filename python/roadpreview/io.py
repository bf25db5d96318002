"""Reading frames from files (the C++ reader used by the CLI)."""

from __future__ import annotations

import os

import numpy as np

from ._native import core


def read(path: str | os.PathLike) -> np.ndarray:
    """Points of a KITTI ``.bin`` (float32 x, y, z, intensity) or ``.pcd`` file as an (N, 4) float32 array.

    Raises RuntimeError naming the file when it is missing, truncated or corrupt.
    """
    return core().read_frame(os.fspath(path))


def expand(inputs: list[str]) -> list[str]:
    """Files of the given files and directories (directories sorted by name), as the CLI sees them."""
    return core().expand_inputs([os.fspath(p) for p in inputs])
