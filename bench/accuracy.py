"""Accuracy benchmark: simulated roads of known roughness, scanned by simulated LiDARs, through the C++ pipeline.

A fixed suite (roadpreview.sim, every random draw seeded):
  * ISO 8608 classes A–F × straight and curved (R = 50 m) paths × OS1-128, HDL-64E and VLP-16;
  * speed bumps 2–10 cm high (1 m long, raised cosine) on a smooth (class A) road, OS1-128;
  * cars and a wall beside the path on a class C road, OS1-128;
  * a class C road with 6 % grade and 4 % cross-slope, straight and curved, OS1-128;
  * classes B and C seen by an HDL-64E whose beams miss their table angles by 0.03° (1σ), the size of the
    per-beam height offsets measured on the bundled KITTI frame (README, "Accuracy").
Each is a sequence of 10 frames at 10 Hz, driving at 10 m/s, sensor 1.8 m high, run twice: frame by frame
(fusion "none") and through the temporal fusion's elevation map (fusion "kalman", docs/method.md §7).

Printed (Markdown, progress on stderr):
  * per scenario and fusion: sequence class (exact, within one), frames classified, per-frame class and median
    |log2(G_d(n0) estimate / truth)|, bins backed by data in the first 30 m, profile RMSE vs truth (cm), bump
    height error (cm), ground precision / recall vs the per-point labels, C++ ms per frame;
  * the bump height error per bump height, single frame and fused;
  * what one frame resolves per range: bins backed by points, spacing of the points, the highest frequency
    that spacing resolves, and the profile error, per sensor; and the bins the fused map backs there.
  * repeatability (docs/method.md §9), a measure that needs no truth: the same stretch of road seen by the first
    frame 14–24 m ahead and by the last 5–15 m ahead, frame by frame, beside what a noise-free sensor with the
    same rings allows; the same stretch in the last frames of two passes over the class C–D roads; and on every
    real recording with poses (the OS1-128 pcap, KITTI seq 00 frames 0–5 from the shared data), with their fused
    classes frame by frame.
Definitions are in bench/README.md. Usage: ``python bench/accuracy.py [--quick] [--jobs N] [--match TEXT]``.
"""

from __future__ import annotations

import argparse
import math
import multiprocessing
import os
import platform
import sys
import time
from dataclasses import dataclass, field, replace
from types import SimpleNamespace
from typing import Optional

import numpy as np

import roadpreview as rp
from roadpreview import sim

import real_recordings

SPEED_MPS = 10.0
CURVE_YAW_RATE_RPS = 0.2  # radius 50 m at 10 m/s
FRAMES = 10
SENSOR_HEIGHT_M = 1.8
CLASSES = "ABCDEF"
SENSORS = {"OS1-128": sim.os1_128, "HDL-64E": sim.hdl_64e, "VLP-16": sim.vlp_16}
FUSION = ("none", "kalman")  # frame by frame, and the fused map (bench/fusion.py compares EMA too)
COVERAGE_M = 30.0  # the temporal fusion issue's coverage target is over the first 30 m
BUMP_HEIGHTS_M = (0.02, 0.04, 0.06, 0.08, 0.10)
BUMP_X_M = 14.05  # seen from 14 m ahead down to 5 m in the 10 frames
BUMP_LENGTH_M = 1.0
BUMP_RANGE_M = (5.0, 12.0)  # frames whose bump lies this far ahead score its height
BEAM_ERROR_DEG = 0.03  # per-beam elevation error of the calibration scenarios
RANGE_BUCKETS_M = ((4, 8), (8, 12), (12, 16), (16, 25), (25, 40))
NEAR_M = (5.0, 15.0)  # repeatability: the stretch as the last frame sees it; the first saw it further ahead
REPEATED_CLASSES = "CD"  # roads driven twice for the repeated-pass repeatability
SECOND_PASS_S = 0.037  # the second pass's frames lie 0.37 m further along the path: its rings fall elsewhere
WHEELS = ("left", "right")
ROI_X_M, ROI_Y_ABS_M = (1.0, 40.0), 10.0
SCENE_BOXES = (
    sim.Box(10.0, 14.5, 2.4, 4.2, 1.5),  # parked car, left
    sim.Box(18.0, 22.5, -4.4, -2.6, 1.6),  # parked car, right
    sim.Box(-20.0, 80.0, 5.5, 5.8, 2.5),  # wall along the left
    sim.Box(30.0, 30.3, -3.0, -2.7, 2.5),  # post
)


