# SPDX-License-Identifier: BSD-3-Clause
"""Route outputs (docs/method.md §10): the frames' wheel-path profiles stitched along the drive, and its segments.

Works on output lines (``Result.to_dict()`` or parsed lines of the CLI's JSONL), so it can check the C++
``RouteBuilder`` behind ``roadpreview run --segments / --export-profile`` from the same run's output.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
import numpy as np

from ..config import Config
from .iri import Iri, noise_iri, rectified_slope, vehicle_iri
from .profile import fill_gaps
from .roughness import analyze_roughness, vehicle_from_wheels, vehicle_roughness

MIN_SHARED_BINS = 10  #: a frame is shifted onto the drive's profile only over at least this many shared bins
MAX_FRAME_STEP_M = 1000.0  #: a frame moves the drive on by at most this
MAX_DRIVE_PER_WHEEL_METRE = 100.0  #: a wheel with a larger q places nothing


@dataclass
class Stitched:
    """One wheel along the drive: bin j covers drive distance [j·ds, (j+1)·ds)."""

    ds: float
    z: np.ndarray  #: m, NaN where missing (interior gaps up to profile.max_gap_m filled)
    count: np.ndarray  #: points behind each bin over all frames
    spread: np.ndarray  #: m, NaN below two points
    frames: np.ndarray  #: frames that backed the bin
    blocked: np.ndarray  #: a frame saw an obstacle over the bin and no frame saw road there (z NaN, never filled)


@dataclass
class _Sums:
    weight: list = field(default_factory=list)
    weighted_z: list = field(default_factory=list)
    weighted_square: list = field(default_factory=list)
    count: list = field(default_factory=list)
    frames: list = field(default_factory=list)
    blocked: set = field(default_factory=set)  #: drive bins some frame's profile held blocked

    def grow(self, size: int) -> None:
        for values in (self.weight, self.weighted_z, self.weighted_square, self.count, self.frames):
            values.extend([0] * (size - len(values)))


def _arc_scale(line: dict, wheel: str) -> float:
    """Drive metres per metre of the wheel's arc length (q): |y_icr| / r_wheel on an arc, else 1."""
    path = line.get("path") or {}
    radius = path.get(f"{wheel}_radius")
    if path.get("icr_y") is None or radius is None or not radius > 0:
        return 1.0
    return abs(path["icr_y"]) / radius


def _values(items) -> np.ndarray:
    return np.array([np.nan if v is None else v for v in items], dtype=np.float64)


class DriveDistance:
    """The drive distance of §10, frame by frame: ``advance`` each line (and pose) in drive order."""

    def __init__(self, cfg: Config, who: str):
        self.cfg, self.who = cfg, who
        self.distance = 0.0
        self.frames = 0
        self._last_time = None
        self._last_pose = None

    def advance(self, line: dict, pose=None) -> None:
        step = 0.0
        if self.frames:
            if (pose is None) != (self._last_pose is None):
                raise ValueError(f"{self.who}: frame {self.frames}: poses must be given for every frame or for none")
            if pose is not None:
                step = math.hypot(pose[0] - self._last_pose[0], pose[1] - self._last_pose[1])
            else:
                dt = 1.0 / self.cfg.fusion.frame_rate_hz
                if line.get("timestamp") is not None and self._last_time is not None:
                    dt = line["timestamp"] - self._last_time
                if dt < 0:
                    raise ValueError(f"{self.who}: frame {self.frames} is {-dt} s before the previous frame")
                speed = line["motion"]["speed"]
                step = abs(math.nan if speed is None else speed) * dt
        if not step <= MAX_FRAME_STEP_M:
            raise ValueError(f"{self.who}: frame {self.frames} moves the drive on by {step} m: more than "
                             f"{MAX_FRAME_STEP_M} m per frame is no drive")
        self.distance += step
        self.frames += 1
        self._last_time, self._last_pose = line.get("timestamp"), pose

    def placeable_wheels(self, line: dict) -> list[str]:
        """The wheels whose profiles the next line places along the drive (§10): none for a line with a reason,
        not a wheel with q > 100; ValueError for a bin further from the wheel than the profiles reach, or a q that
        is no positive number."""
        return [] if line.get("reason") else [w for w in ("left", "right") if self._placeable(line, w)]

    def _placeable(self, line: dict, wheel: str) -> bool:
        reach = self.cfg.profile.preview_length_m + self.cfg.fusion.behind_m
        s = _values(line["profiles"][wheel]["s"])
        if not np.all(np.abs(s) <= reach):
            raise ValueError(f"{self.who}: frame {self.frames}: a profile bin lies beyond the profiles' reach "
                             f"({reach} m)")
        q = _arc_scale(line, wheel)
        if not 0 < q < math.inf:
            raise ValueError(f"{self.who}: frame {self.frames}: the path's centre of rotation and wheel radii give "
                             f"no distance along the drive")
        return q <= MAX_DRIVE_PER_WHEEL_METRE


