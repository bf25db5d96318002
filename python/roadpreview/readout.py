# SPDX-License-Identifier: BSD-3-Clause
"""The readout: each wheel's profile read a fixed distance ahead and kept in an array along the drive (the
moving-average paper's road profile; docs/method.md §10, "Readout")."""

from __future__ import annotations

from typing import Optional

from ._native import core
from .config import Config


class ProfileReadout(core().ProfileReadout):
    """``ProfileReadout(6.0, config)``; ``add(result, pose=None)`` each frame's result in drive order (pose: x, y,
    yaw when the drive has poses), then ``left`` / ``right`` (``s``, ``z``, ``count``: the bins from the wheel to
    ``ahead_m``, each as read ``ahead_m`` or more ahead), ``distance_m``, ``frames``. ``roadpreview run
    --read-ahead-m`` writes the same into each line's ``readout``."""

    def __init__(self, ahead_m: float, config: Optional[Config] = None):
        super().__init__((config or Config()).to_json(), float(ahead_m))