@dataclass(frozen=True)
class Scenario:
    group: str
    name: str
    sensor: str
    iso_class: str = "A"
    seed: int = 0
    yaw_rate: float = 0.0
    grade: float = 0.0
    cross_slope: float = 0.0
    bump_height: float = 0.0
    boxes: tuple = ()
    elevation_error_deg: float = 0.0
    frames: int = FRAMES

    def scene(self) -> sim.Scene:
        bumps = (sim.SpeedBump(BUMP_X_M, self.bump_height, BUMP_LENGTH_M),) if self.bump_height else ()
        road = sim.Road.iso8608(self.iso_class, seed=self.seed, grade=self.grade, cross_slope=self.cross_slope,
                                bumps=bumps)
        return sim.Scene(road, self.boxes)


def suite(quick: bool) -> list[Scenario]:
    if quick:
        return [Scenario("classes", "class C, straight", "OS1-128", "C", seed=3, frames=3),
                Scenario("classes", "class C, straight", "VLP-16", "C", seed=3, frames=3),
                Scenario("bumps", "bump 6 cm", "OS1-128", bump_height=0.06)]
    out = []
    for sensor in SENSORS:
        for k, iso_class in enumerate(CLASSES):
            for path, yaw_rate in (("straight", 0.0), ("curved", CURVE_YAW_RATE_RPS)):
                out.append(Scenario("classes", f"class {iso_class}, {path}", sensor, iso_class, 10 * k + 1, yaw_rate))
    for h in BUMP_HEIGHTS_M:
        out.append(Scenario("bumps", f"bump {h * 100:.0f} cm", "OS1-128", "A", seed=50, bump_height=h))
    out.append(Scenario("scene", "cars and a wall, class C", "OS1-128", "C", seed=60, boxes=SCENE_BOXES))
    for path, yaw_rate in (("straight", 0.0), ("curved", CURVE_YAW_RATE_RPS)):
        out.append(Scenario("slope", f"6 % grade, 4 % bank, class C, {path}", "OS1-128", "C", 70, yaw_rate,
                            grade=0.06, cross_slope=0.04))
    for iso_class in "BC":
        out.append(Scenario("calibration", f"class {iso_class}, beams off by 0.03°", "HDL-64E", iso_class, 80,
                            elevation_error_deg=BEAM_ERROR_DEG))
    return out


# ------------------------------------------------------------------------------------------------ one run
def detrended_rms(s: np.ndarray, error: np.ndarray, band_m: Optional[float] = None) -> float:
    """RMS of a profile error after removing its least-squares line: profiles are heights above the fitted
    ground plane, which takes up the road's long waves over the region of interest as an offset and tilt. With
    band_m, a line per band of band_m along s: the local levelling's bands (docs/method.md §3), each of whose
    planes takes up its own offset and grade (waves longer than ~1.5 band_m)."""
    if len(error) < 3:
        return math.nan
    band = np.floor(s / band_m) if band_m else np.zeros(len(s))
    residual = np.array(error, dtype=float)
    for k in np.unique(band):
        inside = band == k
        if inside.sum() >= 3:
            residual[inside] -= np.polyval(np.polyfit(s[inside], error[inside], 1), s[inside])
        else:
            residual[inside] -= np.mean(error[inside])
    return float(np.sqrt(np.mean(residual**2)))


def bump_height(s: np.ndarray, z: np.ndarray, s_bump: float) -> float:
    """Crest (max within ±0.3 m) minus the median of the road 1–2.5 m before and after; NaN if not seen."""
    crest = np.abs(s - s_bump) <= 0.3
    around = (np.abs(s - s_bump) >= 1.0) & (np.abs(s - s_bump) <= 2.5)
    if not np.isfinite(z[crest]).any() or np.isfinite(z[around]).sum() < 5:
        return math.nan
    return float(np.nanmax(z[crest]) - np.nanmedian(z[around]))


