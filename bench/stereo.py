"""Stereo cameras as a preview sensor: the moving-average paper's experiment, a real KITTI pair against the LiDAR,
and the time per pair.

  * the paper's experiment (Lee & Yoon, moving-average road profile estimation, a stereo system) in the simulator
    at KITTI's geometry (f = 721.5 px, B = 0.5327 m, 1.65 m high, 1242 × 375): a smooth road with one bump of
    1–10 cm under the left wheel and plain road under the right, driven at 10 m/s, 10 Hz; disparity noise
    0.25 px, 2 % invalid pixels. Bump height = crest minus the road 1–2.5 m around it (bench/accuracy.py),
    scored in the frames with the bump 5–15 m ahead; the plain road is the right wheel's profile 5–15 m ahead;
    frame by frame (none), the paper's moving average (ema, α = 0.5) and the Kalman map; ``--noise sgbm`` draws
    the disparity noise as measured on the real pair (sim.SGBM_ON_KITTI: 0.3 px, correlated along the rows);
    and, as the paper reads its profile, the readout (rp.ProfileReadout) A = 6, 9, 12, 15 m ahead: the bump
    scored once per sequence in the array between the wheel and A, the plain road there under the right wheel;
  * the real pair of ../shared/data/stereo/stereo_rcnn_kitti_object (StereoSGBM in C++) against the Velodyne
    scan of the same instant, both in one base frame (on the road below the Velodyne): the wheel-path profiles'
    RMS difference per distance band and the ISO class of each; a picture;
  * the noise of that pair's disparities: the Velodyne's road points projected into both images give the true
    disparity of the pixels they fall on; SGBM's error there per depth band, and how it is correlated along the
    rows and across them (each laser ring's median error removed: the rings' own calibration errors);
  * the time per KITTI pair (1242 × 375): reading, matching (road rows only, and the whole image), points and
    the pipeline, with 1 and 2 OpenCV threads.

    python bench/stereo.py [--quick] [--jobs N] [--runs N] [--picture PATH] [--parts paper,real,noise,timing]
                           [--noise independent|sgbm] [--seeds N]
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import roadpreview as rp
from roadpreview import sim
from roadpreview.reference.surface_calibration import rings_in_scan_order

sys.path.insert(0, str(Path(__file__).resolve().parent))
from accuracy import bump_height, detrended_rms, md_table, run_in_pool  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
SHARED_CANDIDATES = [os.environ.get("ROADPREVIEW_SHARED_DATA", "")] + [str(p / "shared" / "data") for p in REPO.parents[:2]]
SHARED = Path(next((c for c in SHARED_CANDIDATES if c and Path(c).is_dir()), SHARED_CANDIDATES[1]))
PAIR = SHARED / "stereo" / "stereo_rcnn_kitti_object"  # $ROADPREVIEW_SHARED_DATA, else ../shared/data
LIDAR_HEIGHT_M = 1.75  # the ground plane fitted to lidar.bin (shared data README, stereo section)
SPEED_MPS = 10.0
FRAMES = 14  # the bump goes from 16 m to 3 m ahead (scored 5–15 m ahead; the readout at 6 m needs 13 m driven)
BUMP_X_M = 16.05
BUMP_LENGTH_M = 1.0
BUMP_HALF_WIDTH_M = 0.5  # across the left wheel path (y = 0.8 m), clear of the right one
BUMP_RANGE_M = (5.0, 15.0)
HEIGHTS_M = tuple(h / 100 for h in range(1, 11))
METHODS = (("none", True), ("ema", True), ("kalman", True), ("kalman", False))  # (fusion, range variances)
BANDS_M = ((5, 10), (10, 15), (15, 20), (20, 30), (30, 40))
# The readout's distances ahead: from the nearest the camera sees the road in every frame (its image's last row
# meets the road 5.92 m ahead at KITTI's geometry; the next half metre) to the far end of the paper's 5–15 m.
READ_AHEAD_M = (6.0, 9.0, 12.0, 15.0)
BUMP_AROUND_M = 2.5  # bench/accuracy.py's bump_height reads the road up to 2.5 m before and after the crest
LIDAR_RANGE_SIGMA_M = 0.02  # the HDL-64E's range accuracy (its manual: < 2 cm): the truth's own disparity error


def method_name(method: str, variances: bool) -> str:
    return method + ("" if variances else ", no point variances")


# ------------------------------------------------------------------------------------------------ the paper
NOISE_MODELS = {"independent": {}, "sgbm": sim.SGBM_ON_KITTI}  # disparity noise of the simulated camera
# … and the config's statement of its correlation: none for independent noise, the measured default for SGBM's
STEREO_CONFIGS = {"independent": {"error_correlation_along_px": 0.0, "error_correlation_across_px": 0.0}, "sgbm": {}}


def paper_run(item: tuple[float, int, str, int]) -> dict:
    """One bump height, frame count, noise model and seed: frames rendered once, processed by every method;
    per-frame bump and road errors."""
    height_m, frame_count, noise, seed = item
    camera = sim.kitti_stereo(**NOISE_MODELS[noise])
    bump = sim.SpeedBump(BUMP_X_M, height_m, BUMP_LENGTH_M, y_min_m=0.8 - BUMP_HALF_WIDTH_M,
                         y_max_m=0.8 + BUMP_HALF_WIDTH_M)
    scene = sim.Scene(sim.Road(bumps=(bump,)))
    draw = int(round(height_m * 1000)) + 101 * seed  # seed 0: the draws of the tables in the README
    frames = sim.drive_stereo(scene, camera, SPEED_MPS, 0.0, frame_count, seed=draw)
    out = {"height": height_m}
    with tempfile.TemporaryDirectory() as tmp:
        calib = camera.write_calibration(Path(tmp) / "stereo.yaml")
        for method, variances in METHODS:
            cfg = rp.Config(extrinsics=camera.extrinsics(), fusion={"method": method}, obstacles={"enabled": False},
                            stereo=STEREO_CONFIGS[noise])
            est = rp.Estimator(cfg)
            record = {"bump": [], "road": [], "ms": []}
            readouts = {a: rp.ProfileReadout(a, cfg) for a in READ_AHEAD_M}
            for f in frames:
                found = rp.io.stereo_points(None, None, calib, disparity=f.disparity, config=cfg)
                res = est.process(found.points, SPEED_MPS, 0.0, timestamp=f.time_s,
                                  range_variances=found.range_variances if variances else None,
                                  error_groups=found.error_groups if variances else None)
                record["ms"].append(res.timing_ms["total"])
                for a, readout in readouts.items():
                    readout.add(res)
                    if readout_scores(readout, f.pose.x_m):
                        record[f"readout {a:g}"] = readout_errors(readout, f.pose.x_m, height_m)
                ahead = BUMP_X_M - f.pose.x_m
                if not BUMP_RANGE_M[0] <= ahead <= BUMP_RANGE_M[1]:
                    continue
                record["bump"].append(bump_height(np.asarray(res.left.s), np.asarray(res.left.z), ahead) - height_m)
                s, z = np.asarray(res.right.s), np.asarray(res.right.z)
                near = (s >= BUMP_RANGE_M[0]) & (s <= BUMP_RANGE_M[1]) & np.isfinite(z)
                record["road"].extend(z[near])  # the truth is 0 under the right wheel
            out[method_name(method, variances)] = record
    return out


def readout_scores(readout, driven_m: float) -> bool:
    """The first frame whose readout (the wheel to A ahead) holds the bump and the road around it."""
    first = BUMP_X_M + BUMP_AROUND_M - readout.ahead_m
    return first <= driven_m < first + SPEED_MPS * 0.1 and driven_m <= BUMP_X_M - BUMP_AROUND_M


def readout_errors(readout, driven_m: float, height_m: float) -> dict:
    """The bump's height error under the left wheel and the plain road's heights under the right, as read."""
    left, right = readout.left, readout.right
    return {"bump": bump_height(np.asarray(left.s), np.asarray(left.z), BUMP_X_M - driven_m) - height_m,
            "road": np.asarray(right.z)[np.isfinite(right.z)]}


def print_paper(results: list[dict]) -> None:
    rows = []
    for method, variances in METHODS:
        name = method_name(method, variances)
        bump = np.concatenate([r[name]["bump"] for r in results])
        road = np.abs(np.concatenate([r[name]["road"] for r in results]))
        ms = np.concatenate([r[name]["ms"] for r in results])
        rows.append([name, f"{np.sqrt(np.nanmean(bump ** 2)) * 100:.2f}", f"{np.nanmax(np.abs(bump)) * 100:.2f}",
                     f"{np.count_nonzero(np.isfinite(bump))}/{len(bump)}", f"{np.percentile(road, 95) * 100:.2f}",
                     f"{road.max() * 100:.2f}", f"{np.mean(road <= 0.003) * 100:.1f}", f"{np.median(ms):.1f}"])
    print("## The paper's experiment (simulated KITTI stereo, bumps 1–10 cm under the left wheel)\n")
    print(md_table(["method", "bump height RMSE cm", "bump max error cm", "bumps scored",
                    "plain road |z| 95th pct cm", "plain road max |z| cm", "plain road bins within ±0.3 cm %",
                    "pipeline ms / frame"], rows) + "\n")
    def rms_cm(height_m: float, name: str) -> str:  # over every sequence (seed) of the height
        errors = np.concatenate([r[name]["bump"] for r in results if r["height"] == height_m])
        return f"{np.sqrt(np.nanmean(np.square(errors))) * 100:.2f}"

    rows = [[f"{h * 100:.0f}"] + [rms_cm(h, method_name(m, v)) for m, v in METHODS]
            for h in sorted({r["height"] for r in results})]
    print(md_table(["bump cm", *(method_name(m, v) for m, v in METHODS)], rows) + "\n")
    print("The paper: RMSE 0.63 cm without its filter, 0.73 cm with it; road surface within ±0.5 cm.\n")
    rows = []
    for method, variances in METHODS:
        for a in READ_AHEAD_M:
            scored = [r[method_name(method, variances)].get(f"readout {a:g}") for r in results]
            bump = np.array([x["bump"] if x else math.nan for x in scored])
            road = np.abs(np.concatenate([x["road"] for x in scored if x] or [np.array([math.nan])]))
            rows.append([method_name(method, variances), f"{a:g}", f"{np.sqrt(np.nanmean(bump ** 2)) * 100:.2f}",
                         f"{np.nanmax(np.abs(bump)) * 100:.2f}", f"{np.count_nonzero(np.isfinite(bump))}/{len(bump)}",
                         f"{np.percentile(road, 95) * 100:.2f}", f"{np.max(road) * 100:.2f}",
                         f"{np.mean(road <= 0.003) * 100:.1f}"])
    print("### Read as the paper reads its profile: the readout A ahead (rp.ProfileReadout)\n")
    print(md_table(["method", "read ahead m", "bump height RMSE cm", "bump max error cm", "bumps scored",
                    "plain road |z| 95th pct cm", "plain road max |z| cm", "plain road bins within ±0.3 cm %"],
                   rows) + "\n")


# ------------------------------------------------------------------------------------------------ real pair
def disparity_errors(pair_dir: Path = PAIR) -> dict:
    """SGBM's disparity error at the pixels the Velodyne's road points fall on (bilinear in the disparity image,
    all four neighbours valid): the true disparity is u₂ − u₃ of the point projected by P2 and P3."""
    m = kitti_matrices(pair_dir / "calib.txt")
    velo_to_rect = np.eye(4)
    velo_to_rect[:3, :] = m["Tr_velo_to_cam"].reshape(3, 4)
    r0 = np.eye(4)
    r0[:3, :3] = m["R0_rect"].reshape(3, 3)
    points = rp.io.read(pair_dir / "lidar.bin")
    ground = rp.Estimator(rp.Config(sensor_height=LIDAR_HEIGHT_M)).process(points, 5.0, 0.0).ground_mask
    rect = r0 @ velo_to_rect @ np.c_[points[:, :3], np.ones(len(points))].T
    p2, p3 = m["P2"].reshape(3, 4) @ rect, m["P3"].reshape(3, 4) @ rect
    depth = p2[2]
    u = p2[0] / np.where(depth > 1, depth, np.nan)
    v = p2[1] / np.where(depth > 1, depth, np.nan)
    found = rp.io.stereo_points(pair_dir / "left.png", pair_dir / "right.png", pair_dir / "calib.txt",
                                config=rp.Config(sensor_height=LIDAR_HEIGHT_M))
    disparity = found.disparity
    rows, cols = disparity.shape
    inside = np.asarray(ground, bool) & (u >= 0) & (u < cols - 1) & (v >= found.first_row) & (v < rows - 1)
    i = np.flatnonzero(inside)
    u0, v0 = np.floor(u[i]).astype(int), np.floor(v[i]).astype(int)
    a, b = u[i] - u0, v[i] - v0
    corners = np.stack([disparity[v0, u0], disparity[v0, u0 + 1], disparity[v0 + 1, u0], disparity[v0 + 1, u0 + 1]])
    valid = np.all(corners > 0, axis=0)
    sgbm = corners[0] * (1 - a) * (1 - b) + corners[1] * a * (1 - b) + corners[2] * (1 - a) * b + corners[3] * a * b
    i, sgbm = i[valid], sgbm[valid]
    ring = rings_in_scan_order(points)[i]  # KITTI lists its points ring by ring
    truth = p2[0][i] / depth[i] - p3[0][i] / p3[2][i]
    return {"error": sgbm - truth, "truth": truth, "depth": depth[i], "u": u[i], "v": v[i], "ring": ring,
            "range_m": np.linalg.norm(points[i, :3], axis=1)}


def robust_sigma(x: np.ndarray) -> float:
    return float(1.4826 * np.median(np.abs(x - np.median(x))))


def print_noise(errors: dict, gross_px: float = 1.5) -> None:
    """The error per depth band, then its correlation along and across the rows after each ring's median error
    (the LiDAR ring's own calibration error, with any error common to the ring) is removed."""
    e, depth = errors["error"], errors["depth"]
    clean = np.abs(e - np.median(e)) < gross_px
    rows = []
    for lo, hi in ((5, 10), (10, 15), (15, 20), (20, 30), (30, 45)):
        band = (depth >= lo) & (depth < hi)
        lidar_px = np.median(errors["truth"][band] * LIDAR_RANGE_SIGMA_M / errors["range_m"][band])
        rows.append([f"{lo}–{hi}", int(band.sum()), f"{np.median(e[band]):+.3f}", f"{robust_sigma(e[band]):.3f}",
                     f"{np.mean(~clean[band]) * 100:.1f}", f"{lidar_px:.3f}"])
    print("## Disparity noise of the real pair (StereoSGBM against the Velodyne's road points)\n")
    print(md_table(["depth m", "points", "median error px", "robust σ px", f"beyond {gross_px:g} px %",
                    "the truth's own error (2 cm in range) px"], rows) + "\n")
    ring_median = {r: np.median(e[clean & (errors["ring"] == r)]) for r in np.unique(errors["ring"][clean])}
    residual = (e - np.array([ring_median.get(r, np.nan) for r in errors["ring"]]))[clean]
    u, v = errors["u"][clean], errors["v"][clean]
    from scipy.spatial import cKDTree  # the test extra's scipy: pairs of points within 40 px
    pairs = cKDTree(np.c_[u, v]).query_pairs(40.0, output_type="ndarray")
    du, dv = np.abs(np.diff(u[pairs], axis=1))[:, 0], np.abs(np.diff(v[pairs], axis=1))[:, 0]
    x, y = residual[pairs[:, 0]], residual[pairs[:, 1]]
    rows = []
    for lo, hi in ((1, 3), (3, 6), (6, 10), (10, 15), (15, 25), (25, 40)):
        along, across = (dv < 1) & (du >= lo) & (du < hi), (du < 2) & (dv >= lo) & (dv < hi)
        rows.append([f"{lo}–{hi}", *(f"{np.corrcoef(x[s], y[s])[0, 1]:.2f} ({s.sum()})" if s.sum() > 30 else "–"
                                     for s in (along, across))])
    print(f"Each ring's median error removed: robust σ {robust_sigma(residual):.3f} px; the rings' medians spread "
          f"{robust_sigma(np.array(list(ring_median.values()))):.3f} px ({len(ring_median)} rings).\n")
    print(md_table(["separation px", "correlation along a row, Δv < 1 px (pairs)",
                    "correlation across rows, Δu < 2 px (pairs)"], rows) + "\n")


def bin_noise_rows(seeds: int = 6) -> tuple[list[list[str]], list[list[str]]]:
    """One simulated frame of a flat road per seed and noise model: each wheel-path bin's height error (the truth
    is 0) against the σ the roughness stage gives its median, √(π/2 · spread² / count) (docs/method.md §4), with
    the points counted as independent and with their error groups (each group once), 5–20 m ahead; and, farther,
    the bins of a single point against the σ their point states (its spread)."""
    models = (("independent, 0.25 px", {}), ("independent, 0.3 px", {"disparity_noise_px": 0.3}),
              ("as measured (sim.SGBM_ON_KITTI)", sim.SGBM_ON_KITTI))
    far_bands = BANDS_M[3:]
    rows, single_rows = [], []
    for name, noise in models:
        camera = sim.kitti_stereo(**noise)
        errors = {band: [] for band in BANDS_M[:3]}
        stated = {grouped: {band: [] for band in BANDS_M[:3]} for grouped in (False, True)}
        single = {band: ([], []) for band in far_bands}  # errors, stated σ
        with tempfile.TemporaryDirectory() as tmp:
            calib = camera.write_calibration(Path(tmp) / "stereo.yaml")
            cfg = rp.Config(extrinsics=camera.extrinsics(), obstacles={"enabled": False})
            for seed in range(seeds):
                frame = sim.render(sim.Scene(sim.Road()), camera, sim.Pose(), np.random.default_rng(seed))
                found = rp.io.stereo_points(None, None, calib, disparity=frame.disparity, config=cfg)
                for grouped in (False, True):
                    res = rp.Estimator(cfg).process(found.points, SPEED_MPS, 0.0,
                                                    range_variances=found.range_variances,
                                                    error_groups=found.error_groups if grouped else None)
                    for p in (res.left, res.right):
                        s, z = np.asarray(p.s), np.asarray(p.z)
                        spread, count = np.asarray(p.spread), np.asarray(p.count)
                        for lo, hi in errors:
                            w = (s >= lo) & (s < hi) & (count >= 3) & np.isfinite(z)
                            if not grouped:  # the heights do not depend on the groups
                                errors[(lo, hi)].extend(z[w])
                            stated[grouped][(lo, hi)].extend(np.sqrt(np.pi / 2 * spread[w] ** 2 / count[w]))
                        for lo, hi in far_bands if grouped else ():
                            w = (s >= lo) & (s < hi) & (count == 1) & np.isfinite(z)
                            single[(lo, hi)][0].extend(z[w])
                            single[(lo, hi)][1].extend(spread[w])
        for band in errors:
            actual = np.sqrt(np.mean(np.square(errors[band])))
            as_points, as_groups = (np.median(stated[g][band]) for g in (False, True))
            rows.append([name, f"{band[0]}–{band[1]}", len(errors[band]), f"{actual * 100:.2f}",
                         f"{as_points * 100:.2f}", f"{actual / as_points:.1f}", f"{as_groups * 100:.2f}",
                         f"{actual / as_groups:.1f}"])
        for band, (err, sigma) in single.items():
            actual = np.sqrt(np.mean(np.square(err)))
            single_rows.append([name, f"{band[0]}–{band[1]}", len(err), f"{actual * 100:.2f}",
                                f"{np.median(sigma) * 100:.2f}", f"{actual / np.median(sigma):.1f}"])
    return rows, single_rows


def kitti_matrices(path: Path) -> dict:
    out = {}
    for line in path.read_text().splitlines():
        name, _, values = line.partition(":")
        if values.strip():
            out[name.strip()] = np.array(values.split(), float)
    return out


def camera_extrinsics(calib_path: Path, lidar_height_m: float) -> dict:
    """The colour camera's pose in the base frame on the road below the Velodyne: rectified camera 2 →
    rectified camera 0 (P2's offset) → Velodyne (R0_rect · Tr_velo_to_cam, inverted) → base (the height)."""
    m = kitti_matrices(calib_path)
    p2 = m["P2"].reshape(3, 4)
    velo_to_rect = np.eye(4)
    velo_to_rect[:3, :] = m["Tr_velo_to_cam"].reshape(3, 4)
    r0 = np.eye(4)
    r0[:3, :3] = m["R0_rect"].reshape(3, 3)
    rect_to_velo = np.linalg.inv(r0 @ velo_to_rect)
    centre = -np.linalg.solve(p2[:, :3], p2[:, 3])  # camera 2's optical centre in rectified camera 0
    optical_from_camera = np.array([[0, -1, 0], [0, 0, -1], [1, 0, 0]], float)  # x ahead, y left, z up → optical
    rotation = rect_to_velo[:3, :3] @ optical_from_camera
    origin = rect_to_velo[:3, :3] @ centre + rect_to_velo[:3, 3] + np.array([0.0, 0.0, lidar_height_m])
    return {"x_m": origin[0], "y_m": origin[1], "z_m": origin[2], "roll_rad": math.atan2(rotation[2, 1], rotation[2, 2]),
            "pitch_rad": -math.asin(rotation[2, 0]), "yaw_rad": math.atan2(rotation[1, 0], rotation[0, 0])}


def real_pair(pair_dir: Path = PAIR, **config) -> dict:
    """Both sensors through the same pipeline (5 m/s straight ahead, the motion is unknown for one frame);
    ``config``: further rp.Config fields for both."""
    camera_cfg = rp.Config(extrinsics=camera_extrinsics(pair_dir / "calib.txt", LIDAR_HEIGHT_M), **config)
    found = rp.io.stereo_points(pair_dir / "left.png", pair_dir / "right.png", pair_dir / "calib.txt",
                                config=camera_cfg)
    stereo = rp.Estimator(camera_cfg).process(found.points, 5.0, 0.0, source="left.png",
                                              range_variances=found.range_variances, error_groups=found.error_groups)
    lidar_points = rp.io.read(pair_dir / "lidar.bin")
    lidar = rp.Estimator(rp.Config(sensor_height=LIDAR_HEIGHT_M, **config)).process(lidar_points, 5.0, 0.0,
                                                                                  source="lidar.bin")
    return {"stereo": stereo, "lidar": lidar, "found": found, "extrinsics": camera_cfg.extrinsics}


def print_real(pair: dict) -> None:
    stereo, lidar = pair["stereo"], pair["lidar"]
    rows = []
    for wheel in ("left", "right"):
        a, b = getattr(stereo, wheel), getattr(lidar, wheel)
        s = np.asarray(a.s)
        both = (np.asarray(a.count) > 0) & (np.asarray(b.count) > 0)
        diff = np.asarray(a.z) - np.asarray(b.z)
        for lo, hi in BANDS_M:
            band = both & (s >= lo) & (s < hi)
            rms = f"{np.sqrt(np.mean(diff[band] ** 2)) * 100:.2f}" if band.any() else "–"
            bias = f"{np.median(diff[band]) * 100:+.2f}" if band.any() else "–"
            rows.append([wheel, f"{lo}–{hi}", str(np.count_nonzero(band)), rms, bias])
    print("## Real KITTI pair against the Velodyne scan of the same instant\n")
    e = pair["extrinsics"]
    print(f"Camera pose in the base frame (from calib.txt; base on the road below the Velodyne, {LIDAR_HEIGHT_M} m): "
          f"x {e.x_m:.3f}, y {e.y_m:.3f}, z {e.z_m:.3f} m, roll {math.degrees(e.roll_rad):.2f}°, "
          f"pitch {math.degrees(e.pitch_rad):.2f}°, yaw {math.degrees(e.yaw_rad):.2f}°. Stereo: "
          f"{len(pair['found'].points)} points from rows {pair['found'].first_row}–374, "
          f"{stereo.points['ground']} ground.\n")
    print(md_table(["wheel", "distance m", "bins with both", "RMS difference cm", "median difference cm"], rows) + "\n")
    rows = []
    for name, res in (("stereo", stereo), ("LiDAR", lidar)):
        cells = []
        for r in (res.left.roughness, res.right.roughness, res.vehicle):
            cells.append(f"{r.iso_class} ({r.gd_n0:.2e} m³)" if r.iso_class else f"– ({r.reason})")
        rows.append([name, *cells])
    print(md_table(["sensor", "left class", "right class", "vehicle class"], rows) + "\n")


def save_picture(pair: dict, path: Path) -> None:
    from roadpreview import plot

    fig = plot.plot_sensor_comparison({"stereo (SGBM)": pair["stereo"].to_dict(), "LiDAR (HDL-64E)": pair["lidar"].to_dict()},
                                      title="KITTI pair, 2011_09_26: wheel-path profiles, stereo vs LiDAR")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    print(f"Picture: {path.relative_to(REPO) if path.is_relative_to(REPO) else path}\n")


# ------------------------------------------------------------------------------------------------ timing
def spread(values: list[float]) -> str:
    return f"{statistics.median(values):.1f} ({min(values):.1f}–{max(values):.1f})"


WALL_STEPS = ("read + match + points", "match + points")  # also timed by the clock: what threads gain


def time_pair(runs: int) -> list[list[str]]:
    """Median (min–max) ms of each step per pair, road rows and whole image, 1 and 2 OpenCV threads: CPU time of
    this process (all its threads; on a busy machine the wall time mostly measures the queue for a core)."""
    import cv2  # the images, preloaded, to time matching without the PNG decoding

    left = cv2.imread(str(PAIR / "left.png"), cv2.IMREAD_GRAYSCALE)
    right = cv2.imread(str(PAIR / "right.png"), cv2.IMREAD_GRAYSCALE)
    extrinsics = camera_extrinsics(PAIR / "calib.txt", LIDAR_HEIGHT_M)
    rows = []
    for rows_name, rise in (("road rows", 2.0), ("whole image", 1e6)):
        for threads in (1, 2):
            cfg = rp.Config(extrinsics=extrinsics, stereo={"threads": threads, "road_rise_m": rise})
            est = rp.Estimator(cfg)
            steps = {"read + match + points": lambda: rp.io.stereo_points(PAIR / "left.png", PAIR / "right.png",
                                                                          PAIR / "calib.txt", config=cfg),
                     "match + points": lambda: rp.io.stereo_points(left, right, PAIR / "calib.txt", config=cfg)}
            found = steps["match + points"]()
            steps["points"] = lambda: rp.io.stereo_points(None, None, PAIR / "calib.txt", disparity=found.disparity,
                                                          config=cfg)
            steps["pipeline"] = lambda: est.process(found.points, 5.0, 0.0, range_variances=found.range_variances,
                                                    error_groups=found.error_groups)
            times = {name: [] for name in steps}
            wall = {name: [] for name in WALL_STEPS}
            for k in range(runs + 1):  # the first run warms up
                for name, step in steps.items():
                    start, start_wall = time.process_time(), time.perf_counter()
                    step()
                    if k:
                        times[name].append((time.process_time() - start) * 1000)
                        if name in wall:
                            wall[name].append((time.perf_counter() - start_wall) * 1000)
            total = [a + b for a, b in zip(times["read + match + points"], times["pipeline"])]
            rows.append([rows_name, str(found.first_row), str(len(found.points)), str(threads),
                         *(spread(times[name]) for name in steps), spread(total),
                         *(spread(wall[name]) for name in WALL_STEPS)])
    return rows


def print_timing(rows: list[list[str]], runs: int) -> None:
    print(f"## Time per KITTI pair (1242 × 375): CPU ms of the process, median (min–max) of {runs} runs\n")
    print(md_table(["rows matched", "first row", "points", "OpenCV threads", "read + match + points",
                    "match + points", "points", "pipeline", "total CPU", *(f"{name}, wall ms" for name in WALL_STEPS)],
                   rows) + "\n")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="one bump, 3 timing runs (smoke test)")
    parser.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1), help="worker processes")
    parser.add_argument("--runs", type=int, default=15, help="timing runs per setting")
    parser.add_argument("--picture", type=Path, help="write the stereo-vs-LiDAR profile picture here")
    parser.add_argument("--parts", default="paper,real,noise,timing", help="comma-separated parts to run")
    parser.add_argument("--seeds", type=int, default=1, help="noise draws per bump height in the paper's experiment")
    parser.add_argument("--noise", choices=sorted(NOISE_MODELS), default="independent",
                        help="the simulated camera's disparity noise in the paper's experiment")
    args = parser.parse_args(argv)
    heights, frames = ((0.05,), FRAMES) if args.quick else (HEIGHTS_M, FRAMES)
    runs = 3 if args.quick else args.runs
    start = time.perf_counter()
    print("# roadpreview stereo benchmark\n")
    parts = set(args.parts.split(","))
    print(f"- Python {platform.python_version()}, numpy {np.__version__}, roadpreview {rp.__version__}; "
          f"1-min load {os.getloadavg()[0]:.1f}\n")
    if "paper" in parts:
        items = [(h, frames, args.noise, seed) for seed in range(args.seeds) for h in heights]
        results = run_in_pool(paper_run, items, args.jobs, lambda r: f"bump {r['height'] * 100:.0f} cm")
        print(f"- {len(items)} sequences of {frames} frames at 10 Hz, {SPEED_MPS:g} m/s, {args.noise} disparity "
              f"noise {NOISE_MODELS[args.noise] or '(0.25 px)'}; "
              f"{time.perf_counter() - start:.0f} s on {args.jobs} worker(s)\n")
        print_paper(results)
    if not (PAIR / "left.png").exists():
        print(f"(the KITTI pair is not at {PAIR}: real-pair comparison and timing skipped)")
        return 0
    if "real" in parts:
        pair = real_pair()
        print_real(pair)
        if args.picture:
            save_picture(pair, args.picture)
    if "noise" in parts:
        print_noise(disparity_errors())
        print("## The bins' noise, simulated (a flat road, one frame per seed, σ_d 0.4 px in the config)\n")
        rows, single_rows = bin_noise_rows(2 if args.quick else 6)
        print(md_table(["disparity noise", "distance m", "bins", "height error RMS cm",
                        "stated σ, points independent, median cm", "error / stated",
                        "stated σ, error groups, median cm", "error / stated"], rows) + "\n")
        print("Bins of a single point, against the σ their point states:\n")
        print(md_table(["disparity noise", "distance m", "bins", "height error RMS cm", "stated σ, median cm",
                        "error / stated"], single_rows) + "\n")
    if "timing" in parts:
        print_timing(time_pair(runs), runs)
    print(f"1-min load at the end: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
