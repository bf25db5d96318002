"""Beam self-calibration (docs/method.md §8), written plainly from the method: every ground point of every frame
is one observation of the height of the road cell it falls in, shifted by its frame's plane and by its beam's
elevation (and range) offset; the cells' heights are eliminated by centring each cell's observations, and the
beams' and frames' parameters are the weighted least-squares solution with weak priors."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..config import Config
from .frames import check_points, sensor_pose
from .ground import fit_ground

#: prior σ of each parameter: they only regularise what the data leave open
PRIOR_ELEVATION_RAD = math.radians(0.5)
PRIOR_RANGE_M = 0.1
PRIOR_OFFSET_M = 0.5
PRIOR_SLOPE = 0.02


class CalibrationError(ValueError):
    """The drive cannot determine the beams' offsets (too short, no motion, too few beams on the ground)."""


@dataclass
class CalibrationOptions:
    cell_m: float = 0.2  #: road cells whose heights the beams are compared in (smaller: steep beams biased)
    min_frames: int = 2
    min_travel_m: float = 0.3  #: the vehicle must move at least this far over the drive
    max_sigma_deg: float = 0.01  #: a beam whose offset is less certain than this is not determined
    max_range_sigma_m: float = 0.01  #: range offsets less certain than this are not estimated
    min_beams: int = 3  #: fewer determined beams is an error
    min_observations: int = 100  #: a beam seen in fewer shared cells is not determined (the noise is pooled)
    outlier_sigmas: float = 4.0  #: observations further off than this many robust σ are dropped
    rounds: int = 3  #: fits, each after dropping the previous fit's outliers


@dataclass
class BeamCalibrationResult:
    beam_count: int
    elevation_offset_deg: np.ndarray  #: per beam; 0 where not determined
    elevation_sigma_deg: np.ndarray  #: per beam; NaN where not determined
    range_offset_m: np.ndarray  #: per beam; 0 where not estimated
    range_sigma_m: np.ndarray  #: per beam; NaN where not estimated
    determined: np.ndarray  #: bool per beam
    observations: np.ndarray  #: per beam, cell observations used
    residual_m: float  #: robust σ of one point's height after the fit
    frames: int
    travel_m: float
    extra: dict = field(default_factory=dict)


def point_observations(points, beams, ground_mask, pose, cfg: Config):
    """Per ground point: odometry x, y, base-frame x, y, z and the height's derivatives by the beam's elevation
    offset (J_δ, m/rad) and range offset (J_ρ, m/m), and its beam. A point reported at range r along u(θ, φ) whose
    beam truly points at θ + δ and whose true range is r − ρ lies at p − ρ·u + r·δ·∂u/∂θ."""
    points = check_points(points)
    rotation, translation = sensor_pose(cfg)
    xyz = points[:, :3].astype(np.float64)
    keep = np.asarray(ground_mask, bool) & np.isfinite(xyz).all(axis=1)
    xyz, beams = xyz[keep], np.asarray(beams)[keep]
    r = np.linalg.norm(xyz, axis=1)
    u = xyz / r[:, None]
    elevation = np.arcsin(np.clip(u[:, 2], -1, 1))
    azimuth = np.arctan2(u[:, 1], u[:, 0])
    du = np.stack([-np.sin(elevation) * np.cos(azimuth), -np.sin(elevation) * np.sin(azimuth), np.cos(elevation)], 1)
    base = xyz @ rotation.T + translation
    x0, y0, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    return {"odo_x": x0 + c * base[:, 0] - s * base[:, 1], "odo_y": y0 + s * base[:, 0] + c * base[:, 1],
            "x": base[:, 0], "y": base[:, 1], "z": base[:, 2], "j_elevation": -r * (du @ rotation.T)[:, 2],
            "j_range": (u @ rotation.T)[:, 2], "beam": beams.astype(np.int64)}


def ground_mask_of(points, cfg: Config) -> np.ndarray:
    """The reference ground of one frame, as a mask over its rows: the paper's one plane (method "pca") whatever
    ground.method says — the smooth road every beam crosses, not the verges a zone ground follows (method.md §8)."""
    from .frames import to_base_frame
    base, finite = to_base_frame(points, cfg)
    mask = np.zeros(len(finite), bool)
    one_plane = dataclasses.replace(cfg, ground=dataclasses.replace(cfg.ground, method="pca"))
    ground, _plane = fit_ground(base, one_plane)
    mask[np.flatnonzero(finite)[ground]] = True
    return mask