def range_stats(profile, truth_z: np.ndarray) -> list[dict]:
    """Per range bucket (by arc length ahead): bins backed by points, the median spacing of the points around a
    bin (the interval between the backed bins it lies in), and the profile error."""
    s, z, count = np.asarray(profile.s), np.asarray(profile.z), np.asarray(profile.count)
    backed = np.flatnonzero(count > 0)
    spacing = np.full(len(s), np.nan)
    for a, b in zip(backed[:-1], backed[1:]):
        spacing[a:b] = s[b] - s[a]
    out = []
    for lo, hi in RANGE_BUCKETS_M:
        inside = (s >= lo) & (s < hi)
        valid = inside & np.isfinite(z)
        known = inside & np.isfinite(spacing)
        out.append({"backed": np.count_nonzero(inside & (count > 0)) / np.count_nonzero(inside),
                    "spacing": float(np.median(spacing[known])) if known.any() else math.nan,
                    "error": detrended_rms(s[valid], (z - truth_z)[valid]) if valid.sum() > 5 else math.nan})
    return out


def ground_counts(frame: sim.Frame, mask: np.ndarray) -> np.ndarray:
    """(true positives, predicted ground, true ground) in the ROI, points that returned."""
    x, y = frame.points[:, 0], frame.points[:, 1]  # the base frame differs by the height (no tilt here)
    scored = np.isfinite(x) & (x >= ROI_X_M[0]) & (x <= ROI_X_M[1]) & (np.abs(y) <= ROI_Y_ABS_M)
    truth = frame.labels == sim.LABEL_ROAD
    return np.array([np.count_nonzero(mask & truth & scored), np.count_nonzero(mask & scored),
                     np.count_nonzero(truth & scored)])


def levelling_band_m(cfg) -> Optional[float]:
    """The band length of the local levelling, None when one plane levels the frame."""
    return cfg.profile.level_band_m if cfg.profile.level_local else None


def measure(res, frame: sim.Frame, truth: dict, scenario: Scenario, band_m: Optional[float]) -> dict:
    """One frame's result against the truth; profile errors detrended per levelling band of band_m (None: one
    plane levels the frame)."""
    record = {"gd_n0": res.vehicle.gd_n0, "class": res.vehicle.iso_class, "confidence": res.vehicle.confidence,
              "band": res.vehicle.band, "ms": res.timing_ms["total"],
              "ground": ground_counts(frame, np.asarray(res.ground_mask)), "rms": [], "rms_all": [],
              "bump": [], "ranges": [], "coverage": []}
    for wheel in WHEELS:
        profile, truth_z = getattr(res, wheel), truth[wheel]
        s, z, count = np.asarray(profile.s), np.asarray(profile.z), np.asarray(profile.count)
        record["rms"].append(detrended_rms(s[count > 0], (z - truth_z)[count > 0], band_m))
        record["rms_all"].append(detrended_rms(s[np.isfinite(z)], (z - truth_z)[np.isfinite(z)], band_m))
        record["ranges"].append(range_stats(profile, truth_z))
        record["coverage"].append(float(np.mean(count[s < COVERAGE_M] > 0)))
        if scenario.bump_height:
            ahead = BUMP_X_M - frame.pose.x_m
            if BUMP_RANGE_M[0] <= ahead <= BUMP_RANGE_M[1]:
                record["bump"].append(bump_height(s, z, ahead) - scenario.bump_height)
    return record


def run(scenario: Scenario) -> dict:
    """Simulate one scenario and process it frame by frame and fused; per-frame measurements of each."""
    scene = scenario.scene()
    lidar = SENSORS[scenario.sensor](height_m=SENSOR_HEIGHT_M, elevation_error_deg=scenario.elevation_error_deg,
                                     calibration_seed=scenario.seed)
    frames = sim.drive(scene, lidar, SPEED_MPS, scenario.yaw_rate, scenario.frames, seed=scenario.seed)
    truths = [sim.truth_profiles(scene, f.pose, SPEED_MPS, scenario.yaw_rate) for f in frames]
    second = repeated_pass(scenario, scene, lidar)
    cfg = rp.Config(extrinsics=lidar.extrinsics())
    travel = {w: wheel_travel(SPEED_MPS * (frames[-1].time_s - frames[0].time_s), scenario.yaw_rate, w, cfg)
              for w in WHEELS}
    out = {"scenario": scenario, "rings": ring_repeatability(scenario, scene, lidar, frames, travel)}
    for method in FUSION:
        est = rp.Estimator(rp.Config(extrinsics=lidar.extrinsics(), fusion={"method": method}))
        results = [est.process(f.points, SPEED_MPS, scenario.yaw_rate, timestamp=f.time_s) for f in frames]
        out[method] = [measure(res, f, truth, scenario, levelling_band_m(est.config))
                       for res, f, truth in zip(results, frames, truths)]
        out[method][0]["repeatability"] = [frame_repeatability(getattr(results[0], w), getattr(results[-1], w),
                                                               travel[w]) for w in WHEELS]
        if second:
            est = rp.Estimator(rp.Config(extrinsics=lidar.extrinsics(), fusion={"method": method}))
            again = [est.process(f.points, SPEED_MPS, scenario.yaw_rate, timestamp=f.time_s) for f in second][-1]
            out[method][0]["passes"] = [
                pass_repeatability(getattr(results[-1], w), getattr(again, w), travel[w],
                                   wheel_travel(SPEED_MPS * second[-1].time_s, scenario.yaw_rate, w, cfg))
                for w in WHEELS]
    return out


