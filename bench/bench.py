"""Benchmark of the roadpreview pipeline: stage timings and ground-segmentation quality.

What it measures, printed as Markdown tables on stdout (progress goes to stderr):

1. Timing, single-threaded, per stage (ground, path, profile, roughness) and in total, as median (min–max)
   in milliseconds, for both ground methods (``pca``, ``ransac``):
   * the C++ pipeline: ``Estimator.process`` repeated ``--repeat`` times after 3 warm-up calls, each stage
     read from ``Result.timing_ms`` (measured inside C++; "ground" includes the frame transform and the ROI
     crop); the wall time of the Python call is shown beside it;
   * the numpy reference: the chain of ``roadpreview.reference.pipeline.process`` timed stage by stage with
     ``time.perf_counter`` (``--ref-repeat`` runs after 1 warm-up). The reference's ``wheel_profile`` also
     analyses each wheel's roughness, so the bench calls its steps (levelling, arc length, bin medians, gap
     filling) and the roughness functions separately — checked once to give wheel_profile's profiles — so
     the split matches the C++ one (roughness = both wheels + vehicle).
   Frames: every ``tests/data/semantickitti/*.bin`` (sensor height 1.73 m) and a synthetic 131,072-point
   Ouster OS1-128-sized frame (128 beams × 1024 columns, sensor 1.8 m high, see :func:`ouster_frame`).
   Motion: 5 m/s and 0.1 rad/s, so the wheel paths are arcs.
2. Ground quality of the C++ ground mask against the SemanticKITTI labels (``*.label`` beside each
   ``.bin``): precision, recall and F1 inside the ROI x ∈ [1, 40] m, |y| ≤ 10 m, unlabelled points excluded.
   The synthetic frame, whose ground truth is known from the ray casting, is shown too (not in the mean).
3. Point counts per frame: input, finite, ROI, and ground for each method and implementation.
4. The default pipeline (``rp.Config`` defaults but the sensor height: ground, obstacles, paths, profiles,
   roughness), C++ stage times as in 1., on each KITTI frame and the first frame of the bundled OS1-128
   recording (``OS1_128_PCAP``, 1.97 m high), in sensor order and shuffled (one random permutation of the
   rows, seed 0): median (min–max) per stage, shuffled/ordered ratio of the total median, and whether the
   shuffled run gave the same ground, clusters and profiles (its masks and labels mapped back to the rows).

Usage: ``python bench/bench.py [--repeat N] [--ref-repeat N] [--quick] [--default-only]``
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

# Single-threaded numpy: the BLAS thread count must be fixed before numpy is imported.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

import roadpreview as rp  # noqa: E402
from roadpreview.reference.frames import check_points  # noqa: E402
from roadpreview.reference.ground import roi_mask  # noqa: E402
from roadpreview.reference.path import check_motion  # noqa: E402
from roadpreview.reference import profile as ref_profile  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
KITTI_DIR = REPO / "tests" / "data" / "semantickitti"
OUSTER_META = REPO / "tests" / "data" / "ouster" / "OS-1-128_v2.3.0_1024x10.json"  # beam angles
OS1_128_PCAP = REPO / "tests" / "data" / "ouster" / "OS-1-128_v2.3.0_1024x10_lb_n3.pcap"  # a real frame

SPEED_MPS = 5.0
YAW_RATE_RPS = 0.1
KITTI_SENSOR_HEIGHT_M = 1.73
OUSTER_SENSOR_HEIGHT_M = 1.8
OS1_128_SENSOR_HEIGHT_M = 1.97  # the recording's ground level (README, "Two commands")
METHODS = ("zones", "pca", "ransac")
PATCHWORK = "Patchwork++"
STAGES = ("ground", "path", "profile", "roughness", "total")
CPP_WARMUP = 3
REF_WARMUP = 1

GROUND_CLASSES = (40, 44, 48, 49, 60, 72)  # road, parking, sidewalk, other-ground, lane-marking, terrain
UNLABELLED = 0
ROI_X_M = (1.0, 40.0)
ROI_Y_ABS_M = 10.0

TARGET_TOTAL_MS = 1.5
DEFAULT_STAGES = ("ground", "obstacles", "path", "profile", "roughness", "total")
TARGET_SHUFFLED_RATIO = 1.2  # shuffled total / sensor-ordered total
SHUFFLE_SEED = 0
BUSY_LOAD = 0.5  # 1-min load average above which the timings are flagged
PAPER_MS = {"ground": 9.88, "profile": 0.74, "roughness": 0.37, "total": 10.96}  # Seok et al. 2024, Table 2
FIELD_NOTES_F1 = {"plain PCA ×3 (0.2 m)": 0.953, "Patchwork++ 1.4.1": 0.957}
TARGET_F1 = 0.97  # issue 10: front-ROI F1, mean over the labelled frames, default method


# ------------------------------------------------------------------------------------------------ frames
@dataclass
class Frame:
    """One benchmark frame: sensor-frame points, mounting height and, if known, per-point ground truth."""

    name: str
    points: np.ndarray
    sensor_height: float
    truth: Optional[np.ndarray] = None  #: bool per point: ground
    scored: Optional[np.ndarray] = None  #: bool per point: has a label (counts in the metrics)
    synthetic: bool = False


def kitti_frames() -> list[Frame]:
    frames = []
    for path in sorted(KITTI_DIR.glob("*.bin")):
        points = rp.io.read(path)
        truth = scored = None
        label_path = path.with_suffix(".label")
        if label_path.exists():
            classes = np.fromfile(label_path, dtype=np.uint32) & 0xFFFF
            if len(classes) != len(points):
                raise RuntimeError(f"{label_path}: {len(classes)} labels for {len(points)} points")
            truth, scored = np.isin(classes, GROUND_CLASSES), classes != UNLABELLED
        frames.append(Frame(path.stem, points, KITTI_SENSOR_HEIGHT_M, truth, scored))
    return frames


def beam_altitudes_deg(meta_path: Path) -> tuple[np.ndarray, str]:
    """The 128 beam altitude angles of an Ouster OS1-128 metadata file."""
    try:
        return np.asarray(json.loads(meta_path.read_text())["beam_altitude_angles"], float), meta_path.name
    except (OSError, KeyError, ValueError) as err:
        sys.exit(f"bench: {meta_path}: cannot read beam_altitude_angles ({err})")


def ground_height(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Gently undulating ground, a few cm of sinusoids (base frame, metres)."""
    return (0.03 * np.sin(2 * np.pi * x / 11.0) + 0.015 * np.sin(2 * np.pi * x / 3.7 + 0.5)
            + 0.01 * np.sin(2 * np.pi * (0.3 * x + y) / 2.3) + 0.02 * np.sin(2 * np.pi * y / 17.0))


