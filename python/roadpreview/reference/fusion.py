"""Temporal fusion (docs/method.md §7), simple version: an unbounded, non-scrolling map of the same cells.

The C++ map is a window over this same grid of cells (i, j) = (floor(x/cell), floor(y/cell)) in the
odometry frame; while the vehicle stays within half the map's side of where cells were seen, both hold the
same values.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..config import Config
from .frames import check_points, to_base_frame
from .ground import NO_GROUND, ground_model, roi_facing
from .iri import vehicle_iri, wheel_iri
from .path import check_motion, finite_number, plan_path, wheel_y
from .point_errors import point_errors
from .profile import Profile, bin_count, fill_gaps, level_points, levelling_rotation, local_ground_model
from .roughness import analyze_roughness, vehicle_from_wheels, vehicle_roughness
from .stereo import groups_per_bin
from .support import pooled_variances

_MEDIAN_VARIANCE_FACTOR = math.pi / 2  # Var(median of n Gaussians) ≈ (π/2)σ²/n
_MIN_VARIANCE = 1e-12
_MIN_ALIGN_CELLS = 10  # fewer cells shared with the map leave the frame as it is
_MIN_EXCESS_CELLS = 200  # lane cells that measure the excess alone (a variance from n cells: ±√(2/n))
_MAD_TO_SIGMA = 1.4826  # σ of a Gaussian from its median absolute deviation
_OUTLIER_SIGMAS = 3.0  # cells farther than this from the alignment plane are outliers
# A single point's variance is pooled over its 5 m band of range (its height error shrinks with range), from the
# band's cells spread at most 4 × its typical spread, no more than a nearer band's (a wall's foot is no road noise,
# and far out may be most of a band's cells of several points; 3 × would cut honest pairs), when
# 10 cells at least stand behind it (beyond 20 m the few cells of several points are mostly kerb faces).
_POOL_BAND_M, _POOL_MAX_SPREAD, _MIN_POOL_CELLS = 5.0, 4.0, 10


def integrate_motion(pose, speed: float, yaw_rate: float, dt: float) -> tuple[float, float, float]:
    """(x, y, yaw) after dt seconds at constant speed and yaw rate: an arc, or a line when ω·dt = 0."""
    x, y, yaw = pose
    turn = yaw_rate * dt
    if turn == 0:
        return x + speed * dt * math.cos(yaw), y + speed * dt * math.sin(yaw), yaw
    radius = speed / yaw_rate
    return x + radius * (math.sin(yaw + turn) - math.sin(yaw)), y + radius * (math.cos(yaw) - math.cos(yaw + turn)), \
        yaw + turn


def check_timestamp_pose(timestamp, pose) -> tuple[Optional[float], Optional[tuple]]:
    """(timestamp, pose) as a float and a tuple of three floats (None passes); a non-number timestamp is a
    TypeError, a timestamp that is not finite or a pose that is not three finite numbers a ValueError."""
    if timestamp is not None:
        timestamp = finite_number(timestamp, "timestamp", TypeError)
    if pose is not None:
        try:
            values = tuple(float(v) for v in pose)
        except (TypeError, ValueError):
            raise ValueError(f"pose must be (x, y, yaw), three finite numbers, got {pose!r:.60}") from None
        if len(values) != 3 or not all(math.isfinite(v) for v in values):
            raise ValueError(f"pose must be (x, y, yaw), three finite numbers, got {values}")
        pose = values
    return timestamp, pose


@dataclass
class Cell:
    height: float
    variance: float
    observations: int
    points: int
    last_update: int


def fuse_cell(cell: Optional[Cell], z: float, r: float, points: int, frame: int, cfg: Config) -> Cell:
    if cell is None:
        return Cell(z, r, 1, points, frame)
    if cfg.fusion.method == "ema":
        a = cfg.fusion.alpha
        height, variance = a * z + (1 - a) * cell.height, a * a * r + (1 - a) ** 2 * cell.variance
    else:  # kalman
        gain = cell.variance / (cell.variance + r)
        height, variance = cell.height + gain * (z - cell.height), cell.variance * r / (cell.variance + r)
    return Cell(height, variance, cell.observations + 1, cell.points + points, frame)


def spread_for_variance(v: float, count: int) -> float:
    """The spread whose bin variance in the roughness stage ((π/2)s²/n; s²/2 for two points, s² for one) is v."""
    if count >= 3:
        return math.sqrt(v * count / _MEDIAN_VARIANCE_FACTOR)
    return math.sqrt(2 * v if count == 2 else v)


def path_point(path: dict, wheel: str, s: float, offset: float, speed: float, yaw_rate: float, cfg: Config):
    """Base-frame (x, y) of the point `offset` across (radially outward on an arc) from the wheel's path at s."""
    y_w = wheel_y(wheel, cfg)
    if path["status"] == "straight":
        return math.copysign(1.0, speed) * s, y_w + offset
    r_w = path[f"{wheel}_radius"]
    if r_w <= 0:
        return None
    phi = math.copysign(1.0, yaw_rate) * s / r_w
    u = (y_w - path["icr_y"]) / r_w
    return -math.sin(phi) * u * (r_w + offset), path["icr_y"] + math.cos(phi) * u * (r_w + offset)