def repeated_pass(scenario: Scenario, scene: sim.Scene, lidar: sim.Lidar) -> list:
    """A second drive over a class C–D road of the classes group (new noise, frames SECOND_PASS_S later along the
    same path, so the rings fall elsewhere), as profiler certification repeats runs; [] for other scenarios."""
    if scenario.group != "classes" or scenario.iso_class not in REPEATED_CLASSES:
        return []
    return sim.drive(scene, lidar, SPEED_MPS, scenario.yaw_rate, scenario.frames, seed=scenario.seed + 1000,
                     start_s=SECOND_PASS_S)


def ring_repeatability(scenario: Scenario, scene: sim.Scene, lidar: sim.Lidar, frames: list, travel: dict) -> list:
    """frame_repeatability of what a noise-free sensor with this beam table gives the first and last frame
    (sim.ring_profiles: the exact relief where the rings cross the wheel paths): what the ring spacing allows."""
    first, last = (sim.ring_profiles(scene, lidar, f.pose, SPEED_MPS, scenario.yaw_rate) for f in (frames[0], frames[-1]))
    return [frame_repeatability(SimpleNamespace(s=first["s"], z=first[w]), SimpleNamespace(s=last["s"], z=last[w]),
                                travel[w]) for w in WHEELS]


def wheel_travel(travelled_m: float, yaw_rate: float, wheel: str, cfg) -> float:
    """Arc length a wheel rolls while the vehicle's origin travels travelled_m at this yaw rate."""
    if yaw_rate == 0.0:
        return travelled_m
    radius = SPEED_MPS / yaw_rate
    y_wheel = cfg.track_width / 2 * (1 if wheel == "left" else -1)
    return travelled_m * abs(radius - y_wheel) / abs(radius)


def frame_repeatability(first, last, travelled_m: float) -> rp.Repeatability:
    """The stretch the last frame's profile holds NEAR_M ahead, against the first frame's view of it."""
    return pass_repeatability(last, first, travelled_m, 0.0)


def pass_repeatability(profile, other, travelled_m: float, other_travelled_m: float) -> rp.Repeatability:
    """The stretch `profile` holds NEAR_M ahead, its wheel having rolled travelled_m along the path since t = 0,
    against `other`'s view of it from other_travelled_m."""
    grid = np.arange(*NEAR_M, 0.1) + 0.05 + travelled_m
    return rp.repeatability(rp.world_profile(other.s, other.z, other_travelled_m, grid),
                            rp.world_profile(profile.s, profile.z, travelled_m, grid), 0.1)


# ------------------------------------------------------------------------------------------------ summary
def class_index(c: str) -> int:
    return "ABCDEFGH".index(c)


def sequence_class(frames: list[dict], method: str):
    """Frame by frame: the geometric mean of the classified frames' G_d(n0) when at least half of the frames are
    classified. Fused: the last frame's class (its map holds the whole sequence)."""
    if method != "none":
        last = frames[-1]
        return last["class"], last["gd_n0"] if last["class"] else None
    values = [f["gd_n0"] for f in frames if f["class"] is not None]
    if 2 * len(values) < len(frames):
        return None, None
    gd = float(np.exp(np.mean(np.log(values))))
    return rp.reference.iso_class(gd), gd


