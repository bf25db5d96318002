"""Beam self-calibration benchmark (docs/method.md §8): offsets recovered on simulated drives, and classes before
and after calibration on simulated and real recordings.

Simulated: a class B road (ISO 8608), straight, 10 m/s, 10 Hz, sensor 1.8 m high, HDL-64E whose beams miss their
table angles (a) by 0.03° (1σ, normal; the size measured on KITTI, README "Accuracy") and (b) by uniform offsets
up to 0.1°. The drive is calibrated (C++, rp.calibrate_beams, the simulator's exact poses), its frames corrected
with the result (BeamCalibration.apply), and both versions go through the fused pipeline (kalman) like the
accuracy benchmark's calibration rows. Errors are against the truth in the same gauge (its fit by
a + b/reach + c·reach over the determined beams removed).

Real: the six KITTI seq 00 frames (three in tests/data/semantickitti, three in the shared data) with the seq 00
ground-truth poses, and the bundled OS1-128 recording with its poses: per-beam offsets, and the vehicle class of
every frame before and after (single frame and fused).

Consistency and transfer on KITTI (both methods): the offsets calibrated from frames 0–2 and from frames 3–5
compared beam by beam, and the vehicle class, G_d(n0) and IRI of every frame and of the SPVNAS frame (another
street) before and after a calibration that did not see it (surface method: from the other half of seq 00; the
SPVNAS frame: from all six).

Usage: ``python bench/calibration.py [--quick] [--frames N] [--cell M] [--method motion|surface]`` (default 20
frames, a 19 m drive, the calibration's default 0.2 m cells, method motion); prints Markdown, progress on stderr.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

import roadpreview as rp
from roadpreview import sim
from roadpreview.reference import calibration as ref

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared" / "data"  # the project's shared data beside the repository (--shared overrides)
SPEED_MPS = 10.0
SENSOR_HEIGHT_M = 1.8
KITTI_HEIGHT_M = 1.73
OS1_HEIGHT_M = 1.97
OS1_PCAP = REPO / "tests" / "data" / "ouster" / "OS-1-128_v2.3.0_1024x10_lb_n3.pcap"
OS1_POSES = REPO / "tests" / "data" / "ouster" / "OS-1-128_v2.3.0_1024x10_lb_n3_poses_kitti.txt"
# KITTI poses are of the left camera (x right, y down, z forward); the Velodyne's axes are x forward, y left, z up
CAMERA_TO_VELODYNE = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def log(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def md_table(headers, rows) -> str:
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    return "\n".join(lines + ["| " + " | ".join(str(c) for c in r) + " |" for r in rows])


def vehicle_classes(frames, cfg: rp.Config, poses=None, speed_mps: float = SPEED_MPS) -> list:
    """The vehicle class of every frame through one estimator ('-' when declined)."""
    est = rp.Estimator(cfg)
    out = []
    for k, points in enumerate(frames):
        kwargs = {"pose": poses[k]} if poses is not None else {"timestamp": k / 10.0}
        res = est.process(points, speed_mps, 0.0, **kwargs)
        out.append(res.vehicle.iso_class)
    return [c or "-" for c in out]


def gauge_free_error(c, truth_deg: np.ndarray, reach: np.ndarray) -> np.ndarray:
    d = np.asarray(c.determined)
    basis = ref.gauge_columns(reach[d])
    t = truth_deg[d]
    return np.asarray(c.elevation_offset_deg)[d] - (t - basis @ np.linalg.lstsq(basis, t, rcond=None)[0])


def simulated(name: str, errors: dict, frames: int, quick: bool, cell_m: float, method: str) -> list:
    lidar = sim.hdl_64e(height_m=SENSOR_HEIGHT_M, calibration_seed=80, columns=1024 if quick else 2083, **errors)
    scene = sim.Scene(sim.Road.iso8608("B", seed=80), ())
    start = time.perf_counter()
    drive = sim.drive(scene, lidar, SPEED_MPS, 0.0, frames, seed=80)
    log(f"{name}: simulated {frames} frames in {time.perf_counter() - start:.0f} s")
    beams = lidar.beam_index().astype(np.int32)
    poses = [(f.pose.x_m, f.pose.y_m, f.pose.yaw_rad) for f in drive]
    cfg = rp.Config(extrinsics=lidar.extrinsics())
    start = time.perf_counter()
    c = rp.calibrate_beams([(f.points, beams) for f in drive], poses=poses, config=cfg, beam_count=lidar.beams,
                           cell_m=cell_m, method=method)
    seconds = time.perf_counter() - start
    # reach per beam (the gauge) as the estimator saw it: level sensor, flat road
    elevations = np.radians(np.asarray(lidar.elevations_deg))
    reach = np.where(elevations < 0, SENSOR_HEIGHT_M / np.tan(-np.minimum(elevations, -1e-6)), np.inf)
    error = gauge_free_error(c, lidar.elevation_errors_deg(), reach)
    fused = rp.Config(extrinsics=lidar.extrinsics(), fusion={"method": "kalman"})
    single = rp.Config(extrinsics=lidar.extrinsics())
    corrected = [c.apply(f.points, beams) for f in drive]
    raw = [f.points for f in drive]
    rows = []
    for label, pts in (("before", raw), ("after", corrected)):
        rows.append([name, label, "–" if label == "before" else f"{int(np.sum(c.determined))}/{lidar.beams}",
                     "–" if label == "before" else f"{np.abs(error).max():.4f}",
                     "–" if label == "before" else f"{np.sqrt(np.mean(error ** 2)):.4f}",
                     "–" if label == "before" else f"{int(np.sum(np.abs(error) <= 0.005))}",
                     "–" if label == "before" else f"{np.nanmedian(np.asarray(c.elevation_sigma_deg)):.4f}",
                     " ".join(vehicle_classes(pts, single)), " ".join(vehicle_classes(pts, fused)),
                     "–" if label == "before" else f"{seconds:.1f}"])
    return rows


def kitti_files(shared: Path) -> list:
    files = sorted((REPO / "tests" / "data" / "semantickitti").glob("00000[0-2].bin"))
    return files + sorted((shared / "kitti" / "patchworkpp_seq00").glob("*.bin"))


def kitti_frames(shared: Path):
    files = kitti_files(shared)
    poses_file = shared / "kitti" / "seq00_poses" / "00.txt"
    if len(files) != 6 or not poses_file.exists():
        log(f"KITTI frames 3-5 or the seq 00 poses not found under {shared}: skipped")
        return None, None
    poses = []
    for line in poses_file.read_text().splitlines()[:6]:
        m = np.array(line.split(), float).reshape(3, 4)
        t = CAMERA_TO_VELODYNE @ m[:, 3]
        heading = CAMERA_TO_VELODYNE @ m[:, :3] @ CAMERA_TO_VELODYNE.T
        poses.append((t[0], t[1], float(np.arctan2(heading[1, 0], heading[0, 0]))))
    return [rp.io.read(f) for f in files], poses


def os1_frames():
    frames = [f.points.copy() for f in rp.io.open(OS1_PCAP)]
    rows = [np.array(line.split(), float).reshape(3, 4) for line in OS1_POSES.read_text().splitlines() if line]
    return frames, [(m[0, 3], m[1, 3], float(np.arctan2(m[1, 0], m[0, 0]))) for m in rows]


def real(name: str, frames, poses, height: float, speed_mps: float, tmp: Path, cell_m: float, method: str,
         **open_kwargs) -> tuple[list, list]:
    cfg = rp.Config(sensor_height=height)
    source = rp.io.open(open_kwargs.pop("path")) if "path" in open_kwargs else None
    if source is not None:
        numbered = [(f.points.copy(), np.asarray(f.beams).copy()) for f in source]
        c = rp.calibrate_beams(numbered, poses=poses, config=cfg, beam_count=source.info["beams"], cell_m=cell_m,
                               method=method)
        c.sensor_model, c.serial = source.info["sensor_model"], source.info["serial"]
        corrected = [c.apply(p, b) for p, b in numbered]
    else:
        c = rp.calibrate_beams(frames, poses=poses, config=cfg, cell_m=cell_m, method=method)
        path = tmp / f"{name}.yaml"
        c.save(str(path))
        corrected = [f.points.copy() for f in rp.io.open([str(p) for p in open_kwargs["files"]],
                                                         beam_calibration=path)]
    d = np.asarray(c.determined)
    offsets = np.asarray(c.elevation_offset_deg)[d]
    summary = [name, f"{int(d.sum())}/{c.beam_count}", f"{c.frames}", f"{c.travel_m:.2f}",
               f"{1e3 * c.residual_m:.1f}", f"{np.std(offsets):.4f}", f"{np.abs(offsets).max():.4f}",
               f"{np.nanmedian(np.asarray(c.elevation_sigma_deg)):.4f}"]
    fused = rp.Config(sensor_height=height, fusion={"method": "kalman"})
    classes = []
    for label, pts in (("before", frames), ("after", corrected)):
        pts = [p if isinstance(p, np.ndarray) else p[0] for p in pts]
        classes.append([name, label, " ".join(vehicle_classes(pts, cfg, poses, speed_mps)),
                        " ".join(vehicle_classes(pts, fused, poses, speed_mps))])
    return summary, classes


MOTIONS = ((5.0, 0.0), (8.0, 0.2))  # (m/s, rad/s): straight, and a 40 m curve to the left


def roughness_summary(points, cfg: rp.Config) -> str:
    """Per motion: left, right and vehicle class ('·' declined), the wheels' G_d(n0) (10⁻⁶ m³) and vehicle IRI."""
    out = []
    for speed, yaw_rate in MOTIONS:
        r = rp.Estimator(cfg).process(points, speed, yaw_rate)
        wheels = (r.left.roughness, r.right.roughness)
        gd = "/".join(f"{w.gd_n0 * 1e6:.0f}" if w.gd_n0 else "·" for w in wheels)
        classes = "".join(c or "·" for c in (*(w.iso_class for w in wheels), r.vehicle.iso_class))
        iri = r.vehicle.iri.value if r.vehicle.iri else None
        out.append(f"{classes} ({gd}, IRI {f'{iri:.1f}' if iri else '·'})")
    return "; ".join(out)


