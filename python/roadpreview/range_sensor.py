"""Point range preview sensors (ultrasonic, laser displacement) through the profile, roughness and IRI stages.

    import roadpreview as rp
    cal = rp.range_sensor.calibrate_distance(counts, distances)            # d = a1·c + a2, with RMS, R², outliers
    off = rp.range_sensor.calibrate_offset(["run1.csv", "run2.csv"], ["m1.csv", "m2.csv"], "sensors.yaml",
                                           calibration="cal.yaml", reference=profile_xz, output="cal.yaml")
    windows = rp.range_sensor.process("readings.csv", "sensors.yaml", calibration="cal.yaml", speed=10.0)
    windows[0]["roughness"]["left"]["class"], windows[0]["samples"]["time_to_wheel"]

The reference of the offset calibration is a known profile ((N, 2) array of x, z in metres, x where the axle is
at the motion table's first time = 0; or a CSV path with header x,z), or a fused LiDAR map: an ``rp.Estimator``
with temporal fusion that drove the same road from the same start (one per run, or one for all), sampled along
each sensor's line. Files are as the CLI reads them (docs/method.md §11); errors name the file and line.
"""

from __future__ import annotations

import json
import os
from typing import Optional, Sequence, Union

import numpy as np

from ._native import core

PathLike = Union[str, os.PathLike]


def read_layout(path: PathLike) -> list[dict]:
    """The sensors of a layout file, with each one's geometric beam foot ``foot_m`` (x_m + h·tan pitch)."""
    return core().range_layout(os.fspath(path))


def calibrate_distance(counts, distances, *, output: Optional[PathLike] = None,
                       keep: Optional[PathLike] = None) -> dict:
    """Least squares d = a1·c + a2 with outlier rejection: {a1, a2, rms_m, r_squared, used, rejected, ...}.

    counts, distances: bench readings at known distances (m). With ``output`` the calibration file is written
    (``keep``: an existing calibration whose per-sensor entries are kept).
    """
    c = np.asarray(counts, dtype=float).ravel()
    d = np.asarray(distances, dtype=float).ravel()
    bad = np.flatnonzero(~(np.isfinite(c) & np.isfinite(d)))
    if bad.size:  # as the CLI refuses such a bench line
        raise ValueError(f"counts and distances must be finite: pair {bad[0]} is ({c[bad[0]]}, {d[bad[0]]})")
    if output is not None:
        return core().range_write_distance_calibration(c, d, os.fspath(keep) if keep else "", os.fspath(output))
    return core().range_calibrate_distance(c, d)


def samples(readings: PathLike, sensors: PathLike, *, calibration: Optional[PathLike] = None,
            motion: Optional[PathLike] = None, speed: Optional[float] = None, yaw_rate: float = 0.0,
            raw: bool = False) -> dict:
    """Every reading as a height sample: {t, sensor (layout index), s (m along the wheel's track), z (m),
    ahead (m ahead of the axle), speed, time_to_wheel (s)} arrays. raw: place with b1 = b2 = 0 (s is where the
    axle was), as the offset calibration does."""
    _one_motion(motion, speed)
    return core().range_samples(os.fspath(readings), os.fspath(sensors), _path(calibration), _path(motion),
                                speed, float(yaw_rate), raw)


def map_profile(estimator, y_m: float, x_from_m: float, x_to_m: float) -> np.ndarray:
    """(x, z) of an estimator's fused LiDAR map along the odometry line y = y_m: one point per cell, where the cell's
    height lies — the mean x of the points fused into it (a LiDAR ring crosses a cell at one place; read at the
    cell's centre, the profile sits up to half a cell off the road it holds) —, empty cells bridged linearly at
    their centres, the ends trimmed to observed cells."""
    cell = estimator.config.fusion.cell_m
    x = (np.arange(np.floor(x_from_m / cell), np.ceil(x_to_m / cell)) + 0.5) * cell
    cells = core().fusion_map_cells(estimator._impl, x, np.full_like(x, y_m))
    ok = np.isfinite(cells[:, 2])
    if ok.sum() < 2:
        raise ValueError(f"the fused map holds fewer than 2 cells along y = {y_m} m "
                         f"between x = {x_from_m} and {x_to_m} m")
    first, last = np.flatnonzero(ok)[[0, -1]]
    cells, x, ok = cells[first:last + 1], x[first:last + 1], ok[first:last + 1]
    x = np.where(ok, cells[:, 0], x)  # each fused x lies inside its cell: the order is kept
    return np.column_stack([x, np.interp(x, x[ok], cells[ok, 2])])


