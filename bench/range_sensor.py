"""Point range sensor benchmark (docs/method.md §11): calibration accuracy, profile accuracy, roughness class and
IRI from range-sensor profiles, and the C++ throughput on long readings files.

Simulated throughout (roadpreview.sim.range_sensor, every draw seeded):
  * distance calibration: an ultrasonic sensor (1 mm noise, 0.17 mm counts) on a bench of 10 distances
    0.15–0.6 m × 20 readings, clean and with 2 % gross errors (±2–5 cm); a1 and a2 errors against the truth;
  * offset calibration: laser (8 ms latency) and ultrasonic (12 ms, 12° cone) 0.3 m ahead of the axle, 0.25 m up:
    on the 3 m bench track at 0.2 and 1.0 m/s; and on a class C road against the fused LiDAR map (simulated
    OS1-128 1.8 m up, Kalman fusion, 20 frames per run) at 5 and 20 m/s; b1 and b2 errors by ICP and by
    cross-correlation;
  * profile RMSE after calibration on the bench (detrended error against the true track) and the ultrasonic
    footprint bias by the track's slope;
  * ISO 8608 class and IRI of laser profiles (1 kHz, 0.3 mm noise, both wheels) of class A–E roads at 10 m/s,
    40 m windows, against the class the road was drawn from and the IRI of the true relief in the same bins;
  * throughput: `roadpreview range run` (C++, single thread) on files of 10⁶ and 4·10⁶ readings (two laser
    sensors at 10 kHz, 20 m/s): readings per second and peak memory (max RSS).

Usage: ``python bench/range_sensor.py [--quick]`` (Markdown on stdout, progress on stderr).
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

import roadpreview as rp
from roadpreview import sim

sys.path.insert(0, str(Path(__file__).resolve().parent))
from accuracy import detrended_rms, md_table  # noqa: E402

BENCH_SPEEDS = (0.2, 1.0)
ROAD_SPEEDS = (5.0, 20.0)
CLASSES = "ABCDE"
LIDAR_HEIGHT_M = 1.8


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def write_drive(dir_: Path, name: str, drive) -> tuple[Path, Path]:
    (dir_ / f"{name}.csv").write_text(drive.readings_csv())
    (dir_ / f"{name}_motion.csv").write_text(drive.motion_csv())
    return dir_ / f"{name}.csv", dir_ / f"{name}_motion.csv"


# --- distance calibration ------------------------------------------------------------------------------------

def distance_rows(seeds: int) -> list[list]:
    rows = []
    us = sim.ultrasonic(a2=0.005)
    for outliers in (False, True):
        errs_a1, errs_a2, rms, rejected = [], [], [], []
        for seed in range(seeds):
            bench = sim.bench_counts(us, np.linspace(0.15, 0.6, 10), repeats=20, seed=seed)
            if outliers:
                rng = np.random.default_rng(100 + seed)
                bad = rng.choice(len(bench), len(bench) // 50, replace=False)
                bench[bad, 0] += np.round(rng.choice([-1, 1], len(bad)) * rng.uniform(0.02, 0.05, len(bad)) / us.a1)
            fit = rp.range_sensor.calibrate_distance(bench[:, 0], bench[:, 1])
            errs_a1.append(abs(fit["a1"] / us.a1 - 1) * 100)
            errs_a2.append(abs(fit["a2"] - us.a2) * 1e3)
            rms.append(fit["rms_m"] * 1e3)
            rejected.append(fit["rejected"])
        rows.append(["with 2 % gross errors" if outliers else "clean", seeds, f"{np.max(errs_a1):.3f}",
                     f"{np.max(errs_a2):.3f}", f"{np.median(rms):.2f}", f"{np.median(rejected):.0f}",
                     "yes" if np.max(errs_a1) <= 0.5 and np.max(errs_a2) <= 1.0 else "no"])
    return rows


# --- offset calibration --------------------------------------------------------------------------------------

def sensors_for_offset():
    return [sim.laser("laser", x_m=0.3, height_m=0.25, latency_s=0.008, rate_hz=400.0),
            sim.ultrasonic("ultrasonic", x_m=0.3, height_m=0.25, latency_s=0.012, rate_hz=200.0)]


def bench_offset(work: Path) -> tuple[list[list], dict]:
    xz = sim.bench_reference()
    rows, runs_by_sensor = [], {}
    for sensor in sensors_for_offset():
        d = work / f"bench_{sensor.id}"
        d.mkdir()
        (d / "sensors.yaml").write_text(sim.layout_yaml([sensor]))
        drives = [sim.drive_readings(sim.bench_road(), [sensor], v, 4.0, seed=i, counts=False)
                  for i, v in enumerate(BENCH_SPEEDS)]
        files = [write_drive(d, f"run{i}", drv) for i, drv in enumerate(drives)]
        log(f"bench offset calibration: {sensor.id}")
        out = rp.range_sensor.calibrate_offset([f[0] for f in files], [f[1] for f in files], d / "sensors.yaml",
                                               reference=xz)[sensor.id]
        rows.append(offset_row("bench 3 m track", sensor, BENCH_SPEEDS, out))
        runs_by_sensor[sensor.id] = (sensor, d, files, drives, out)
    return rows, runs_by_sensor


def offset_row(where: str, sensor, speeds, out: dict) -> list:
    e_b1 = (out["b1_s"] + sensor.latency_s) * 1e3
    e_b2 = (out["b2_m"] - sensor.foot_m) * 1e3
    x_b1 = (out["b1_xcorr_s"] + sensor.latency_s) * 1e3
    x_b2 = (out["b2_xcorr_m"] - sensor.foot_m) * 1e3
    met = abs(e_b1) <= 2 and abs(e_b2) <= 5
    return [where, sensor.id, " / ".join(f"{v:g}" for v in speeds), f"{e_b1:+.2f} (± {out['b1_sigma_s'] * 1e3:.2f})",
            f"{e_b2:+.2f} (± {out['b2_sigma_m'] * 1e3:.2f})", f"{x_b1:+.2f}", f"{x_b2:+.2f}",
            "yes" if met else "no"]


def lidar_map(road: "sim.Road", speed: float, frames: int) -> "rp.Estimator":
    lidar = sim.os1_128(height_m=LIDAR_HEIGHT_M, range_noise_m=0.01)
    est = rp.Estimator(rp.Config(extrinsics=lidar.extrinsics(), fusion={"method": "kalman"}))
    for f in sim.drive(sim.Scene(road), lidar, speed, 0.0, frames=frames, seed=1):
        est.process(f.points, speed, 0.0, timestamp=f.time_s)
    return est


def road_offset(work: Path, frames: int) -> list[list]:
    # Speed bumps give the registration features the LiDAR map resolves: on a plain class C road its 0.1 m cells
    # correlate with the true relief at about 0.4 only (noise and long waves dominate).
    road = sim.Road.iso8608("C", seed=11, bumps=tuple(sim.SpeedBump(x_m=x, height_m=0.03, length_m=0.6)
                                                     for x in (8.0, 13.0, 18.0)))
    maps = []
    for v in ROAD_SPEEDS:
        log(f"LiDAR map at {v} m/s ({frames} simulated OS1-128 frames)")
        maps.append(lidar_map(road, v, frames))
    rows = []
    for sensor in sensors_for_offset():
        sensor = replace(sensor, x_m=1.0, height_m=0.3, rate_hz=1000.0 if sensor.kind == "laser" else 500.0)
        d = work / f"road_{sensor.id}"
        d.mkdir()
        (d / "sensors.yaml").write_text(sim.layout_yaml([sensor]))
        files = [write_drive(d, f"run{i}", sim.drive_readings(road, [sensor], v, 30.0, seed=i, counts=False))
                 for i, v in enumerate(ROAD_SPEEDS)]
        log(f"road self-calibration against the LiDAR map: {sensor.id}")
        out = rp.range_sensor.calibrate_offset([f[0] for f in files], [f[1] for f in files], d / "sensors.yaml",
                                               reference=maps)[sensor.id]
        rows.append(offset_row("class C road with 3 cm bumps, fused LiDAR map", sensor, ROAD_SPEEDS, out))
    return rows


# --- profile accuracy after calibration ----------------------------------------------------------------------

def profile_rows(runs_by_sensor: dict, work: Path) -> tuple[list[list], list[list]]:
    rows, bias_rows = [], []
    slope_edges = (-np.inf, -0.5, -0.1, 0.1, 0.5, np.inf)
    for sensor_id, (sensor, d, files, drives, out) in runs_by_sensor.items():
        cal = d / "cal.yaml"
        cal.write_text(f"sensors:\n  {sensor_id}:\n    offset: {{b1_s: {out['b1_s']!r}, b2_m: {out['b2_m']!r}}}\n")
        for (readings, motion), v in zip(files, BENCH_SPEEDS):
            smp = rp.range_sensor.samples(readings, d / "sensors.yaml", calibration=cal, motion=motion)
            truth = sim.bench_profile(smp["s"])
            err = smp["z"] - truth
            on = (smp["s"] > 0.3) & (smp["s"] < 3.7)
            rows.append([sensor_id, f"{v:g}", int(on.sum()), f"{detrended_rms(smp['s'][on], err[on]) * 1e3:.2f}",
                         f"{np.max(np.abs(err[on])) * 1e3:.1f}",
                         ("yes" if detrended_rms(smp['s'][on], err[on]) <= 0.003 else "no") if sensor.kind == "laser"
                         else "(not a target)"])
            slope = np.gradient(sim.bench_profile(np.arange(-1, 6, 0.001)), 0.001)
            s_slope = np.interp(smp["s"], np.arange(-1, 6, 0.001), slope)
            cells = []
            for lo, hi in zip(slope_edges[:-1], slope_edges[1:]):
                m = on & (s_slope >= lo) & (s_slope < hi)
                cells.append(f"{np.mean(err[m]) * 1e3:+.1f} (n = {m.sum()})" if m.any() else "–")
            bias_rows.append([sensor_id, f"{v:g}", *cells])
    return rows, bias_rows


# --- class and IRI -------------------------------------------------------------------------------------------

def class_rows(work: Path, length_m: float) -> list[list]:
    rows = []
    sensors = [sim.laser("l", "left", x_m=1.0), sim.laser("r", "right", x_m=1.0)]
    d = work / "classes"
    d.mkdir()
    (d / "sensors.yaml").write_text(sim.layout_yaml(sensors))
    (d / "cal.yaml").write_text("sensors:\n" + "".join(
        f"  {s.id}:\n    offset: {{b1_s: {-s.latency_s!r}, b2_m: {s.foot_m!r}}}\n" for s in sensors))
    for c in CLASSES:
        road = sim.Road.iso8608(c, seed=5)
        log(f"class {c}: laser drive of {length_m:g} m")
        files = write_drive(d, f"class_{c}", sim.drive_readings(road, sensors, 10.0, length_m + 1.5, seed=3))
        windows = rp.range_sensor.process(files[0], d / "sensors.yaml", calibration=d / "cal.yaml", motion=files[1])
        windows = [w for w in windows if w["window"]["s_end"] <= length_m + 1e-9]
        exact = within = 0
        iri_err = []
        for w in windows:
            got = w["roughness"]["vehicle"]["class"]
            exact += got == c
            within += got is not None and abs(ord(got) - ord(c)) <= 1
            for wheel, y in (("left", 0.8), ("right", -0.8)):
                p = w["profiles"][wheel]
                s = np.array(p["s"])
                truth = road.height(s, np.full_like(s, y))
                true_iri = rp.reference.profile_iri(truth, 0.1).value
                got_iri = w["roughness"][wheel]["iri"]["value"]
                if got_iri is not None and true_iri:
                    iri_err.append(abs(got_iri / true_iri - 1) * 100)
        rows.append([c, len(windows), f"{exact}/{len(windows)}", f"{within}/{len(windows)}",
                     f"{np.median(iri_err):.1f}" if iri_err else "–", f"{np.max(iri_err):.1f}" if iri_err else "–",
                     "yes" if within == len(windows) and iri_err and max(iri_err) <= 10 else "no"])
    return rows


# --- throughput ----------------------------------------------------------------------------------------------

def readings_file(path: Path, n: int) -> None:
    """n readings of two laser sensors at 10 kHz each, 20 m/s: a sine road 1 cm high, 2.5 m long waves."""
    t = np.arange(n // 2) / 10000.0
    with open(path, "w") as f:
        f.write("t,sensor,distance\n")
        for start in range(0, len(t), 200000):
            tt = t[start:start + 200000]
            z = 0.01 * np.sin(2 * np.pi * (20.0 * tt + 1.0) / 2.5)
            lines = np.empty(2 * len(tt), dtype=object)
            lines[0::2] = [f"{a:.5f},l,{0.3 - b:.5f}\n" for a, b in zip(tt, z)]
            lines[1::2] = [f"{a:.5f},r,{0.3 - b:.5f}\n" for a, b in zip(tt, z)]
            f.write("".join(lines))


def timed_run(args: list[str]) -> tuple[float, float, float]:
    """(wall s, CPU s, peak RSS MB) of one run, measured by GNU time (a child forked from this process would
    count the parent's pages in its own peak)."""
    start = time.perf_counter()
    proc = subprocess.run(["/usr/bin/time", "-f", "%U %S %M", *args], capture_output=True, text=True)
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(args)} failed: {proc.stderr}")
    user, system, rss_kb = proc.stderr.strip().splitlines()[-1].split()
    return wall, float(user) + float(system), float(rss_kb) / 1024


