# SPDX-License-Identifier: BSD-3-Clause
"""The readout (docs/method.md §10, "Readout"): each wheel's profile read a fixed distance ahead and kept in an
array along the drive, as the moving-average paper builds its road profile.

Works on output lines (``Result.to_dict()`` or parsed lines of the CLI's JSONL), so it can check the C++
``ProfileReadout`` behind ``roadpreview run --read-ahead-m`` from the same run's output.
"""

from __future__ import annotations

import math

import numpy as np

from ..config import Config
from .route import DriveDistance, _arc_scale, _values


class Readout:
    """Feed output lines in drive order with :meth:`add`; :meth:`wheel` gives the array relative to the wheel."""

    def __init__(self, ahead_m: float, cfg: Config | None = None):
        self.cfg = cfg or Config()
        if not (math.isfinite(ahead_m) and 0 < ahead_m < self.cfg.profile.preview_length_m):
            raise ValueError(f"readout: the distance ahead must be a positive number of metres within the profiles "
                             f"(profile.preview_length_m {self.cfg.profile.preview_length_m} m), got {ahead_m}")
        self.ahead_m = ahead_m
        self._drive = DriveDistance(self.cfg, "readout")
        self._bins = {"left": {}, "right": {}}  # drive bin → (z, count)
        self._scale = {"left": 1.0, "right": 1.0}

    @property
    def distance(self) -> float:
        return self._drive.distance

    def add(self, line: dict, pose=None) -> None:
        wheels = self._drive.placeable_wheels(line)
        self._drive.advance(line, pose)
        ds = self.cfg.profile.ds_m
        for wheel, bins in self._bins.items():
            for j in [j for j in bins if (j + 1) * ds <= self.distance]:  # passed by the wheel
                del bins[j]
            if wheel not in wheels:
                continue
            self._scale[wheel] = _arc_scale(line, wheel)
            s, z = _values(line["profiles"][wheel]["s"]), _values(line["profiles"][wheel]["z"])
            count = line["profiles"][wheel]["count"]
            if not len(s):
                continue
            last = s[0] + (len(s) - 1) * ds  # the bins are ds apart
            j = math.ceil((self.distance + self.ahead_m) / ds - 0.5)
            while ((j + 0.5) * ds - self.distance) / self._scale[wheel] <= last + 1e-9:
                ahead = (j + 0.5) * ds - self.distance
                value = _interpolate(s, z, count, ahead / self._scale[wheel], ds) if ahead >= self.ahead_m else None
                if value is not None:
                    bins[j] = value
                j += 1

    def wheel(self, wheel: str) -> dict:
        """``s`` (m along the wheel's current path), ``z`` (NaN where never read) and ``count`` per drive bin, from
        the wheel to ``ahead_m``."""
        ds, bins = self.cfg.profile.ds_m, self._bins[wheel]
        first = math.floor(self.distance / ds)
        js = [j for j in range(first, first + int(self.ahead_m / ds) + 2)
              if 0 <= (j + 0.5) * ds - self.distance < self.ahead_m]
        return {"s": np.array([((j + 0.5) * ds - self.distance) / self._scale[wheel] for j in js]),
                "z": np.array([bins.get(j, (np.nan, 0))[0] for j in js]),
                "count": np.array([bins.get(j, (np.nan, 0))[1] for j in js], dtype=np.int64)}


def _interpolate(s: np.ndarray, z: np.ndarray, count, at: float, ds: float):
    """(z, count) of the profile at arc length `at`: a bin's own where `at` is its centre, else the line between
    the two bins around it when both have a height (count of the nearer); None otherwise."""
    position = (at - s[0]) / ds
    k = math.floor(position + 1e-9)
    if not 0 <= k < len(z):
        return None
    t = max(0.0, position - k)
    if t < 1e-9:
        return (z[k], count[k]) if math.isfinite(z[k]) else None
    if k + 1 >= len(z) or not (math.isfinite(z[k]) and math.isfinite(z[k + 1])):
        return None
    return (1 - t) * z[k] + t * z[k + 1], count[k] if t < 0.5 else count[k + 1]