# Boxes standing on the ground, base frame: (x_min, x_max, y_min, y_max, height).
BOXES = (
    (10.0, 14.5, 2.6, 4.4, 1.5),  # parked car, left
    (18.0, 22.5, -5.0, -3.2, 1.6),  # parked car, right
    (30.0, 30.4, 6.0, 6.4, 2.5),  # post
    (-8.0, -3.5, -1.0, 0.8, 1.5),  # car behind
    (-30.0, 60.0, 12.0, 13.0, 4.0),  # wall beside the road, outside the ROI
)


def ray_ground(origin_z: float, d: np.ndarray, max_range: float, steps: int = 40) -> np.ndarray:
    """Range along unit rays d to the ground surface by bisection (inf where the ray has not reached it)."""
    def above(t):
        return origin_z + t * d[:, 2] - ground_height(t * d[:, 0], t * d[:, 1])

    hits = above(np.full(len(d), max_range)) < 0
    lo, hi = np.zeros(len(d)), np.full(len(d), max_range)
    for _ in range(steps):
        mid = (lo + hi) / 2
        below = above(mid) < 0
        hi, lo = np.where(below, mid, hi), np.where(below, lo, mid)
    return np.where(hits, hi, np.inf)


def ray_box(origin_z: float, d: np.ndarray, box: tuple) -> np.ndarray:
    """Range along unit rays d to an axis-aligned box (slab method; inf where missed)."""
    x0, x1, y0, y1, height = box
    lower, upper = np.array([x0, y0, -0.3]), np.array([x1, y1, height])
    origin = np.array([0.0, 0.0, origin_z])
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (lower - origin) / d, (upper - origin) / d
    t_near = np.nanmax(np.minimum(t0, t1), axis=1)
    t_far = np.nanmin(np.maximum(t0, t1), axis=1)
    return np.where((t_near <= t_far) & (t_near > 0), t_near, np.inf)