def fuse_into(estimator, x_m, y_m, z_m, sigma_m) -> int:
    """Fuses height samples into an estimator's temporal-fusion map (odometry frame, metres; sigma_m: each
    sample's standard deviation, or one for all), so its next frame's profiles carry them: a vehicle with both
    sensors gets one profile. For a straight drive from the odometry origin a sample's x is its track position
    ``s`` and y its sensor's ``y_m``. Returns the cells updated."""
    x = np.asarray(x_m, dtype=float).ravel()
    variance = np.broadcast_to(np.asarray(sigma_m, dtype=float) ** 2, x.shape)
    return core().fuse_map_samples(estimator._impl, x, np.broadcast_to(np.asarray(y_m, float), x.shape),
                                   np.asarray(z_m, dtype=float).ravel(), variance)


def calibrate_offset(runs: Sequence[PathLike], motions: Sequence[PathLike], sensors: PathLike, *, reference,
                     calibration: Optional[PathLike] = None, search_m: float = 0.5,
                     output: Optional[PathLike] = None) -> dict:
    """b1 (s) and b2 (m) of x = b1·v + b2 per sensor from runs over a known profile at two or more speeds.

    Returns {sensor id: {b1_s, b2_m, b1_sigma_s, b2_sigma_m, b1_xcorr_s, b2_xcorr_m, runs: [...]}}; each run's
    ICP shift, its standard error and the cross-correlation shift are in ``runs``. ``reference``: see the module
    docstring; an Estimator (or a list, one per run) gives the self-calibration on the road.
    """
    if len(runs) != len(motions):
        raise ValueError(f"give one motion file per run ({len(runs)} runs, {len(motions)} motion files)")
    layout = read_layout(sensors)
    refs, from_maps = _references(reference, layout, len(runs))
    return core().range_calibrate_offsets([os.fspath(r) for r in runs], [os.fspath(m) for m in motions],
                                          os.fspath(sensors), _path(calibration), refs, from_maps, float(search_m),
                                          _path(output))


def process(readings: PathLike, sensors: PathLike, *, calibration: Optional[PathLike] = None,
            motion: Optional[PathLike] = None, speed: Optional[float] = None, yaw_rate: float = 0.0,
            frame_length_m: float = 40.0) -> list[dict]:
    """The CLI's `range run`: one dict per window of frame_length_m (docs/output.md, "Range sensors")."""
    _one_motion(motion, speed)
    lines = core().range_process(os.fspath(readings), os.fspath(sensors), _path(calibration), _path(motion), speed,
                                 float(yaw_rate), float(frame_length_m))
    return [json.loads(line) for line in lines]


def _one_motion(motion, speed) -> None:
    """As the CLI's --motion and --speed: one of them (with both, the table won and the speed was ignored)."""
    if motion is not None and speed is not None:
        raise ValueError("give the motion as a table (motion=) or a constant speed (speed=), not both")


def _path(p: Optional[PathLike]) -> str:
    return os.fspath(p) if p is not None else ""


def _references(reference, layout: list[dict], runs: int) -> tuple[list, bool]:
    """The reference as (x, z) array pairs, [sensor][run]: one for all sensors and runs, or (fused maps) each
    sensor's line in each run's map; and whether they are maps (whose levelled datum may lean against the
    sensor's heights: the registration then fits a tilt too)."""
    from .estimator import Estimator

    def from_map(est, sensor) -> tuple:
        xz = map_profile(est, sensor["y_m"], -5.0, 500.0)
        return xz[:, 0].copy(), xz[:, 1].copy()

    maps = [reference] if isinstance(reference, Estimator) else reference
    if isinstance(maps, (list, tuple)) and maps and isinstance(maps[0], Estimator):
        if len(maps) not in (1, runs):
            raise ValueError(f"give one estimator, or one per run ({runs} runs, {len(maps)} estimators)")
        return [[from_map(est, sensor) for est in maps] for sensor in layout], True
    if isinstance(reference, (str, os.PathLike)):
        reference = np.genfromtxt(os.fspath(reference), delimiter=",", names=True)
        reference = np.column_stack([reference["x"], reference["z"]])
    xz = np.asarray(reference, dtype=float)
    if xz.ndim != 2 or xz.shape[1] != 2:
        raise ValueError(f"reference must be an (N, 2) array of x, z, got shape {xz.shape}")
    return [[(np.ascontiguousarray(xz[:, 0]), np.ascontiguousarray(xz[:, 1]))]], False