def summarise(results: list[dict], method: str) -> dict:
    s = {"sequences": 0, "seq_classified": 0, "seq_exact": 0, "seq_within": 0, "frames": 0, "classified": 0,
         "exact": 0, "within": 0, "log2": [], "rms": [], "rms_all": [], "bump": [], "ground": np.zeros(3), "ms": [],
         "coverage": []}
    for r in results:
        sc, truth_class = r["scenario"], r["scenario"].iso_class
        truth_gd = sim.class_gd_n0(truth_class)
        if sc.group != "bumps":
            s["sequences"] += 1
            seq, _ = sequence_class(r[method], method)
            if seq is not None:
                s["seq_classified"] += 1
                s["seq_exact"] += seq == truth_class
                s["seq_within"] += abs(class_index(seq) - class_index(truth_class)) <= 1
        for f in r[method]:
            s["frames"] += 1
            s["coverage"] += f["coverage"]
            s["ground"] += f["ground"]
            s["ms"].append(f["ms"])
            s["rms"] += [v for v in f["rms"] if np.isfinite(v)]
            s["rms_all"] += [v for v in f["rms_all"] if np.isfinite(v)]
            s["bump"] += [v for v in f["bump"] if np.isfinite(v)]
            if f["class"] is not None and sc.group != "bumps":
                s["classified"] += 1
                s["exact"] += f["class"] == truth_class
                s["within"] += abs(class_index(f["class"]) - class_index(truth_class)) <= 1
                s["log2"].append(abs(math.log2(f["gd_n0"] / truth_gd)) if f["gd_n0"] > 0 else math.inf)
    return s


def fraction(part: int, whole: int) -> str:
    return f"{part}/{whole} ({100 * part / whole:.0f} %)" if whole else "–"


def row(name: str, sensor: str, method: str, s: dict, classes: bool = True) -> list[str]:
    tp, predicted, truth = s["ground"]
    median = lambda v, scale=1.0, digits=2: f"{np.median(v) * scale:.{digits}f}" if len(v) else "–"  # noqa: E731
    bump = (f"{np.sqrt(np.mean(np.square(s['bump']))) * 100:.2f} / {np.max(np.abs(s['bump'])) * 100:.2f} "
            f"(n = {len(s['bump'])})") if s["bump"] else "–"
    cls = [fraction(s["seq_exact"], s["sequences"]), fraction(s["seq_within"], s["sequences"]),
           fraction(s["classified"], s["frames"]), fraction(s["exact"], s["classified"]),
           fraction(s["within"], s["classified"]), median(s["log2"])] if classes else ["–"] * 6
    return [name, sensor, method, *cls, f"{100 * np.mean(s['coverage']):.0f}",
            f"{median(s['rms'], 100)} / {median(s['rms_all'], 100)}", bump,
            f"{tp / max(predicted, 1):.3f} / {tp / max(truth, 1):.3f}", median(s["ms"])]


def md_table(headers: list[str], rows: list[list]) -> str:
    lines = ["| " + " | ".join(headers) + " |", "|" + "|".join("---" for _ in headers) + "|"]
    return "\n".join(lines + ["| " + " | ".join(str(c) for c in r) + " |" for r in rows])


def print_accuracy(results: list[dict]) -> None:
    rows = []
    for sensor in SENSORS:
        classes = [r for r in results if r["scenario"].group == "classes" and r["scenario"].sensor == sensor]
        name = f"classes {''.join(sorted({r['scenario'].iso_class for r in classes}))}, straight + curved"
        rows += [row(name, sensor, m, summarise(classes, m)) for m in FUSION if classes]
    bumps = [r for r in results if r["scenario"].group == "bumps"]
    heights = sorted({f"{r['scenario'].bump_height * 100:.0f}" for r in bumps}, key=float)
    span = f"{heights[0]}–{heights[-1]}" if len(heights) > 1 else "".join(heights)
    rows += [row(f"bumps {span} cm", "OS1-128", m, summarise(bumps, m), classes=False) for m in FUSION if bumps]
    for group in ("scene", "slope", "calibration"):
        for r in (r for r in results if r["scenario"].group == group):
            rows += [row(r["scenario"].name, r["scenario"].sensor, m, summarise([r], m)) for m in FUSION]
    print("## Accuracy against the simulator's truth\n")
    print(md_table(["scenario", "sensor", "fusion", "sequence class exact", "sequence within one", "frames classified",
                    "frame class exact", "frame within one", "median abs log2 G_d(n0) error",
                    f"bins backed 0–{COVERAGE_M:g} m %", "profile RMSE cm (backed / all)",
                    "bump height error cm (RMSE / max)", "ground precision / recall", "ms / frame"], rows) + "\n")