@dataclass
class FusedMap:
    """The map, the pose (x, y, yaw) and the clock of one fusing estimator."""

    cfg: Config
    cells: dict = field(default_factory=dict)
    pose: tuple = (0.0, 0.0, 0.0)
    last_time: Optional[float] = None
    frame: int = 0
    fused: int = 0
    started: bool = False
    map_has_excess: bool = False  #: the map's variances carry an excess disagreement (an alignment has run)
    #: The last fused frame's local ground model and what takes a map height into that frame: (model, the frame's
    #: pose, its alignment plane (offset, x slope, y slope about the vehicle), its levelling rotation); None: the
    #: profiles read the map's heights.
    readout_ground: Optional[tuple] = None
    #: The cell of the pose at the last frame (the map's window is centred there; the origin's before any frame).
    pose_cell: tuple = (0, 0)

    def reset(self):
        self.cells, self.pose, self.last_time, self.fused, self.started = {}, (0.0, 0.0, 0.0), None, 0, False
        self.map_has_excess = False
        self.readout_ground = None

    def advance(self, speed, yaw_rate, timestamp=None, pose=None) -> Optional[str]:
        """Moves to this frame's pose; returns why the map was reset, if it was. A timestamp or pose that is not
        finite is a ValueError that leaves the map as it was."""
        timestamp, pose = check_timestamp_pose(timestamp, pose)  # before any change: a NaN would stay for good
        dt = 1.0 / self.cfg.fusion.frame_rate_hz if self.started else 0.0
        reset = None
        if timestamp is not None and self.last_time is not None:
            dt = timestamp - self.last_time
            if dt < 0:
                reset = f"time went back by {-dt:.3f} s" if -dt >= 5e-4 else f"time went back by {-dt:.3g} s"
            elif dt > self.cfg.fusion.max_time_gap_s:
                reset = f"time gap of {dt:.3f} s"
            if reset:
                self.reset()
                dt = 0.0
        self.last_time = timestamp  # dt is t − t_prev of consecutive frames, both timestamped
        if pose is not None:
            self.pose = pose
        elif self.started:
            self.pose = integrate_motion(self.pose, speed, yaw_rate, dt)
        self.started = True
        self.frame += 1
        # The map is a window `map_length_m` wide about the pose: a jump of the pose by as much clears it.
        cell, side = self.cfg.fusion.cell_m, math.ceil(self.cfg.fusion.map_length_m / self.cfg.fusion.cell_m - 1e-9)
        pose_cell = (math.floor(self.pose[0] / cell), math.floor(self.pose[1] / cell))
        beyond = any(abs(a - b) >= side for a, b in zip(pose_cell, self.pose_cell))
        self.pose_cell = pose_cell
        if beyond and self.fused:
            self.cells, self.fused, self.map_has_excess, self.readout_ground = {}, 0, False, None
            reset = "moved beyond the map"
        return reset

    def to_odometry(self, xy: np.ndarray) -> np.ndarray:
        x0, y0, yaw = self.pose
        c, s = math.cos(yaw), math.sin(yaw)
        return np.column_stack([x0 + c * xy[:, 0] - s * xy[:, 1], y0 + s * xy[:, 0] + c * xy[:, 1]])

    def fuse(self, levelled_ground: np.ndarray, variances=None, error_groups=None, ground=None, rotation=None):
        """Median per cell of the frame's levelled ground points, fused into the map. The points' height
        ``variances`` (m²), when given, raise each cell's spread to the root of their mean, and with their
        ``error_groups`` a cell's median counts as one measurement per distinct group (method.md §12). With
        ``ground``, the frame's LocalGround, and ``rotation``, the levelling that took the points to levelled, the
        profiles are read as heights above that model (method.md §7) until a frame is fused without one."""
        cell = self.cfg.fusion.cell_m
        ij = np.floor(self.to_odometry(levelled_ground[:, :2]) / cell).astype(np.int64)
        keys, inverse, counts = np.unique(ij, axis=0, return_inverse=True, return_counts=True)
        heights = levelled_ground[np.argsort(inverse.ravel(), kind="stable"), 2]
        groups = np.split(heights, np.cumsum(counts)[:-1])
        spreads = np.array([np.std(z, ddof=1) if len(z) >= 2 else np.nan for z in groups])
        if variances is not None:
            mean_variance = np.bincount(inverse.ravel(), weights=variances, minlength=len(counts)) / counts
            spreads = np.sqrt(np.maximum(spreads ** 2, mean_variance))  # NaN stays NaN
            single = (counts == 1) & (mean_variance > 0)  # one point: the variance its sensor states
            spreads[single] = np.sqrt(mean_variance[single])
        # the median counts as one measurement per error group (per point without groups)
        measurements = counts if error_groups is None else groups_per_bin(inverse.ravel(), error_groups, len(counts))
        medians = np.array([np.median(z) for z in groups])
        # As the roughness stage rates a bin's median, with the pooled variance of a point in the cell's 5 m band of
        # range for single points, and as a floor under the cell's own spread (r weighs the cell in the Kalman gain).
        distance = np.hypot(*((keys + 0.5) * cell - np.array(self.pose[:2])).T)
        pooled = pooled_variances(counts, spreads, np.floor(distance / _POOL_BAND_M), _POOL_MAX_SPREAD, _MIN_POOL_CELLS)
        if pooled is None:  # no cell with two points: the configured noise of one point
            pooled = np.full(len(counts), self.cfg.fusion.point_noise_m ** 2)
        point = np.where(np.isnan(spreads), pooled, np.fmax(pooled, spreads ** 2))
        variances = np.where(measurements >= 3, _MEDIAN_VARIANCE_FACTOR / measurements, 1 / measurements) * point
        variances = np.maximum(variances, _MIN_VARIANCE)
        alignment = np.zeros(3)
        if self.cfg.fusion.align:
            medians, variances, alignment = self.align(keys, medians, variances)
        self.readout_ground = None if ground is None else (ground, self.pose, alignment, rotation)
        for key, z, m, r in zip(map(tuple, keys), groups, medians, variances):
            self.cells[key] = fuse_cell(self.cells.get(key), float(m), float(r), len(z), self.frame, self.cfg)
        self.fused += 1

    def align(self, keys: np.ndarray, medians: np.ndarray, variances: np.ndarray):
        """The frame's cell medians minus the plane of their differences to the map's heights, their variances
        plus the disagreement the variances missed (docs/method.md §7, step 3), and that plane (offset, x slope,
        y slope about the vehicle; zeros when too few cells are shared)."""
        offsets = (keys + 0.5) * self.cfg.fusion.cell_m - np.array(self.pose[:2])
        regressors = np.column_stack([np.ones(len(keys)), offsets])
        shared = np.flatnonzero([tuple(k) in self.cells for k in keys])
        if len(shared) < _MIN_ALIGN_CELLS:
            return medians, variances, np.zeros(3)
        cells = [self.cells[tuple(k)] for k in keys[shared]]
        v = regressors[shared]
        difference = medians[shared] - np.array([c.height for c in cells])
        total = variances[shared] + np.maximum([c.variance for c in cells], _MIN_VARIANCE)
        prior = np.diag([0.0, 1.0, 1.0]) / self.cfg.fusion.align_tilt_sigma ** 2

        def fit(use):
            return np.linalg.solve(v[use].T @ (v[use] / total[use, None]) + prior,
                                   v[use].T @ (difference[use] / total[use]))

        # Outliers (a wall's foot, a moving object) are judged against the median difference, not a plane they tilt.
        deviation = np.abs(difference - np.median(difference))
        scale = _MAD_TO_SIGMA * np.median(deviation)
        inlier = deviation <= _OUTLIER_SIGMAS * np.maximum(scale, np.sqrt(total))
        if inlier.sum() < _MIN_ALIGN_CELLS:
            inlier[:] = True
        plane = fit(inlier)
        variances = variances.copy()
        variances[shared[~inlier]] += (difference[~inlier] - v[~inlier] @ plane) ** 2
        # The disagreement left beyond the variances is error common to every frame that no cell's spread sees,
        # the same at every range on real recordings: its weighted mean joins every cell of the frame; the first
        # time, the map's cells (from frames never compared) take half of it.
        # Measured in the lane ahead, where the profiles are read (not on the verges), when it holds enough cells
        # for a ±10 % estimate of a variance (√(2/n)); a sparse sensor's lane holds a few rings' cells.
        c, s = math.cos(self.pose[2]), math.sin(self.pose[2])
        lane = inlier & (np.abs(-s * offsets[shared, 0] + c * offsets[shared, 1])
                         <= self.cfg.fusion.align_excess_half_width_m)
        use = lane if lane.sum() >= _MIN_EXCESS_CELLS else inlier
        residual = difference[use] - v[use] @ plane
        weights = 1 / total[use] ** 2
        excess = max(0.0, float(np.sum(weights * (residual ** 2 - total[use])) / np.sum(weights)))
        if not self.map_has_excess:
            excess /= 2
            for cell in self.cells.values():
                cell.variance += excess
            self.map_has_excess = True
        return medians - regressors @ plane, variances + excess, plane

    def profile(self, path: dict, wheel: str, speed: float, yaw_rate: float, blocked=None) -> tuple[Profile, int, int]:
        """(profile, bins ahead with data, of them bins seen this frame) sampled from the map (method.md §7)."""
        cfg = self.cfg
        ds, cell, tire = cfg.profile.ds_m, cfg.fusion.cell_m, cfg.tire_width
        behind = math.ceil(cfg.fusion.behind_m / ds - 1e-9)
        bins = behind + bin_count(cfg)
        lanes = max(1, round(tire / cell))
        offsets = [(lane + 0.5) * tire / lanes - tire / 2 for lane in range(lanes)]
        s = (np.arange(bins) + 0.5 - behind) * ds
        z, spread = np.full(bins, np.nan), np.full(bins, np.nan)
        count = np.zeros(bins, dtype=np.int64)
        flags = np.zeros(bins, dtype=bool)
        if blocked is not None:
            flags[behind:] = np.asarray(blocked, dtype=bool)
        ahead = ahead_now = 0
        for k in range(bins):
            found = [self._cell_at(path, wheel, s[k], o, speed, yaw_rate) for o in offsets]
            found = [(odom, c) for odom, c in found if c is not None]
            heights = [self._height(odom, c.height) for odom, c in found]
            found = [c for _, c in found]
            if not found:
                continue
            count[k] = sum(c.points for c in found)
            if k >= behind:
                ahead += 1
                ahead_now += any(c.last_update == self.frame for c in found)
            if flags[k]:
                continue
            z[k] = sum(heights) / len(found)
            spread[k] = spread_for_variance(sum(c.variance for c in found) / len(found) ** 2, count[k])
        z = fill_gaps(z, ds, cfg.profile.max_gap_m, flags)
        roughness = analyze_roughness(z, ds, cfg, count=count, spread=spread)
        roughness.iri = wheel_iri(z, count, ds, roughness.iso_class, cfg, spread)
        return Profile(s=s, z=z, count=count, spread=spread, roughness=roughness, blocked=flags), ahead, ahead_now

    def _cell_at(self, path, wheel, s, offset, speed, yaw_rate) -> tuple:
        """(odometry (x, y), the cell there or None)."""
        xy = path_point(path, wheel, s, offset, speed, yaw_rate, self.cfg)
        if xy is None:
            return None, None
        odom = self.to_odometry(np.array([xy]))[0]
        return odom, self.cells.get(tuple(np.floor(odom / self.cfg.fusion.cell_m).astype(np.int64)))

    def _height(self, odom, height: float) -> float:
        """A map height at odometry (x, y) as the profile reads it: above the last fused frame's local ground
        model, taken into that frame's datum (undoing its alignment), vehicle axes and base frame (method.md §7)."""
        if self.readout_ground is None:
            return height
        model, (x0, y0, yaw), alignment, rotation = self.readout_ground
        dx, dy = odom[0] - x0, odom[1] - y0
        c, s = math.cos(yaw), math.sin(yaw)
        levelled = np.array([c * dx + s * dy, -s * dx + c * dy, height + alignment @ [1.0, dx, dy]])
        return float(model.heights((levelled @ rotation)[None, :])[0])  # base frame: Lᵀ·levelled