def consistency(frames, poses, files) -> None:
    """KITTI: both methods' offsets from frames 0–2 against those from 3–5; classes before and after calibrations
    that did not see the frame (surface method)."""
    cfg = rp.Config(sensor_height=KITTI_HEIGHT_M)
    halves = ((0, 1, 2), (3, 4, 5))
    rows = []
    for method in ("motion", "surface"):
        start = time.perf_counter()
        cals = [rp.calibrate_beams([frames[i] for i in h], poses=[poses[i] for i in h], config=cfg, method=method)
                for h in halves]
        seconds = (time.perf_counter() - start) / 2
        both = np.asarray(cals[0].determined) & np.asarray(cals[1].determined)
        a, b = (np.asarray(c.elevation_offset_deg)[both] for c in cals)
        rms = [f"{np.sqrt(np.mean(v ** 2)):.4f}" for v in (a, b)]
        rows.append([method, f"{int(both.sum())}", f"{np.corrcoef(a, b)[0, 1]:.2f}",
                     f"{np.sqrt(np.mean((a - b) ** 2)):.4f}", " / ".join(rms),
                     f"{np.nanmedian(np.asarray(cals[0].elevation_sigma_deg)):.4f}", f"{seconds:.1f}"])
    print("## KITTI: the offsets of frames 0–2 against those of frames 3–5\n")
    print(md_table(["method", "beams in both", "correlation", "RMS difference °", "RMS of offsets °",
                    "median σ °", "calibration s"], rows) + "\n")
    import tempfile
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        paths = {}
        for name, idx in (("0–2", halves[0]), ("3–5", halves[1]), ("0–5", range(6))):
            paths[name] = Path(tmp) / f"{name}.yaml"
            rp.calibrate_beams([frames[i] for i in idx], method="surface", config=cfg).save(str(paths[name]))
        spvnas = REPO / "tests" / "data" / "semantickitti" / "spvnas_000000.bin"
        targets = [(f"seq 00 frame {k}", files[k], "3–5" if k < 3 else "0–2") for k in range(6)]
        targets.append(("SPVNAS frame (another street)", spvnas, "0–5"))
        for label, path, source in targets:
            before = roughness_summary(rp.io.read(path), cfg)
            after = roughness_summary(next(iter(rp.io.open(path, beam_calibration=paths[source]))).points, cfg)
            rows.append([label, source, before, after])
    print("## KITTI: classes (left, right, vehicle), G_d(n0) ×10⁻⁶ m³ and vehicle IRI m/km before and after a "
          "surface calibration that did not see the frame; 5 m/s straight; 8 m/s, 0.2 rad/s\n")
    print(md_table(["frame", "calibrated from seq 00 frames", "before", "after"], rows) + "\n")
    print("## KITTI: repeatability of single frames (the later frame's 5–15 m ahead against the earlier frame's view "
          "of that stretch; correlation of the IRI-filtered profiles, RMS difference cm), before → after the surface "
          "calibration from the other half\n")
    print(md_table(["frames", "travelled m", "left", "right", "left, bins both measured after: count: RMS / noise",
                    "right"], repeatability_rows(files, poses, cfg)) + "\n")