def print_bumps(results: list[dict]) -> None:
    rows = []
    for r in (r for r in results if r["scenario"].group == "bumps"):
        errors = [summarise([r], m)["bump"] for m in FUSION]
        rows.append([f"{r['scenario'].bump_height * 100:.0f}"] + [
            f"{np.sqrt(np.mean(np.square(e))) * 100:.2f} / {np.max(np.abs(e)) * 100:.2f}" if e else "–"
            for e in errors])
    if rows:
        print("## Bump height error by height (cm, RMSE / max over frames and wheels)\n")
        print(md_table(["bump cm", *FUSION], rows) + "\n")


def print_classes(results: list[dict]) -> None:
    rows = []
    for r in (r for r in results if r["scenario"].group == "classes"):
        cells = []
        for method in FUSION:
            seq, gd = sequence_class(r[method], method)
            frames = "".join(f["class"] or "·" for f in r[method])
            cells += [seq or "declined", f"{gd * 1e6:.0f}" if gd else "–", frames]
        rows.append([r["scenario"].name, r["scenario"].sensor, *cells])
    print("## Per sequence (vehicle result; frame classes in order, · = declined)\n")
    headers = [f"{m}: {h}" for m in FUSION for h in ("class", "G_d(n0) 10⁻⁶ m³", "frames")]
    print(md_table(["scenario", "sensor", *headers], rows) + "\n")


def print_ranges(results: list[dict]) -> None:
    rows = []
    for sensor in SENSORS:
        chosen = [r for r in results if r["scenario"].group == "classes" and r["scenario"].sensor == sensor]
        stats = [rs for r in chosen for f in r["none"] for rs in f["ranges"]]
        fused = [rs for r in chosen for rs in r[FUSION[-1]][-1]["ranges"]]  # the map after the whole sequence
        if not stats:
            continue
        for i, (lo, hi) in enumerate(RANGE_BUCKETS_M):
            backed = [s[i]["backed"] for s in stats]
            spacings = [s[i]["spacing"] for s in stats if np.isfinite(s[i]["spacing"])]
            spacing = float(np.median(spacings)) if spacings else math.nan
            error = [s[i]["error"] for s in stats if np.isfinite(s[i]["error"])]
            resolved = f"{1 / (2 * max(spacing, 0.1)):.2f}" if np.isfinite(spacing) else "–"
            rows.append([sensor, f"{lo}–{hi} m", f"{np.mean(backed):.2f}",
                         f"{spacing:.2f}" if np.isfinite(spacing) else "–", resolved,
                         f"{np.median(error) * 100:.2f}" if error else "–",
                         f"{np.mean([s[i]['backed'] for s in fused]):.2f}"])
    print("## What one frame resolves, by distance ahead (classes A–F, both paths, both wheels)\n")
    print(md_table(["sensor", "ahead", "bins backed by points", "median spacing of points (m)",
                    "resolvable up to (cycles/m)", "profile RMSE (cm)",
                    f"bins backed, {FUSION[-1]} map after the sequence"], rows) + "\n")


def correlations(reps: list) -> str:
    """'median (min), n/N' of the correlations of those repeatabilities that have one."""
    values = [x.correlation for x in reps if x.correlation is not None]
    return f"{np.median(values):.3f} ({np.min(values):.3f}), {len(values)}/{len(reps)}" if values else f"–, 0/{len(reps)}"


def median_rms_cm(reps: list) -> str:
    rms = [x.rms_m for x in reps if x.rms_m is not None]
    return f"{np.median(rms) * 100:.2f}" if rms else "–"


def wheel_correlations(reps: list) -> str:
    return " / ".join("–" if x.correlation is None else f"{x.correlation:.3f}" for x in reps)