@dataclass
class FusedResult:
    left: Profile
    right: Profile
    fusion: dict  #: method, frames, coverage, frame_coverage, reset, pose
    reason: Optional[str] = None
    vehicle: object = None


def process_fused(state: FusedMap, points, speed, yaw_rate, *, timestamp=None, pose=None,
                  range_variances=None, error_groups=None, beams=None) -> FusedResult:
    """One frame through the fusing pipeline without obstacles (cfg.obstacles is not consulted); with the points'
    ``range_variances`` (m², stereo) and ``error_groups`` as in method.md §12, ``beams`` as in §3."""
    cfg = state.cfg
    points = check_points(points)
    speed, yaw_rate = check_motion(speed, yaw_rate)
    path = plan_path(speed, yaw_rate, cfg)
    # Every input is checked before the map moves: a bad frame leaves the state as it was.
    base_xyz, finite = to_base_frame(points, cfg)
    variances, groups = point_errors(points, base_xyz, finite, cfg, range_variances, error_groups, beams)
    reset = state.advance(speed, yaw_rate, timestamp, pose)
    status = {"method": cfg.fusion.method, "frames": state.fused, "coverage": 0.0, "frame_coverage": 0.0,
              "reset": reset, "pose": state.pose}
    facing = roi_facing(cfg, speed) if path["status"] != "stopped" else cfg  # reversing looks behind
    model = ground_model(base_xyz, facing) if len(base_xyz) else None
    ground, plane = (model.mask, model.plane) if model else (None, None)
    if plane is not None and path["status"] != "stopped":
        xyz = base_xyz[ground]
        local = cfg.profile.level and cfg.profile.level_local
        local_model = local_ground_model(xyz, plane, cfg, path, math.copysign(1.0, speed)) if local else None
        state.fuse(level_points(xyz, plane) if cfg.profile.level else xyz,
                   None if variances is None else variances[ground], None if groups is None else groups[ground],
                   local_model, levelling_rotation(plane) if local else None)
    status["frames"] = state.fused
    # A map that holds data stands in for a frame without ground: the profiles are read from it.
    reason = "no finite points" if len(base_xyz) == 0 and not state.fused else \
        (model.reason if model else NO_GROUND) if plane is None and not state.fused else "vehicle stopped" if path["status"] == "stopped" else None
    if reason:
        return FusedResult(Profile(), Profile(), status, reason)
    (left, a_l, n_l), (right, a_r, n_r) = (state.profile(path, w, speed, yaw_rate) for w in ("left", "right"))
    status["coverage"] = (a_l + a_r) / (2 * bin_count(cfg))
    status["frame_coverage"] = (n_l + n_r) / (2 * bin_count(cfg))
    vehicle = vehicle_roughness(left.z, right.z, cfg.profile.ds_m, cfg, count_left=left.count,
                                spread_left=left.spread, count_right=right.count, spread_right=right.spread)
    vehicle = vehicle_from_wheels(vehicle, left.roughness, right.roughness)
    vehicle.iri = vehicle_iri(left.roughness.iri, right.roughness.iri)
    return FusedResult(left, right, status, None, vehicle)