def cell_observations(frames_obs: list, cell_m: float) -> dict:
    """Means of each (cell, frame, beam) group of points, with their point counts as weights."""
    columns = ("z", "x", "y", "j_elevation", "j_range")
    keys = []
    for f, obs in enumerate(frames_obs):
        i = np.floor(obs["odo_x"] / cell_m).astype(np.int64)
        j = np.floor(obs["odo_y"] / cell_m).astype(np.int64)
        keys.append(np.stack([i, j, np.full_like(i, f), obs["beam"]], 1))
    keys = np.concatenate(keys)
    values = {c: np.concatenate([obs[c] for obs in frames_obs]) for c in columns}
    groups, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    out = {c: np.bincount(inverse, values[c]) / counts for c in columns}
    _, cell, per_cell = np.unique(groups[:, :2], axis=0, return_inverse=True, return_counts=True)
    out.update(cell=cell.ravel(), frame=groups[:, 2], beam=groups[:, 3], weight=counts.astype(float))
    shared = per_cell[cell.ravel()] >= 2  # a cell seen once compares nothing
    out = {k: v[shared] for k, v in out.items()}
    out["cell"] = np.unique(out["cell"], return_inverse=True)[1].ravel()
    return out


def design(obs: dict, beam_count: int, frame_count: int, range_beams: np.ndarray) -> sp.csr_matrix:
    """Rows: observations; columns: δ per beam, ρ per beam in range_beams, then a, b, c per frame."""
    n = len(obs["z"])
    rows = np.arange(n)
    range_column = np.full(beam_count, -1)
    range_column[range_beams] = beam_count + np.arange(len(range_beams))
    frame0 = beam_count + len(range_beams)
    has_range = range_column[obs["beam"]] >= 0
    r = [rows, rows[has_range], rows, rows, rows]
    c = [obs["beam"], range_column[obs["beam"]][has_range], frame0 + 3 * obs["frame"],
         frame0 + 3 * obs["frame"] + 1, frame0 + 3 * obs["frame"] + 2]
    v = [obs["j_elevation"], obs["j_range"][has_range], np.ones(n), obs["x"], obs["y"]]
    return sp.csr_matrix((np.concatenate(v), (np.concatenate(r), np.concatenate(c))),
                         shape=(n, frame0 + 3 * frame_count))


def centre_by_cell(matrix, weight: np.ndarray, cell: np.ndarray):
    """Each row minus the weighted mean of its cell's rows: the cells' unknown heights drop out."""
    cells = cell.max() + 1
    averaging = sp.csr_matrix((weight, (cell, np.arange(len(cell)))), shape=(cells, len(cell)))
    averaging = sp.diags(1.0 / np.asarray(averaging.sum(axis=1)).ravel()) @ averaging
    expand = sp.csr_matrix((np.ones(len(cell)), (np.arange(len(cell)), cell)), shape=(len(cell), cells))
    return matrix - expand @ (averaging @ matrix)


def prior_precision(beam_count: int, range_count: int, frame_count: int) -> np.ndarray:
    sigmas = np.concatenate([np.full(beam_count, PRIOR_ELEVATION_RAD), np.full(range_count, PRIOR_RANGE_M),
                             np.tile([PRIOR_OFFSET_M, PRIOR_SLOPE, PRIOR_SLOPE], frame_count)])
    return 1.0 / sigmas**2