def repeatability_rows(files, poses, cfg: rp.Config) -> list:
    """Pairs of seq 00 frames: each wheel's repeatability (rp.repeatability) before → after calibrating each frame
    with the surface offsets of the other half of the six."""
    import tempfile
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        other = []
        for k, idx in enumerate(((3, 4, 5), (0, 1, 2))):
            other.append(Path(tmp) / f"half{k}.yaml")
            rp.calibrate_beams([rp.io.read(files[i]) for i in idx], method="surface", config=cfg).save(str(other[-1]))

        def results(i, calibrated):
            points = next(iter(rp.io.open(files[i], beam_calibration=other[i >= 3]))).points if calibrated else \
                rp.io.read(files[i])
            return rp.Estimator(cfg).process(points, 8.6, 0.0)

        for i, j in ((0, 2), (3, 5), (0, 3), (1, 4), (2, 5), (0, 5)):
            travelled = float(np.hypot(poses[j][0] - poses[i][0], poses[j][1] - poses[i][1]))
            grid = np.arange(5.0, 15.0, 0.1) + 0.05 + travelled
            cells, measured = {}, []
            for calibrated in (False, True):
                a, b = results(i, calibrated), results(j, calibrated)
                for wheel in ("left", "right"):
                    pa, pb = getattr(a, wheel), getattr(b, wheel)
                    x = rp.repeatability(rp.world_profile(pa.s, pa.z, 0.0, grid),
                                         rp.world_profile(pb.s, pb.z, travelled, grid), 0.1)
                    text = "–" if x.correlation is None else f"{x.correlation:.2f}, {x.rms_m * 100:.2f}"
                    cells[wheel] = text if not calibrated else f"{cells[wheel]} → {text}"
                    if calibrated:
                        measured.append(measured_bins(pa, pb, travelled, grid))
            rows.append([f"{i} and {j}", f"{travelled:.2f}", cells["left"], cells["right"], *measured])
    return rows