class Route:
    """Feed output lines in drive order with :meth:`add`; read :meth:`stitched` and :meth:`segments`."""

    def __init__(self, cfg: Config | None = None):
        self.cfg = cfg or Config()
        self._drive = DriveDistance(self.cfg, "route")
        self._sums = {"left": _Sums(), "right": _Sums()}
        self._track = []  # (distance, (x, y, yaw)) per frame, with poses

    @property
    def distance(self) -> float:
        return self._drive.distance

    def add(self, line: dict, pose=None) -> None:
        wheels = self._drive.placeable_wheels(line)
        self._drive.advance(line, pose)
        if pose is not None:
            self._track.append((self.distance, tuple(pose)))
        for wheel in wheels:
            self._stitch(line["profiles"][wheel], _arc_scale(line, wheel), self._sums[wheel])

    def _stitch(self, profile: dict, scale: float, sums: _Sums) -> None:
        ds = self.cfg.profile.ds_m
        s, z, count, spread = (_values(profile[k]) for k in ("s", "z", "count", "spread"))
        drive = self.distance + s * scale
        blocked = profile.get("blocked")  # older lines lack it
        blocked = np.zeros(len(s), dtype=bool) if blocked is None else np.asarray(blocked, dtype=bool)
        sums.blocked.update(np.floor(drive[blocked & (drive >= 0)] / ds).astype(int).tolist())
        use = (count > 0) & np.isfinite(z) & (drive >= 0)
        bins = np.floor(drive[use] / ds).astype(int)
        z, count, spread = z[use], count[use], np.nan_to_num(spread[use], nan=0.0)
        sums.grow(int(bins.max()) + 1 if len(bins) else 0)
        weight = np.array(sums.weight, dtype=float)
        shared = weight[bins] > 0
        offset = 0.0
        if np.count_nonzero(shared) >= MIN_SHARED_BINS:
            mean = np.array(sums.weighted_z, dtype=float)[bins[shared]] / weight[bins[shared]]
            offset = float(np.median(z[shared] - mean))
        z = z - offset
        for j in np.unique(bins):
            here = bins == j
            c = count[here]
            sums.weight[j] += float(c.sum())
            sums.weighted_z[j] += float((c * z[here]).sum())
            sums.weighted_square[j] += float((c * (spread[here] ** 2 + z[here] ** 2)).sum())
            sums.count[j] += int(c.sum())
            sums.frames[j] += 1

    def stitched(self, wheel: str) -> Stitched:
        sums = self._sums[wheel]
        weight = np.array(sums.weight, dtype=float)
        count = np.array(sums.count, dtype=np.int64)
        with np.errstate(invalid="ignore", divide="ignore"):
            z = np.where(weight > 0, np.array(sums.weighted_z, dtype=float) / weight, np.nan)
            variance = np.maximum(np.array(sums.weighted_square, dtype=float) / weight - z**2, 0.0)
        spread = np.where(count >= 2, np.sqrt(variance), np.nan)
        # An obstacle one frame saw counts only where no frame saw road.
        blocked = np.isin(np.arange(len(z)), list(sums.blocked)) & ~(weight > 0)
        z = fill_gaps(z, self.cfg.profile.ds_m, self.cfg.profile.max_gap_m, blocked)
        return Stitched(self.cfg.profile.ds_m, z, count, spread, np.array(sums.frames, dtype=np.int64), blocked)

    def pose_at(self, distance: float):
        if not self._track:
            return None
        ds, poses = zip(*self._track)
        if distance <= ds[0]:
            return poses[0]
        for (d0, p0), (d1, p1) in zip(self._track, self._track[1:]):
            if distance <= d1:
                if d1 <= d0:
                    return p1
                t = (distance - d0) / (d1 - d0)
                dyaw = math.remainder(p1[2] - p0[2], 2 * math.pi)
                return (p0[0] + t * (p1[0] - p0[0]), p0[1] + t * (p1[1] - p0[1]), p0[2] + t * dyaw)
        return None  # the road ahead of the last frame: the drive was never there

    def segments(self, length_m: float) -> list[dict]:
        """One dict per segment [k·L, (k+1)·L) (the last may end short): start_m, end_m, start/end pose and,
        per side, roughness, iri and backed_fraction."""
        ds = self.cfg.profile.ds_m
        if not (length_m >= ds and math.isfinite(length_m)):  # a segment holds one bin or more
            raise ValueError(f"route: segment length must be a number of metres of at least one profile bin "
                             f"(profile.ds_m {ds} m), got {length_m}")
        wheels = {w: self.stitched(w) for w in ("left", "right")}
        bins = max(len(p.z) for p in wheels.values())
        slopes = {w: _slope_by_bin(p.z, ds) for w, p in wheels.items()}
        out = []
        k = 0
        while (j0 := round(k * length_m / ds)) < bins:
            j1 = min(bins, round((k + 1) * length_m / ds))
            row = {"length_m": length_m, "start_m": j0 * ds, "end_m": j1 * ds,
                   "start": self.pose_at(j0 * ds), "end": self.pose_at(j1 * ds)}
            parts = {w: _part(p, j0, j1) for w, p in wheels.items()}
            for w, (z, count, spread) in parts.items():
                row[w] = {"roughness": analyze_roughness(z, ds, self.cfg, count=count, spread=spread),
                          "iri": _segment_iri(slopes[w], j0, j1, ds, count, spread),
                          "backed_fraction": float(np.mean(count > 0))}
            (zl, cl, sl), (zr, cr, sr) = parts["left"], parts["right"]
            vehicle = vehicle_from_wheels(vehicle_roughness(zl, zr, ds, self.cfg, count_left=cl, spread_left=sl,
                                                            count_right=cr, spread_right=sr),
                                          row["left"]["roughness"], row["right"]["roughness"])
            row["vehicle"] = {"roughness": vehicle, "iri": vehicle_iri(row["left"]["iri"], row["right"]["iri"]),
                              "backed_fraction": (row["left"]["backed_fraction"] + row["right"]["backed_fraction"]) / 2}
            out.append(row)
            k += 1
        return out