def fit(obs: dict, keep: np.ndarray, beam_count: int, frame_count: int, range_beams: np.ndarray, noise_m: float):
    """Least squares of the cell-centred observations in `keep`, each weighted by its points / noise_m², with the
    priors: the parameters, their covariance and every observation's centred residual (0 outside keep)."""
    sub = {k: v[keep] for k, v in obs.items()}
    cell = np.unique(sub["cell"], return_inverse=True)[1].ravel()
    Xc = centre_by_cell(design(sub, beam_count, frame_count, range_beams), sub["weight"], cell)
    zc = centre_by_cell(sp.csr_matrix(sub["z"][:, None]), sub["weight"], cell).toarray().ravel()
    w = sub["weight"] / noise_m**2
    precision = (Xc.T @ sp.diags(w) @ Xc).toarray() + np.diag(prior_precision(beam_count, len(range_beams),
                                                                              frame_count))
    gauge = gauge_basis(obs, beam_count)  # pins what the ground cannot tell from the mounting (see below)
    precision[:beam_count, :beam_count] += GAUGE_PRECISION * gauge @ gauge.T
    covariance = np.linalg.inv(precision)
    theta = covariance @ (Xc.T @ (w * zc))
    residual = np.zeros(len(obs["z"]))
    residual[keep] = zc - Xc @ theta
    return theta, covariance, residual


def travel_m(poses) -> float:
    xy = np.asarray([p[:2] for p in poses], float)
    return float(np.sum(np.linalg.norm(np.diff(xy, axis=0), axis=1)))


def check_drive(frame_count: int, poses, options: CalibrationOptions) -> float:
    if frame_count < options.min_frames:
        raise CalibrationError(f"too short: {frame_count} frame(s), calibration needs at least {options.min_frames}")
    travel = travel_m(poses)
    if travel < options.min_travel_m:
        raise CalibrationError(f"no motion: the vehicle moved {travel:.3f} m over {frame_count} frames, "
                               f"calibration needs at least {options.min_travel_m} m")
    return travel


def shared_beams(obs: dict, beam_count: int, min_observations: int) -> np.ndarray:
    """Beams with at least min_observations observations in cells that another beam also saw: only these can be
    compared, and a beam seen in a handful of cells has a σ the pooled noise understates."""
    beams_per_cell = np.zeros(obs["cell"].max() + 1, np.int64)
    pairs = np.unique(np.stack([obs["cell"], obs["beam"]], 1), axis=0)
    np.add.at(beams_per_cell, pairs[:, 0], 1)
    shared_cell = beams_per_cell[obs["cell"]] >= 2
    return np.bincount(obs["beam"][shared_cell], minlength=beam_count) >= min_observations


GAUGE_PRECISION = 1e12  #: 1/rad², holds the gauge directions at zero


def gauge_columns(reach: np.ndarray) -> np.ndarray:
    """(len(reach), 3): 1, 1/reach and reach, scaled to about one."""
    mean = reach.mean()
    return np.stack([np.ones(len(reach)), mean / reach, reach / mean], 1)


def gauge_basis(obs: dict, beam_count: int) -> np.ndarray:
    """(beams, 3): the offsets the ground cannot tell from the mounting or the road's shape: a common one (it
    tilts every ring like a pitch), one ∝ 1/reach (it lifts every ring by one height, like the sensor's height)
    and one ∝ reach (it bends the rings' heights by reach², like a sag or crest of the road driven straight over);
    0 for beams without observations."""
    reach = beam_reach(obs, beam_count)
    seen = np.isfinite(reach)
    basis = np.zeros((beam_count, 3))
    basis[seen] = gauge_columns(reach[seen])
    return basis


def beam_reach(obs: dict, beam_count: int) -> np.ndarray:
    """Each beam's weighted mean of −J_δ (its mean horizontal range on the ground for a level sensor), m."""
    weight = np.bincount(obs["beam"], obs["weight"], beam_count)
    reach = -np.bincount(obs["beam"], obs["weight"] * obs["j_elevation"], beam_count)
    return np.where(weight > 0, reach / np.maximum(weight, 1e-300), np.inf)


def robust_fit(obs: dict, beam_count: int, frame_count: int, range_beams, options: CalibrationOptions):
    """fit() repeated: the point noise from the residuals' median, observations beyond outlier_sigmas dropped."""
    keep = np.ones(len(obs["z"]), bool)
    noise = 0.02
    for _ in range(options.rounds):
        theta, covariance, residual = fit(obs, keep, beam_count, frame_count, range_beams, noise)
        scaled = np.abs(residual) * np.sqrt(obs["weight"])
        noise = max(1.4826 * float(np.median(scaled[keep])), 1e-4)
        keep = scaled <= options.outlier_sigmas * noise
    return theta, covariance, noise