def ouster_frame(meta_path: Path, seed: int = 0, max_range: float = 100.0) -> tuple[Frame, str]:
    """A 131,072-point OS1-128-sized frame ray-cast from 1.8 m onto undulating ground with a few boxes.

    Row-major 128 beams × 1024 columns, sensor frame; 1 cm Gaussian range noise; rays without a return
    within ``max_range`` are NaN rows (as an Ouster driver leaves them). Ground truth: the ray hit the ground.
    """
    altitudes, source = beam_altitudes_deg(meta_path)
    elevation = np.radians(altitudes)[:, None]
    azimuth = 2 * np.pi * np.arange(1024)[None, :] / 1024
    d = np.stack(np.broadcast_arrays(np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth),
                                     np.sin(elevation)), axis=-1).reshape(-1, 3)
    h = OUSTER_SENSOR_HEIGHT_M
    t_ground = ray_ground(h, d, max_range)
    t_box = np.min([ray_box(h, d, box) for box in BOXES], axis=0)
    t = np.minimum(t_ground, t_box)
    hit = t <= max_range
    rng = np.random.default_rng(seed)
    t_noisy = t + rng.normal(0.0, 0.01, len(t))
    points = np.full((len(d), 4), np.nan, dtype=np.float32)
    points[hit, :3] = d[hit] * t_noisy[hit, None]
    points[hit, 3] = 1.0
    truth = hit & (t_ground <= t_box)
    return Frame("synthetic OS1-128", points, h, truth, hit, synthetic=True), source


def os1_128_frame() -> Frame:
    """The first frame of the bundled OS1-128 recording (sensor frame, ordered by beam and column)."""
    points = next(iter(rp.io.open(OS1_128_PCAP))).points
    return Frame("OS1-128 recording, frame 0", points, OS1_128_SENSOR_HEIGHT_M)


# ------------------------------------------------------------------------------------------------ timing
def config(frame: Frame, method: str) -> rp.Config:
    """The paper's pipeline: the obstacle stage (not in the paper, timed by bench/obstacles.py) is off."""
    return rp.Config(sensor_height=frame.sensor_height, ground={"method": method}, obstacles={"enabled": False})


def time_cpp(frame: Frame, method: str, repeat: int):
    """Per-run stage times (ms) of the C++ pipeline plus the Python call's wall time, and the last result."""
    est = rp.Estimator(config(frame, method))
    for _ in range(CPP_WARMUP):
        est.process(frame.points, SPEED_MPS, YAW_RATE_RPS)
    runs = []
    for _ in range(repeat):
        start = time.perf_counter()
        res = est.process(frame.points, SPEED_MPS, YAW_RATE_RPS)
        wall = (time.perf_counter() - start) * 1e3
        runs.append({**{s: res.timing_ms[s] for s in STAGES}, "call": wall})
    return runs, res


