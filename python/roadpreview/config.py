"""Pipeline configuration: one dataclass per stage, nested in :class:`Config`.

Field names carry their units (``_m`` metres, ``_mps`` m/s, ``_cpm`` cycles/m, ``_deg`` degrees); the
vehicle geometry at the top level (``sensor_height``, ``track_width``, ``tire_width``) is in metres.
The same names are used by the C++ ``roadpreview::Config``, the CLI's ``--config`` JSON file and
``docs/method.md``; ``Config.to_dict()`` is exactly what the C++ side parses.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional


class _Fields:
    """Setting a name that is not one of the dataclass's fields is an error: `cfg.sensor_hieght = 2` would
    otherwise be kept beside the real field and ignored."""

    def __setattr__(self, name: str, value: Any) -> None:
        if name not in self.__dataclass_fields__:  # type: ignore[attr-defined]
            import difflib

            close = difflib.get_close_matches(name, self.__dataclass_fields__, n=1)  # type: ignore[attr-defined]
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise AttributeError(f"{type(self).__name__} has no field {name!r}{hint}")
        super().__setattr__(name, value)


@dataclass
class Extrinsics(_Fields):
    """Pose of the sensor in the base frame (x forward, y left, z up); R = Rz(yaw)·Ry(pitch)·Rx(roll)."""

    x_m: float = 0.0
    y_m: float = 0.0
    z_m: float = 0.0
    roll_rad: float = 0.0
    pitch_rad: float = 0.0
    yaw_rad: float = 0.0


@dataclass
class GroundConfig(_Fields):
    #: "zones" (a plane per patch of rings × sectors), "pca" (the paper's one iterative plane) or "ransac" (PCL)
    method: str = "zones"
    roi_x_min_m: float = 1.0
    roi_x_max_m: float = 40.0
    roi_y_abs_max_m: float = 10.0
    pca_iterations: int = 3
    pca_threshold_m: float = 0.20  #: points farther than this above the plane are not ground (≥ 0.001)
    #: points farther than this below the ground model (pca: the last plane; zones: the patch's reference and
    #: planes; ransac's band is two-sided) are not ground — returns from under the road (a reflection, multipath)
    max_depth_m: float = 2.0
    ransac_distance_m: float = 0.20
    ransac_max_iterations: int = 200
    ransac_seed: int = 1
    #: every method: a plane or patch whose normal is farther than this from the base frame's up axis (the level
    #: the extrinsics give) is not ground. Old config files may name it ransac_max_tilt_deg.
    max_tilt_deg: float = 15.0
    #: zone ground (docs/method.md §1): ring edges (m, horizontal distance from the base origin) and sectors per
    #: ring over the full circle
    zone_ring_edges_m: list = field(default_factory=lambda: [1, 3, 5, 7, 9, 11, 13, 15.5, 18, 21, 24, 28, 32, 36, 42])
    zone_sectors: list = field(default_factory=lambda: [16, 24, 32, 48, 56, 64, 72, 80, 96, 104, 112, 128, 144, 160])
    zone_root_m: float = 10.0  #: the paper's plane of the points nearer than this is the first ring's reference
    zone_min_points: int = 10  #: fewer points in a patch: no ground there
    zone_seed_points: int = 20  #: the mean height of this many lowest points starts a patch's fit
    zone_max_step_m: float = 0.3  #: elevation test: a patch's ground centroid off the inner ground by at most this
    zone_max_flatness_m: float = 0.08  #: flatness test: RMS distance of the fitted points from the patch plane
    zone_min_breadth_m: float = 0.1  #: breadth test: the fitted points' RMS spread across their longest direction


@dataclass
class PathConfig(_Fields):
    straight_radius_m: float = 1000.0  #: |V/ω| above this is driven as a straight line
    stopped_speed_mps: float = 0.0  #: |V| at or below this means the vehicle is stopped (no path)


@dataclass
class ProfileConfig(_Fields):
    preview_length_m: float = 40.0
    ds_m: float = 0.1  #: resampling step along the wheel path
    max_gap_m: float = 1.0  #: interior gaps up to this length are linearly interpolated
    level: bool = True  #: remove the fitted ground plane's tilt before reading heights
    level_local: bool = True  #: with level: heights above the local ground's plane in bands of level_band_m (§3)
    level_band_m: float = 10.0  #: radial width of those bands; sets which long waves the levelling removes
    #: σ (degrees) of each LiDAR beam's elevation angle, an error all of a beam's points share (method.md §3): counted
    #: in the bins' and the map's noise for points whose beam is known (``beams=``, a decoder's frames); 0: not counted
    beam_sigma_deg: float = 0.0
    #: σ (degrees) of beam b's elevation angle at [b], in place of beam_sigma_deg for the beams it lists (e.g. a
    #: beams file's ``BeamCalibration.beam_sigmas_deg()``); empty: beam_sigma_deg for every beam
    beam_sigmas_deg: list = field(default_factory=list)


@dataclass
class RoughnessConfig(_Fields):
    band_min_cpm: float = 0.1
    band_max_cpm: float = 4.0
    min_length_m: float = 5.0  #: shortest valid stretch that is analysed
    min_cycles: float = 2.0  #: the band starts no lower than min_cycles / stretch length
    min_band_points: int = 5  #: fewest PSD ordinates in the band for a class
    noise_aware: bool = True  #: fit road + measurement noise; band limited by the sampling (docs/noise-aware-roughness.md)
    min_resolved_fraction: float = 0.5  #: the band ends where the bins' spacing keeps less of the road's PSD


@dataclass
class IriConfig(_Fields):
    min_length_m: float = 11.0  #: shortest valid stretch whose IRI is computed (ASTM E1926's 11 m lead-in)
    min_backed_fraction: float = 0.25  #: fewest bins of the stretch holding points (the rest interpolated)


@dataclass
class ObstaclesConfig(_Fields):
    """Euclidean clusters of the non-ground ROI points and where they cross the wheel paths (method.md §5)."""

    enabled: bool = True
    voxel_m: float = 0.25  #: points are clustered by the centroids of voxels this wide; 0: every point
    cluster_tolerance_m: float = 0.5  #: centroids closer than this are in the same cluster (≥ 0.01)
    min_cluster_points: int = 5  #: smaller clusters are dropped (isolated returns, noise)
    max_cluster_points: int = 1000000  #: larger clusters are dropped; the default keeps every one
    ground_search_m: float = 1.0  #: ground points this far around a cluster give its local ground
    safety_margin_m: float = 0.1  #: widens each wheel corridor sideways and each obstacle along s
    min_height_m: float = 0.1  #: lower clusters do not block a wheel path (ground the fit missed)
    clearance_m: float = 2.5  #: clusters entirely higher above their local ground (canopy, signs, bridges) do not block


@dataclass
class FusionConfig(_Fields):
    """Temporal fusion: a rolling elevation map fused over frames (docs/method.md §7)."""

    method: str = "none"  #: "none" (each frame alone), "ema" (the paper's moving average) or "kalman"
    alpha: float = 0.5  #: EMA weight of the new frame, (0, 1]; 1 = the latest frame's cells
    cell_m: float = 0.1  #: square map cells (0.01–10 m)
    #: side of the square map around the vehicle (≥ 2 × (preview + behind) with fusion on; ≤ 4000 cells)
    map_length_m: float = 100.0
    point_noise_m: float = 0.03  #: σ of one point's height when no cell of a frame holds two points
    frame_rate_hz: float = 10.0  #: frames without timestamps are 1/frame_rate_hz apart (0.01–10000)
    max_time_gap_s: float = 0.5  #: a longer step between timestamps, or one back in time, resets the map
    behind_m: float = 0.0  #: fused profiles start this far behind the wheels (already-driven road)
    align: bool = True  #: remove the plane between a frame's heights and the map's before fusing
    #: rad (1e-9–1), prior σ of that plane's slopes: scarce shared cells cannot tilt a frame
    align_tilt_sigma: float = 1e-4
    #: m, the excess disagreement is measured on the shared cells this close to the line ahead (the lane, not verges)
    align_excess_half_width_m: float = 2.0


@dataclass
class StereoConfig(_Fields):
    """Stereo cameras (docs/method.md §12): OpenCV StereoSGBM's settings, the disparity noise and the rows matched."""

    min_disparity: int = 0  #: px, smallest disparity searched
    num_disparities: int = 128  #: px, width of the search (a multiple of 16)
    block_size: int = 5  #: px, odd, matching window
    p1: int = 600  #: smoothness penalty for ±1 px disparity changes (8·3·block_size²)
    p2: int = 2400  #: penalty for larger changes (32·3·block_size²), > p1
    disp12_max_diff: int = 1  #: px, left-right consistency check; < 0 turns it off
    pre_filter_cap: int = 63
    uniqueness_ratio: int = 10  #: %, margin of the best match over the second best
    speckle_window_size: int = 100  #: px, largest speckle removed; 0 turns the filter off
    speckle_range: int = 2  #: px, disparity variation within a connected component
    mode: str = "sgbm_3way"  #: "sgbm" (5 directions), "hh" (8), "sgbm_3way" or "hh4"
    threads: int = 0  #: OpenCV threads for matching; 0: OpenCV's default (all cores)
    disparity_sigma_px: float = 0.4  #: σ_d of a matched disparity; a point's range σ is z²·σ_d/(f·B)·r/z
    #: px, how far matching errors stay correlated along a row and across rows (KITTI pair, SGBM: 15, 2): points
    #: within one tile of twice these share an error group (``error_groups``); 0: every pixel its own
    error_correlation_along_px: float = 15.0
    error_correlation_across_px: float = 2.0
    max_depth_m: float = 40.0  #: farther points are dropped; rows that only see beyond it are not matched
    road_rise_m: float = 2.0  #: the road may rise this far above the base plane at max_depth_m