def print_repeatability(results: list[dict]) -> None:
    rows = []
    for sensor in SENSORS:
        for group, classes in (("classes C–D", REPEATED_CLASSES), ("classes A–F", CLASSES)):
            picked = [r for r in results if r["scenario"].sensor == sensor and r["scenario"].group == "classes"
                      and r["scenario"].iso_class in classes]
            for method in FUSION:
                pairs = [(x, ring) for r in picked for x, ring in zip(r[method][0]["repeatability"], r["rings"])]
                if pairs:
                    rings_compared = [ring for x, ring in pairs if x.correlation is not None]
                    rows.append([sensor, group, method, correlations([x for x, _ in pairs]),
                                 median_rms_cm([x for x, _ in pairs]), correlations([ring for _, ring in pairs]),
                                 correlations(rings_compared)])
    print(f"## Repeatability: {NEAR_M[0]:g}–{NEAR_M[1]:g} m ahead in the last frame vs the first frame's view\n")
    print("Correlation of the IRI-filtered profiles: median (min), wheels with a common stretch of 5 m / wheels. "
          "'Perfect rings': the same for a noise-free sensor with this beam table (sim.ring_profiles: the exact "
          "relief where the rings cross the wheel paths, linear in between), what the ring spacing allows; over "
          "all wheels, and over the wheels the pipeline compared.\n")
    print(md_table(["sensor", "roads", "fusion", "correlation", "RMS difference cm (median)",
                    "perfect rings: all wheels", "perfect rings: wheels compared"], rows) + "\n")
    passes = [r for r in results if "passes" in r[FUSION[0]][0]]
    if not passes:
        return
    print(f"## Repeatability of repeated passes: {NEAR_M[0]:g}–{NEAR_M[1]:g} m ahead in the last frame of two "
          "drives over the same road\n")
    print(f"The second drive's frames lie {SPEED_MPS * SECOND_PASS_S:g} m further along the path, its noise drawn "
          "anew (profiler certification's repeated runs, AASHTO R 56). Correlation left / right.\n")
    rows = [[r["scenario"].sensor, r["scenario"].name] + [wheel_correlations(r[m][0]["passes"]) for m in FUSION]
            + [median_rms_cm(r[FUSION[-1]][0]["passes"])] for r in passes]
    for sensor in SENSORS:
        picked = [r for r in passes if r["scenario"].sensor == sensor]
        if picked:
            rows.append([f"**{sensor}**", "median (min), compared"]
                        + [correlations([x for r in picked for x in r[m][0]["passes"]]) for m in FUSION]
                        + [median_rms_cm([x for r in picked for x in r[FUSION[-1]][0]["passes"]])])
    print(md_table(["sensor", "road"] + [f"correlation, {m}" for m in FUSION]
                   + [f"RMS difference cm, {FUSION[-1]} (median)"], rows) + "\n")


def run_in_pool(work, items: list, jobs: int, describe) -> list:
    """work(item) for every item on `jobs` spawned processes, in order; progress (describe(result)) on stderr."""
    results = []
    with multiprocessing.get_context("spawn").Pool(jobs) as pool:
        for r in pool.imap(work, items):
            results.append(r)
            print(f"[{len(results)}/{len(items)}] {describe(r)}", file=sys.stderr)
    return results


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="three short sequences (smoke test)")
    parser.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1), help="worker processes")
    parser.add_argument("--match", action="append", default=[],
                        help="run only the scenarios whose 'sensor name' contains TEXT (repeatable)")
    args = parser.parse_args(argv)
    if args.jobs < 1:
        parser.error("--jobs must be at least 1")
    scenarios = [sc for sc in suite(args.quick)
                 if not args.match or any(m.lower() in f"{sc.sensor} {sc.name}".lower() for m in args.match)]
    if not scenarios:
        parser.error(f"no scenario matches {args.match}")
    start = time.perf_counter()
    results = run_in_pool(run, scenarios, args.jobs, lambda r: f"{r['scenario'].sensor} {r['scenario'].name}")
    print("# roadpreview accuracy benchmark\n")
    print(f"- {len(scenarios)} sequences of {scenarios[0].frames if args.quick else FRAMES} frames at 10 Hz, "
          f"{SPEED_MPS:g} m/s, sensor {SENSOR_HEIGHT_M} m high; {time.perf_counter() - start:.0f} s on "
          f"{args.jobs} worker(s); Python {platform.python_version()}, numpy {np.__version__}, "
          f"roadpreview {rp.__version__}\n")
    print_accuracy(results)
    print_bumps(results)
    print_classes(results)
    print_ranges(results)
    print_repeatability(results)
    real_recordings.print_tables(args.quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