def reference_wheel_bins(ground_xyz, plane, path: dict, wheel: str, speed: float, yaw_rate: float,
                         cfg: rp.Config) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(z, count, spread) of ``reference.wheel_profile`` without its roughness analysis (timed apart)."""
    xyz = ground_xyz
    if cfg.profile.level:
        xyz = ref_profile.level_points(xyz, plane)
        if cfg.profile.level_local:
            xyz[:, 2] = ref_profile.local_ground_heights(ground_xyz, plane, cfg, path, math.copysign(1.0, speed))
    s, in_corridor = ref_profile.arc_length(xyz[:, :2], path, wheel, speed, yaw_rate, cfg)
    median, count, spread = ref_profile.bin_statistics(s[in_corridor], xyz[in_corridor, 2], cfg)
    return ref_profile.fill_gaps(median, cfg.profile.ds_m, cfg.profile.max_gap_m), count, spread


def reference_once(points: np.ndarray, cfg: rp.Config):
    """One run of the reference chain (as in reference.pipeline.process), timed per stage.

    Returns (ms per stage, ground mask, (left z, right z, base-frame ground points, plane, path)).
    """
    ref = rp.reference
    ms = {"profile": 0.0, "roughness": 0.0}
    mark = time.perf_counter()

    def lap() -> float:
        nonlocal mark
        now = time.perf_counter()
        elapsed, mark = (now - mark) * 1e3, now
        return elapsed

    speed, yaw_rate = check_motion(SPEED_MPS, YAW_RATE_RPS)
    path = ref.plan_path(speed, yaw_rate, cfg)
    ms["path"] = lap()
    base_xyz, finite = ref.to_base_frame(check_points(points), cfg)
    np.count_nonzero(roi_mask(base_xyz, cfg))  # the ROI count the pipeline reports
    ground, plane = ref.fit_ground(base_xyz, cfg)
    mask = np.zeros(len(points), dtype=bool)
    mask[np.flatnonzero(finite)[ground]] = True
    ms["ground"] = lap()
    profiles = None
    if plane is not None and path["status"] != "stopped":
        ground_xyz = base_xyz[ground]
        (zl, cl, sl), (zr, cr, sr) = (reference_wheel_bins(ground_xyz, plane, path, wheel, speed, yaw_rate, cfg)
                                      for wheel in ("left", "right"))
        ms["profile"] = lap()
        ds = cfg.profile.ds_m
        for z, count, spread in ((zl, cl, sl), (zr, cr, sr)):  # noise-aware, as the C++ pipeline
            ref.analyze_roughness(z, ds, cfg, count=count, spread=spread)
        ref.vehicle_roughness(zl, zr, ds, cfg, count_left=cl, spread_left=sl, count_right=cr, spread_right=sr)
        ms["roughness"] = lap()
        profiles = (zl, zr, ground_xyz, plane, path)
    ms["total"] = sum(ms.values())
    return ms, mask, profiles


def check_profiles_match(profiles, cfg: rp.Config) -> None:
    """The timed profile chain must give the profiles of ``reference.wheel_profile`` itself."""
    if profiles is None:
        return
    *z, ground_xyz, plane, path = profiles
    for wheel, wheel_z in zip(("left", "right"), z):
        expected = rp.reference.wheel_profile(ground_xyz, plane, path, wheel, SPEED_MPS, YAW_RATE_RPS, cfg).z
        if not np.array_equal(wheel_z, expected, equal_nan=True):
            raise RuntimeError(f"bench profile chain disagrees with reference.wheel_profile ({wheel} wheel)")


def time_reference(frame: Frame, method: str, repeat: int):
    cfg = config(frame, method)
    for _ in range(REF_WARMUP):
        _, _, profiles = reference_once(frame.points, cfg)
        check_profiles_match(profiles, cfg)
    runs = [reference_once(frame.points, cfg) for _ in range(repeat)]
    return [ms for ms, _, _ in runs], runs[-1][1]


def time_default(points: np.ndarray, sensor_height: float, repeat: int, threads: int = 1):
    """Per-run stage times (ms) of the default pipeline (obstacles on) on `threads` threads and the last result."""
    est = rp.Estimator(rp.Config(sensor_height=sensor_height, threads=threads))
    for _ in range(CPP_WARMUP):
        est.process(points, SPEED_MPS, YAW_RATE_RPS)
    runs = []
    for _ in range(repeat):
        res = est.process(points, SPEED_MPS, YAW_RATE_RPS)
        runs.append({s: res.timing_ms[s] for s in DEFAULT_STAGES})
    return runs, res


def same_answer(ordered, shuffled, permutation: np.ndarray) -> bool:
    """Whether a shuffled frame's result is the ordered frame's: masks and labels per row, planes, profiles."""
    def rows(values) -> np.ndarray:
        back = np.empty_like(np.asarray(values))
        back[permutation] = np.asarray(values)  # shuffled row i is original row permutation[i]
        return back

    same = (np.array_equal(rows(shuffled.ground_mask), np.asarray(ordered.ground_mask))
            and np.array_equal(rows(shuffled.cluster_labels), np.asarray(ordered.cluster_labels))
            and np.allclose(shuffled.plane, ordered.plane, rtol=0, atol=1e-12))
    for wheel in ("left", "right"):
        a, b = getattr(ordered, wheel), getattr(shuffled, wheel)
        same = same and np.array_equal(a.count, b.count) and np.allclose(a.z, b.z, rtol=0, atol=1e-9, equal_nan=True)
    return bool(same)


def run_default(frame: Frame, args) -> dict:
    print(f"{frame.name}: default pipeline ordered and shuffled, ×{args.repeat} each", file=sys.stderr)
    permutation = np.random.default_rng(SHUFFLE_SEED).permutation(len(frame.points))
    ordered, res_ordered = time_default(frame.points, frame.sensor_height, args.repeat, args.threads)
    shuffled, res_shuffled = time_default(np.ascontiguousarray(frame.points[permutation]), frame.sensor_height,
                                          args.repeat, args.threads)
    return {"frame": frame.name, "n": len(frame.points), "ordered": ordered, "shuffled": shuffled,
            "roi": res_ordered.points["roi"], "clusters": len(res_ordered.obstacles.count),
            "same": same_answer(res_ordered, res_shuffled, permutation)}


# ------------------------------------------------------------------------------------------------ Patchwork++
def patchwork_ground(frame: Frame, repeat: int):
    """(ground mask, ms per run) of Patchwork++ (pypatchworkpp, default parameters but the sensor height) on the
    whole sensor-frame cloud, or None when the package is not installed."""
    try:
        import pypatchworkpp
    except ImportError:
        return None
    params = pypatchworkpp.Parameters()
    params.sensor_height = frame.sensor_height
    estimator = pypatchworkpp.patchworkpp(params)
    cloud = np.ascontiguousarray(frame.points[:, :4], dtype=np.float64)
    times = []
    for k in range(CPP_WARMUP + repeat):
        start = time.perf_counter()
        estimator.estimateGround(cloud)
        if k >= CPP_WARMUP:
            times.append((time.perf_counter() - start) * 1e3)
    mask = np.zeros(len(cloud), dtype=bool)
    mask[np.asarray(estimator.getGroundIndices(), dtype=np.int64)] = True
    return mask, times


def patchwork_version() -> str:
    try:
        from importlib.metadata import version

        return version("pypatchworkpp")
    except Exception:  # not installed
        return ""


# ------------------------------------------------------------------------------------------------ quality
def roi(points: np.ndarray) -> np.ndarray:
    """The ROI in x, y (the base frame differs from the sensor frame only by the height)."""
    x, y = points[:, 0], points[:, 1]
    return (x >= ROI_X_M[0]) & (x <= ROI_X_M[1]) & (np.abs(y) <= ROI_Y_ABS_M)


def ground_quality(frame: Frame, mask: np.ndarray) -> dict:
    """Precision, recall and F1 of a ground mask inside the ROI over the labelled points."""
    scored = roi(frame.points) & frame.scored
    pred, truth = mask[scored], frame.truth[scored]
    tp = np.count_nonzero(pred & truth)
    precision = tp / max(np.count_nonzero(pred), 1)
    recall = tp / max(np.count_nonzero(truth), 1)
    f1 = 2 * precision * recall / (precision + recall) if precision + recall else 0.0
    return {"precision": precision, "recall": recall, "f1": f1, "scored": int(np.count_nonzero(scored)),
            "truth": int(np.count_nonzero(truth))}


# ------------------------------------------------------------------------------------------------ output
def md_table(headers: list[str], rows: list[list]) -> str:
    lines = ["| " + " | ".join(headers) + " |", "|" + "|".join("---" for _ in headers) + "|"]
    lines += ["| " + " | ".join(str(cell) for cell in row) + " |" for row in rows]
    return "\n".join(lines)


def median(runs: list[dict], key: str) -> float:
    return float(np.median([run[key] for run in runs]))


def spread(runs: list[dict], key: str) -> str:
    values = [run[key] for run in runs]
    middle = float(np.median(values))
    digits = max(2, 1 - math.floor(math.log10(middle))) if middle > 0 else 2  # at least 2 significant
    return f"{middle:.{digits}f} ({min(values):.{digits}f}–{max(values):.{digits}f})"


def ratio(numerator: float, denominator: float) -> str:
    value = numerator / denominator
    return f"{value:.1f}×" if value < 10 else f"{value:.0f}×"


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def print_header(args, ouster_source: str, load_at_start: float) -> None:
    print("# roadpreview benchmark\n")
    print(f"- Machine: {cpu_model()}, {os.cpu_count()} logical cores; 1-min load average {load_at_start:.2f} "
          f"at start, {os.getloadavg()[0]:.2f} at end; Python {platform.python_version()}, "
          f"numpy {np.__version__}, roadpreview {rp.__version__}")
    if load_at_start > BUSY_LOAD:
        print("- **Other processes were busy when the run started**: expect inflated maxima (and medians of "
              "the compute-bound stages, e.g. RANSAC); rerun on an idle machine for the record.")
    print(f"- Single-threaded (C++ core; numpy with {os.environ['OPENBLAS_NUM_THREADS']} BLAS thread). "
          f"Motion {SPEED_MPS} m/s, {YAW_RATE_RPS} rad/s (arc). C++: median (min–max) of {args.repeat} runs "
          f"after {CPP_WARMUP} warm-up; reference: median (min–max) of {args.ref_repeat} run(s) after {REF_WARMUP} "
          "warm-up. All times in ms.")
    print(f"- Synthetic OS1-128 frame: 128 × 1024 rays from {OUSTER_SENSOR_HEIGHT_M} m, beam altitudes from "
          f"{ouster_source}, undulating ground (±~6 cm), {len(BOXES)} boxes, 1 cm range noise, "
          "no return beyond 100 m = NaN, seed 0.\n")


def print_timing(results: list[dict], args) -> None:
    headers = ["frame", "points", "method", *STAGES]
    cpp_rows, ref_rows = [], []
    for r in results:
        key = [r["frame"], r["n"], r["method"]]
        cpp_rows.append(key + [spread(r["cpp"], s) for s in STAGES] + [spread(r["cpp"], "call")])
        ratios = [ratio(median(r["ref"], s), median(r["cpp"], s)) for s in ("ground", "total")]
        ref_rows.append(key + [spread(r["ref"], s) for s in STAGES] + ratios)
    print("## Timing: C++ pipeline (Result.timing_ms, ms)\n")
    print(md_table(headers + ["Python call"], cpp_rows) + "\n")
    print("## Timing: numpy reference (perf_counter around the reference stages, ms)\n")
    print(md_table(headers + ["ref/C++ ground", "ref/C++ total"], ref_rows) + "\n")
    print("Paper (Seok et al., Trans. KSAE 32(5):413, 2024, Table 2; i7-13700K, 131,072-point OS1-128 frame):\n")
    print(md_table(["", "ground", "profile", "roughness", "total"],
                   [["paper, ms", *(f"{PAPER_MS[s]:.2f}" for s in ("ground", "profile", "roughness", "total"))]]))
    print(f"\nTarget: total ≤ {TARGET_TOTAL_MS} ms per 131,072-point frame on this machine (C++, median; "
          "the paper's ground method is `pca`, the default `zones`).")
    for r in results:
        if r["synthetic"]:
            total = median(r["cpp"], "total")
            verdict = "met" if total <= TARGET_TOTAL_MS else "NOT met"
            print(f"- {r['frame']}, {r['method']}: {total:.2f} ms → {verdict} "
                  f"({PAPER_MS['total'] / total:.1f}× faster than the paper's total)")
    print()


def print_quality(results: list[dict], peers: list[dict]) -> None:
    rows, labelled = [], {m: [] for m in (*METHODS, PATCHWORK)}
    for r in results + peers:
        if r["quality"] is None:
            continue
        q = r["quality"]
        name = r["frame"] + (" (not in mean)" if r["synthetic"] else "")
        rows.append([name, r["method"], f"{q['precision']:.3f}", f"{q['recall']:.3f}", f"{q['f1']:.3f}",
                     q["scored"]])
        if not r["synthetic"]:
            labelled[r["method"]].append(q)
    for method in (*METHODS, PATCHWORK):
        qs = labelled[method]
        if qs:
            rows.append([f"**mean of {len(qs)} labelled frames**", method,  # mean of the per-frame values
                         *(f"{np.mean([q[k] for q in qs]):.3f}" for k in ("precision", "recall", "f1")), ""])
    print(f"## Ground quality: C++ ground mask vs labels, ROI x ∈ [{ROI_X_M[0]:g}, {ROI_X_M[1]:g}] m, "
          f"|y| ≤ {ROI_Y_ABS_M:g} m, unlabelled points excluded\n")
    print(md_table(["frame", "method", "precision", "recall", "F1", "scored points"], rows) + "\n")
    default = rp.Config().ground.method
    if labelled[default]:
        f1 = np.mean([q["f1"] for q in labelled[default]])
        print(f"Target (default method `{default}`): mean F1 ≥ {TARGET_F1} → {f1:.3f}, "
              f"{'met' if f1 >= TARGET_F1 else 'NOT met'}.\n")
    if not peers:
        print(f"{PATCHWORK} was not measured: `pip install .[peers]` (pypatchworkpp) to add it to this run.\n")
    else:
        print(f"{PATCHWORK}: pypatchworkpp {patchwork_version()}, default parameters with the sensor height, whole "
              "frame (its ground indices scored in the same region), measured in this run.\n")
    notes = ", ".join(f"{name} F1 {value:.3f}" for name, value in FIELD_NOTES_F1.items())
    print(f"Surveyed earlier inside the same region on the 4 labelled frames: {notes} "
          "(the project's shared field notes, FIELD-NOTES.md, \"Peers measured here\").\n")


def print_ground_timing(results: list[dict], peers: list[dict]) -> None:
    """The ground stage alone per labelled frame and method (C++ Result.timing_ms.ground; Patchwork++ wall time)."""
    rows = []
    for r in results + peers:
        if not r["synthetic"]:
            rows.append([r["frame"], r["method"], spread(r["cpp"], "ground")])
    print("## Timing: ground stage per KITTI frame (ms, median (min–max); ours include the frame transform and "
          "ROI crop, Patchwork++ runs on the whole frame)\n")
    print(md_table(["frame", "method", "ground"], rows) + "\n")


def print_counts(results: list[dict]) -> None:
    by_frame: dict[str, dict] = {}
    for r in results:
        by_frame.setdefault(r["frame"], {})[r["method"]] = r
    rows = []
    for name, per_method in by_frame.items():
        first = next(iter(per_method.values()))
        points = first["counts"]
        truth = first["quality"]["truth"] if first["quality"] else "–"
        cells = []
        for method in METHODS:
            r = per_method[method]
            cells.append(f"{r['counts']['ground']} / {int(r['ref_mask'].sum())} / {r['mask_diff']}")
        rows.append([name, points["input"], points["finite"], points["roi"], truth, *cells])
    print("## Point counts\n")
    print(md_table(["frame", "input", "finite", "ROI", "labelled ground in ROI",
                    *(f"ground {m} (C++ / ref / differing)" for m in METHODS)], rows) + "\n")
    print("ROI and ground counts are the C++ `Result.points`; \"differing\" counts points whose ground label "
          "differs between the C++ and reference masks (RANSAC samples differ: PCL's generator vs numpy's).")


def print_default(results: list[dict], args) -> None:
    print(f"## Timing: default pipeline (ground {rp.Config().ground.method} + obstacles + roughness), sensor "
          "order vs shuffled (Result.timing_ms, ms)\n")
    threads = "single-threaded" if args.threads == 1 else f"{args.threads} threads"
    print(f"Median (min–max) of {args.repeat} runs after {CPP_WARMUP} warm-up, {threads}; motion "
          f"{SPEED_MPS} m/s, {YAW_RATE_RPS} rad/s; shuffled = one random permutation of the rows (seed "
          f"{SHUFFLE_SEED}); \"same\" = the shuffled frame gave the ordered frame's ground mask, cluster labels, "
          "plane and profiles.\n")
    rows = []
    for r in results:
        for order in ("ordered", "shuffled"):
            tail = [f"{median(r['shuffled'], 'total') / median(r['ordered'], 'total'):.2f}",
                    "yes" if r["same"] else "NO"] if order == "shuffled" else ["", ""]
            rows.append([r["frame"], r["n"], r["roi"], r["clusters"], order,
                         *(spread(r[order], s) for s in DEFAULT_STAGES), *tail])
    print(md_table(["frame", "points", "ROI points", "clusters", "order", *DEFAULT_STAGES, "shuffled / ordered",
                    "same"], rows) + "\n")
    kitti = [r for r in results if not r["frame"].startswith("OS1-128")]
    worst_total = max(median(r[o], "total") for r in kitti for o in ("ordered", "shuffled"))
    worst_ratio = max(median(r["shuffled"], "total") / median(r["ordered"], "total") for r in results)
    print(f"Targets: total ≤ {TARGET_TOTAL_MS} ms per KITTI frame — worst median {worst_total:.2f} ms → "
          f"{'met' if worst_total <= TARGET_TOTAL_MS else 'NOT met'}; shuffled ≤ {TARGET_SHUFFLED_RATIO}× "
          f"sensor order — worst ratio {worst_ratio:.2f} → "
          f"{'met' if worst_ratio <= TARGET_SHUFFLED_RATIO else 'NOT met'}.\n")


# ------------------------------------------------------------------------------------------------ main
def run_frame(frame: Frame, method: str, args) -> dict:
    print(f"{frame.name}: {method} C++ ×{args.repeat}, reference ×{args.ref_repeat}", file=sys.stderr)
    cpp_runs, res = time_cpp(frame, method, args.repeat)
    ref_runs, ref_mask = time_reference(frame, method, args.ref_repeat)
    mask = np.asarray(res.ground_mask, dtype=bool)
    quality = ground_quality(frame, mask) if frame.truth is not None else None
    return {"frame": frame.name, "n": len(frame.points), "synthetic": frame.synthetic, "method": method,
            "cpp": cpp_runs, "ref": ref_runs,
            "counts": dict(res.points), "quality": quality, "ref_mask": ref_mask,
            "mask_diff": int(np.count_nonzero(mask != ref_mask))}


def run_patchwork(frame: Frame, args):
    measured = patchwork_ground(frame, args.repeat)
    if measured is None:
        return None
    print(f"{frame.name}: {PATCHWORK} ×{args.repeat}", file=sys.stderr)
    mask, times = measured
    return {"frame": frame.name, "synthetic": False, "method": PATCHWORK, "quality": ground_quality(frame, mask),
            "cpp": [{"ground": t} for t in times]}


def parse_args(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=30, help="timed C++ runs per frame and method")
    parser.add_argument("--ref-repeat", type=int, default=5, help="timed numpy-reference runs")
    parser.add_argument("--quick", action="store_true", help="3 C++ runs and 1 reference run (smoke test)")
    parser.add_argument("--ouster-meta", type=Path, default=OUSTER_META,
                        help="Ouster metadata JSON with beam_altitude_angles")
    parser.add_argument("--threads", type=int, default=1,
                        help="threads a frame may use in the default pipeline's table")
    parser.add_argument("--default-only", action="store_true",
                        help="only the default pipeline's table, ordered vs shuffled")
    args = parser.parse_args(argv)
    if args.quick:
        args.repeat, args.ref_repeat = 3, 1
    if args.repeat < 1 or args.ref_repeat < 1:
        parser.error("--repeat and --ref-repeat must be at least 1")
    return args


def main(argv=None) -> int:
    args = parse_args(argv)
    load_at_start = os.getloadavg()[0]
    frames = kitti_frames()
    default_results = [run_default(frame, args) for frame in [*frames, os1_128_frame()]]
    synthetic, ouster_source = ouster_frame(args.ouster_meta)
    frames.append(synthetic)
    results = [] if args.default_only else [run_frame(frame, method, args) for frame in frames for method in METHODS]
    peers = [] if args.default_only else [run_patchwork(frame, args) for frame in frames if frame.truth is not None]
    peers = [p for p in peers if p is not None]
    print_header(args, ouster_source, load_at_start)
    if results:
        print_timing(results, args)
        print_ground_timing(results, peers)
        print_quality(results, peers)
        print_counts(results)
    print_default(default_results, args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