_STAGES = {
    "extrinsics": Extrinsics,
    "ground": GroundConfig,
    "path": PathConfig,
    "profile": ProfileConfig,
    "roughness": RoughnessConfig,
    "obstacles": ObstaclesConfig,
    "iri": IriConfig,
    "fusion": FusionConfig,
    "stereo": StereoConfig,
}


@dataclass
class Config(_Fields):
    """Everything the pipeline needs besides the points, the speed and the yaw rate.

    Keyword-constructible; stage blocks accept dataclasses or plain dicts::

        rp.Config(sensor_height=1.73, track_width=1.6, ground={"method": "ransac"})
    """

    sensor_height: Optional[float] = None  #: shortcut for extrinsics (0, 0, h, 0, 0, 0)
    extrinsics: Optional[Extrinsics] = None
    track_width: float = 1.6
    tire_width: float = 0.3
    threads: int = 1  #: threads one frame may use (at most the cores the process may run on); same answer for any
    ground: GroundConfig = field(default_factory=GroundConfig)
    path: PathConfig = field(default_factory=PathConfig)
    profile: ProfileConfig = field(default_factory=ProfileConfig)
    roughness: RoughnessConfig = field(default_factory=RoughnessConfig)
    obstacles: ObstaclesConfig = field(default_factory=ObstaclesConfig)
    iri: IriConfig = field(default_factory=IriConfig)
    fusion: FusionConfig = field(default_factory=FusionConfig)
    stereo: StereoConfig = field(default_factory=StereoConfig)

    def __post_init__(self) -> None:
        for name, cls in _STAGES.items():
            value = getattr(self, name)
            if isinstance(value, dict):
                setattr(self, name, _stage_from_dict(cls, value, name))
            elif value is not None and not isinstance(value, cls):
                raise TypeError(f"Config.{name} must be a {cls.__name__} or a dict, got {type(value).__name__}")

    @classmethod
    def from_dict(cls, data: dict[str, Any], *, source: str = "config") -> "Config":
        if not isinstance(data, dict):
            raise ValueError(f"{source}: expected a mapping of config fields, got {type(data).__name__}")
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"{source}: unknown config field(s) {unknown}; known: {sorted(known)}")
        return cls(**data)

    @classmethod
    def from_file(cls, path: str | Path) -> "Config":
        """Read a JSON or YAML file holding (a subset of) the fields of :meth:`to_dict`."""
        path = Path(path)
        if path.exists() and not path.is_file():  # a directory; a device never ends, a pipe blocks
            raise ValueError(f"{path}: cannot read config file: not a regular file")
        try:
            text = path.read_text()
        except OSError as err:
            raise ValueError(f"{path}: cannot read config file ({err.strerror})") from None
        except UnicodeDecodeError:
            raise ValueError(f"{path}: not a config file: not UTF-8 text") from None
        if path.suffix.lower() in (".yaml", ".yml"):
            try:
                import yaml
            except ImportError:
                raise ImportError(f"{path}: a YAML config needs pyyaml: pip install 'roadpreview[yaml]'") from None
        try:
            if path.suffix.lower() in (".yaml", ".yml"):
                data = yaml.safe_load(text)
            else:
                data = json.loads(text)
        except Exception as err:  # parser errors differ between json and yaml
            raise ValueError(f"{path}: not a valid config file: {err}") from None
        if _values_beyond(data, _MAX_CONFIG_VALUES):
            raise ValueError(f"{path}: not a config: more than {_MAX_CONFIG_VALUES} values (aliases repeating a node "
                             f"over and over?)")
        cfg = cls.from_dict(data or {}, source=str(path))
        from ._native import core

        try:  # the values checked now, naming the file, not when an Estimator is made of them
            core().check_config(cfg.to_json(), str(path))
        except (ValueError, RuntimeError) as err:
            raise ValueError(str(err) if str(err).startswith(str(path)) else f"{path}: {err}") from None
        return cfg

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    def to_json(self) -> str:
        data = self.to_dict()
        _require_finite(data, "Config")
        return json.dumps(data)