def relative_offsets(theta, covariance, members: np.ndarray, reach: np.ndarray):
    """Elevation offsets of `members` less their best fit by a + b/reach + c·reach (reach: each beam's mean
    horizontal range, −J_δ; see gauge_basis), and their σ."""
    idx = np.flatnonzero(members)
    basis = gauge_columns(reach[idx])
    P = np.eye(len(idx)) - basis @ np.linalg.pinv(basis)
    delta = P @ theta[idx]
    sigma = np.sqrt(np.diag(P @ covariance[np.ix_(idx, idx)] @ P.T))
    return idx, delta, sigma


def calibrate_beams(frames, poses, beam_count: int, cfg: Config | None = None, options=None, ground_masks=None):
    """Per-beam elevation (and range) offsets from a drive. frames: (points N×C in the sensor frame, beam index per
    row); poses: (x, y, yaw) of the base frame in the odometry frame per frame; ground_masks: the rows that are
    ground (default: the reference ground of each frame). Raises CalibrationError when the drive cannot tell."""
    cfg = cfg or Config()
    options = options or CalibrationOptions()
    frames = list(frames)
    travel = check_drive(len(frames), poses, options)
    per_frame = []
    for f, (points, beams) in enumerate(frames):
        if len(beams) != len(points) or (len(beams) and (np.min(beams) < 0 or np.max(beams) >= beam_count)):
            raise ValueError(f"frame {f}: need one beam index in [0, {beam_count}) per point")
        mask = ground_mask_of(points, cfg) if ground_masks is None else ground_masks[f]
        per_frame.append(point_observations(points, beams, mask, poses[f], cfg))
    obs = cell_observations(per_frame, options.cell_m)
    candidates = shared_beams(obs, beam_count, options.min_observations)
    if candidates.sum() < options.min_beams:
        raise CalibrationError(f"too few beams on the ground: {int(candidates.sum())} beam(s) share "
                               f"{options.min_observations} road cells with others, calibration needs at least "
                               f"{options.min_beams}")
    none = np.array([], np.int64)
    theta, covariance, noise = robust_fit(obs, beam_count, len(frames), none, options)
    reach = beam_reach(obs, beam_count)
    determined = candidates.copy()
    for _ in range(2):  # the σ of each offset depends on which beams the mean is taken over
        idx, delta, sigma = relative_offsets(theta, covariance, determined, reach)
        determined[idx[sigma > math.radians(options.max_sigma_deg)]] = False
        if determined.sum() < options.min_beams:
            raise CalibrationError(f"too few beams on the ground: {int(determined.sum())} beam(s) determined within "
                                   f"{options.max_sigma_deg}°, calibration needs at least {options.min_beams}")
    idx, delta, sigma = relative_offsets(theta, covariance, determined, reach)
    range_offset, range_sigma = range_offsets(obs, beam_count, len(frames), determined, options)
    out = BeamCalibrationResult(
        beam_count, np.zeros(beam_count), np.full(beam_count, np.nan), range_offset, range_sigma, determined,
        np.bincount(obs["beam"], minlength=beam_count), noise, len(frames), travel, {"reach": reach})
    out.elevation_offset_deg[idx] = np.degrees(delta)
    out.elevation_sigma_deg[idx] = np.degrees(sigma)
    return out


def range_offsets(obs: dict, beam_count: int, frame_count: int, determined: np.ndarray, options: CalibrationOptions):
    """Range offsets where the data tell them from the elevation offsets (a beam seen at one range cannot):
    fitted jointly for the determined beams, kept where their σ is within max_range_sigma_m."""
    offset, sigma = np.zeros(beam_count), np.full(beam_count, np.nan)
    beams = np.flatnonzero(determined)
    theta, covariance, _ = robust_fit(obs, beam_count, frame_count, beams, options)
    rho_sigma = np.sqrt(np.diag(covariance)[beam_count:beam_count + len(beams)])
    good = rho_sigma <= options.max_range_sigma_m
    offset[beams[good]] = theta[beam_count:beam_count + len(beams)][good]
    sigma[beams[good]] = rho_sigma[good]
    return offset, sigma