def throughput_rows(work: Path, sizes: list[int], repeats: int) -> list[list]:
    cli = shutil.which("roadpreview")
    sensors = [sim.laser("l", "left", x_m=1.0), sim.laser("r", "right", x_m=1.0)]
    (work / "tp_sensors.yaml").write_text(sim.layout_yaml(sensors))
    _, _, baseline_mb = timed_run([cli, "--version"])
    rows = []
    for n in sizes:
        path = work / f"tp_{n}.csv"
        log(f"throughput: writing {n} readings")
        readings_file(path, n)
        for output in ("/dev/null", str(work / "tp_out.jsonl")):
            runs = [timed_run([cli, "range", "run", str(path), "--sensors", str(work / "tp_sensors.yaml"), "--speed",
                               "20", "-q", "-o", output]) for _ in range(repeats)]
            wall = np.median([r[0] for r in runs])
            cpu = np.median([r[1] for r in runs])
            rows.append([f"{n:,}", f"{path.stat().st_size / 1e6:.0f}", "null" if output == "/dev/null" else "file",
                         f"{wall:.2f}", f"{n / wall / 1e6:.2f}", f"{cpu:.2f}", f"{n / cpu / 1e6:.2f}",
                         f"{max(r[2] for r in runs):.0f} ({baseline_mb:.0f})", "yes" if n / cpu >= 1e6 else "no"])
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a smoke run: fewer seeds, frames, windows and readings")
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="roadpreview_range_bench_"))
    try:
        print(f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, 1-min load "
              f"{os.getloadavg()[0]:.2f} at the start\n")
        print("**Distance calibration** (ultrasonic, |error| at most over the seeds; "
              "target a1 ≤ 0.5 %, a2 ≤ 1 mm)\n")
        print(md_table(["bench", "seeds", "a1 error %", "a2 error mm", "residual RMS mm", "rejected", "met"],
                       distance_rows(2 if args.quick else 10)))
        bench_rows, runs = bench_offset(work)
        road_rows = [] if args.quick else road_offset(work, 20)  # 2 s of LiDAR: README, Range sensors
        print("\n**Offset calibration** (error against the truth; target b1 within 2 ms, b2 within 5 mm)\n")
        print(md_table(["reference", "sensor", "speeds m/s", "ICP b1 error ms", "ICP b2 error mm",
                        "cross-correlation b1 error ms", "cross-correlation b2 error mm", "met (ICP)"],
                       bench_rows + road_rows))
        prof, bias = profile_rows(runs, work)
        print("\n**Profile after calibration** (bench track; target laser RMSE ≤ 3 mm)\n")
        print(md_table(["sensor", "speed m/s", "samples", "RMSE mm (detrended)", "max abs error mm", "met"], prof))
        print("\n**Height bias by the track's slope** (mean measured − true, mm; the ultrasonic cone's first echo)\n")
        print(md_table(["sensor", "speed m/s", "slope < −0.5", "−0.5 … −0.1", "−0.1 … 0.1", "0.1 … 0.5",
                        "> 0.5"],
                       bias))
        print("\n**ISO 8608 class and IRI** (laser, both wheels, 10 m/s, 40 m windows; target within one class, "
              "IRI within 10 %)\n")
        print(md_table(["class", "windows", "vehicle class exact", "within one", "IRI error median %",
                        "IRI error max %", "met"], class_rows(work, 80.0 if args.quick else 200.0)))
        sizes = [200_000] if args.quick else [1_000_000, 4_000_000]
        print("\n**Throughput** (`roadpreview range run`, C++ single thread, median of "
              f"{1 if args.quick else 3} runs; output to /dev/null or a file; wall time and CPU time (user + system, "
              "the fair measure on a shared machine); target ≥ 10⁶ readings/s)\n")
        print(md_table(["readings", "file MB", "output", "wall s", "M readings/s (wall)", "CPU s",
                        "M readings/s (CPU)", "max RSS MB (the CLI idle)", "met (CPU)"],
                       throughput_rows(work, sizes, 1 if args.quick else 3)))
        print(f"\n1-min load at the end: {os.getloadavg()[0]:.2f}")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