def measured_bins(pa, pb, travelled: float, grid) -> str:
    """The bins both profiles measured (not gap-filled): their count, the RMS of their height difference (its
    line removed) and the RMS the bins' own noise predicts (the roughness stage's bin variance, method.md §4), cm."""
    def on_grid(p, values, at):
        return rp.world_profile(p.s, np.asarray(values, float), at, grid)

    def variance(p):
        spread, count = np.asarray(p.spread, float), np.asarray(p.count, float)
        return np.where(count >= 3, np.pi / 2 * spread ** 2 / np.maximum(count, 1),
                        np.where(count == 2, spread ** 2 / 2, spread ** 2))

    za, zb = on_grid(pa, pa.z, 0.0), on_grid(pb, pb.z, travelled)
    va, vb = on_grid(pa, variance(pa), 0.0), on_grid(pb, variance(pb), travelled)
    both = (on_grid(pa, pa.count, 0.0) > 0) & (on_grid(pb, pb.count, travelled) > 0) & np.isfinite(va + vb + za + zb)
    if both.sum() < 3:
        return "–"
    d, s = (za - zb)[both], grid[both]
    d = d - np.polyval(np.polyfit(s, d, 1), s)
    return f"{both.sum()}: {np.sqrt(np.mean(d ** 2)) * 100:.2f} / {np.sqrt(np.mean((va + vb)[both])) * 100:.2f}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="a short, coarse drive (smoke test)")
    parser.add_argument("--frames", type=int, default=20, help="frames of each simulated drive")
    parser.add_argument("--cell", type=float, default=0.2, help="road cell of the calibration, m (rp.calibrate_beams)")
    parser.add_argument("--method", choices=("motion", "surface"), default="motion",
                        help="calibration method (rp.calibrate_beams) of the simulated and real tables")
    parser.add_argument("--shared", type=Path, default=SHARED, help="the shared data folder (KITTI frames 3-5, poses)")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    frames = 4 if args.quick else args.frames
    rows = []
    for name, errors in (("beams off by 0.03° (1σ)", {"elevation_error_deg": 0.03}),
                         ("uniform offsets up to 0.1°", {"beam_errors_deg": tuple(
                             np.random.default_rng(5).uniform(-0.1, 0.1, 64))})):
        rows += simulated(name, errors, frames, args.quick, args.cell, args.method)
    print("# roadpreview beam calibration benchmark\n")
    print(f"- load {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores; Python {platform.python_version()}, "
          f"roadpreview {rp.__version__}\n")
    print(f"## Simulated HDL-64E, class B road, {frames} frames at {SPEED_MPS:g} m/s, method {args.method}, "
          f"cells of {args.cell:g} m\n")
    print(md_table(["beams", "calibration", "determined", "max |error| °", "RMS error °", "within 0.005°",
                    "median σ °",
                    "vehicle class per frame", "fused class per frame", "calibration s"], rows) + "\n")
    if not args.quick:
        import tempfile
        summaries, classes = [], []
        with tempfile.TemporaryDirectory() as tmp:
            kitti, kitti_poses = kitti_frames(args.shared)
            if kitti is not None:
                files = kitti_files(args.shared)
                s, c = real("KITTI seq 00, frames 0–5", kitti, kitti_poses, KITTI_HEIGHT_M, 8.6, Path(tmp), args.cell,
                            args.method, files=files)
                summaries.append(s)
                classes += c
            os1, os1_poses = os1_frames()
            s, c = real("OS1-128, 3 frames", os1, os1_poses, OS1_HEIGHT_M, 2.5, Path(tmp), args.cell, args.method,
                        path=OS1_PCAP)
            summaries.append(s)
            classes += c
        print("## Real recordings: per-beam offsets\n")
        print(md_table(["recording", "determined", "frames", "travel m", "point noise mm", "std of offsets °",
                        "max |offset| °", "median σ °"], summaries) + "\n")
        print("## Real recordings: vehicle class per frame, before and after calibration\n")
        print(md_table(["recording", "calibration", "single frame", "fused (kalman)"], classes) + "\n")
        kitti, kitti_poses = kitti_frames(args.shared)
        if kitti is not None:
            consistency(kitti, kitti_poses, kitti_files(args.shared))
    log(f"done in {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