def _part(p: Stitched, j0: int, j1: int):
    """(z, count, spread) of bins [j0, j1), missing beyond the profile's end (which may lie before j0)."""
    pad = (j1 - j0) - len(p.z[j0:j1])
    return (np.concatenate((p.z[j0:j1], np.full(pad, np.nan))),
            np.concatenate((p.count[j0:j1], np.zeros(pad, np.int64))),
            np.concatenate((p.spread[j0:j1], np.full(pad, np.nan))))


def _slope_by_bin(z: np.ndarray, ds: float) -> np.ndarray:
    """The golden car's rectified slope at the bin it has reached, over every valid stretch (NaN elsewhere)."""
    out = np.full(len(z), np.nan)
    valid = np.isfinite(z)
    j = 0
    while j < len(z):
        if not valid[j]:
            j += 1
            continue
        end = j
        while end < len(z) and valid[end]:
            end += 1
        rs = rectified_slope(z[j:end], ds)
        out[end - len(rs):end] = rs
        j = end
    return out


def _segment_iri(slope: np.ndarray, j0: int, j1: int, ds: float, count, spread) -> Iri:
    """The mean rectified slope over bins [j0, j1) when the car ran over all of them; its noise that of the segment's
    own bins (``count``, ``spread``) alone."""
    part = slope[j0:j1]
    if j1 <= j0:
        return Iri(reason="no valid profile")
    if len(part) < j1 - j0 or not np.isfinite(part).all():
        return Iri(reason="segment not covered by one valid stretch")
    return Iri(value=float(part.mean() * 1000.0), length=(j1 - j0) * ds, noise=noise_iri(count, spread, ds))