# A config holds a few hundred values; YAML aliases may repeat a node, and aliases of aliases double it at every
# level: ten levels of "billion laughs" are a billion values from a few lines.
_MAX_CONFIG_VALUES = 100_000


def _values_beyond(data: Any, limit: int) -> bool:
    """Whether ``data`` holds more than ``limit`` values, a node reached twice counted twice (stops at the limit)."""
    seen, stack = 0, [data]
    while stack:
        seen += 1
        if seen > limit:
            return True
        item = stack.pop()
        if isinstance(item, dict):
            stack.extend(item.values())
        elif isinstance(item, (list, tuple)):
            stack.extend(item)
    return False


def _require_finite(data: Any, where: str) -> None:
    """ValueError naming the field for NaN or ±Inf (JSON cannot carry them, and no field accepts them)."""
    if isinstance(data, dict):
        for key, value in data.items():
            _require_finite(value, f"{where}.{key}")
    elif isinstance(data, (list, tuple)):
        for i, value in enumerate(data):
            _require_finite(value, f"{where}[{i}]")
    elif isinstance(data, float) and not math.isfinite(data):
        raise ValueError(f"invalid config: {where} must be finite, got {data}")


def _stage_from_dict(cls: type, data: dict[str, Any], name: str) -> Any:
    if cls is GroundConfig and "ransac_max_tilt_deg" in data:  # the tilt limit's old name
        if "max_tilt_deg" in data:
            raise ValueError(f"Config.{name}: set max_tilt_deg or its old name ransac_max_tilt_deg, not both")
        data = {("max_tilt_deg" if key == "ransac_max_tilt_deg" else key): value for key, value in data.items()}
    known = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - known)
    if unknown:
        raise ValueError(f"Config.{name}: unknown field(s) {unknown}; known: {sorted(known)}")
    return cls(**data)
