# SPDX-License-Identifier: BSD-3-Clause
"""Roadside perception on the method paper's five scenarios (simulated): position error against RTK-like truth,
classification, MOTA/MOTP/IDF1 (motmetrics), id switches, cycle time, and the clock-offset experiment.

    python bench/roadside.py [--runs 5] [--offset-runs N] [--quick] [--no-offsets | --offsets-only]

Position error (the paper's Table 1): at every truth second (1 Hz, as the paper's RTK log) of an object inside the
sensed area (|x|, |y| ≤ 30 m; tracks beyond it + 2 m are not scored), the nearest confirmed laser track within 2 m, predicted from its cycle to the
truth time with its velocity; mean and σ over the scenario's runs. Classification: fraction of 10 Hz truth
samples whose matched track has the right class. MOTA/MOTP/IDF1: motmetrics at 10 Hz, match threshold 2 m (MOTP
given in metres). Cycle time: the C++ processing time of each cycle (2 × 361 beams), measured inside the library.
Clock offsets: scanner 2 reads +100 ms / −100 ms (and the camera +100 ms); error with the offsets unknown, then
with the scanner offset estimated by rp.roadside.estimate_clock_offsets and written into the site file.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numpy as np

import roadpreview as rp
from roadpreview.sim import roadside as sr

AREA_M = 30.0
MATCH_M = 2.0


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def tracked(cycles: list[dict]) -> tuple[np.ndarray, list[list[dict]]]:
    times = np.array([c["t_s"] for c in cycles])
    return times, [[o for o in c["objects"] if o["id"] > 0] for c in cycles]


def objects_at(times: np.ndarray, objs: list[list[dict]], t: float) -> list[dict]:
    """Tracks of the cycle nearest to t, predicted to t with their velocity."""
    i = int(np.clip(np.searchsorted(times, t), 0, len(times) - 1))
    if i > 0 and abs(times[i - 1] - t) < abs(times[i] - t):
        i -= 1
    if abs(times[i] - t) > 0.05:
        return []
    dt = t - times[i]
    return [dict(o, x_m=o["x_m"] + o["vx_mps"] * dt, y_m=o["y_m"] + o["vy_mps"] * dt) for o in objs[i]]


def in_area(row: dict) -> bool:
    return abs(row["x_m"]) <= AREA_M and abs(row["y_m"]) <= AREA_M


def evaluate(run: sr.Run, cycles: list[dict]) -> dict:
    import motmetrics as mm

    times, objs = tracked(cycles)
    errors, correct, total = [], 0, 0
    acc = mm.MOTAccumulator(auto_id=True)
    t_end = max(m.t1_s for m in run.movers)
    for t in np.arange(0.0, t_end, 0.1):
        truth = [r for r in run.truth_at(float(t)) if in_area(r)]
        # Tracks outside the area are not scored (nor false): a truth just inside matches one just outside.
        hyp = [o for o in objects_at(times, objs, float(t))
               if abs(o["x_m"]) <= AREA_M + MATCH_M and abs(o["y_m"]) <= AREA_M + MATCH_M]
        a = np.array([[r["x_m"], r["y_m"]] for r in truth]).reshape(-1, 2)
        b = np.array([[o["x_m"], o["y_m"]] for o in hyp]).reshape(-1, 2)
        acc.update([r["id"] for r in truth], [o["id"] for o in hyp],
                   mm.distances.norm2squared_matrix(a, b, max_d2=MATCH_M ** 2))
        for r in truth:
            d = [math.hypot(o["x_m"] - r["x_m"], o["y_m"] - r["y_m"]) for o in hyp]
            if not d or min(d) > MATCH_M:
                continue
            o = hyp[int(np.argmin(d))]
            total += 1
            correct += o["class"] == r["cls"]
            if abs(t - round(t)) < 1e-6:  # the paper's once-a-second comparison
                errors.append(min(d))
    summary = mm.metrics.create().compute(acc, metrics=["mota", "motp", "idf1", "num_switches"], name="run")
    return dict(errors=errors, correct=correct, total=total, mota=float(summary["mota"].iloc[0]),
                motp=math.sqrt(float(summary["motp"].iloc[0])) if np.isfinite(summary["motp"].iloc[0]) else math.nan,
                idf1=float(summary["idf1"].iloc[0]), switches=int(summary["num_switches"].iloc[0]),
                cycle_ms=[c["process_ms"] for c in cycles])


def run_once(scenario: str, seed: int, offsets=(0.0, 0.0), camera_offset=0.0, estimate=False) -> tuple[dict, list]:
    run = sr.simulate(scenario, seed=seed, clock_offsets_s=offsets, camera_offset_s=camera_offset)
    site = run.site_yaml
    est = None
    if estimate:  # the estimated offsets go into the site file, whose clock the processor orders scans by
        est = rp.roadside.estimate_clock_offsets(run.scans, site)
        site = sr.site_yaml(run.scanners, [-o for o in est])
    cycles = rp.roadside.Processor(site).run(run.scans, run.detections)
    return evaluate(run, cycles), est


def fmt(v: float, digits: int = 3) -> str:
    return "–" if v is None or not np.isfinite(v) else f"{v:.{digits}f}"


def scenario_table(runs: int) -> list[float]:
    print("| scenario | runs | samples (1 Hz) | mean error m | σ m | max m | class accuracy | MOTA | MOTP m | IDF1 "
          "| id switches | paper mean m |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    paper = {"one_car": "0.4–0.6", "two_cars_crossing": "0.4–0.6", "two_cars_in_a_row": "0.4–0.6",
             "pedestrian_crossing": "0.4–0.6", "cyclist_crossing": "0.4–0.6"}
    cycle_ms = []
    for scenario in sr.SCENARIOS:
        res = []
        for seed in range(runs):
            r, _ = run_once(scenario, seed)
            res.append(r)
            log(f"{scenario} run {seed}: mean error {np.mean(r['errors']) if r['errors'] else math.nan:.3f} m, "
                f"MOTA {r['mota']:.3f}")
        err = np.concatenate([r["errors"] for r in res]) if any(r["errors"] for r in res) else np.array([])
        cycle_ms += [m for r in res for m in r["cycle_ms"]]
        acc = sum(r["correct"] for r in res) / max(1, sum(r["total"] for r in res))
        print(f"| {scenario} | {runs} | {len(err)} | {fmt(err.mean() if len(err) else None)} | "
              f"{fmt(err.std() if len(err) else None)} | {fmt(err.max() if len(err) else None)} | {acc:.3f} | "
              f"{np.mean([r['mota'] for r in res]):.3f} | {fmt(np.nanmean([r['motp'] for r in res]))} | "
              f"{np.mean([r['idf1'] for r in res]):.3f} | {sum(r['switches'] for r in res)} | {paper[scenario]} |")
    return cycle_ms


def offsets_table(runs: int) -> None:
    print("\n| scenario | scanner 2 clock | camera clock | mean error, offsets unknown m | estimated offset ms "
          "| mean error, offsets estimated m |")
    print("|---|---|---|---|---|---|")
    for scenario in ("one_car", "two_cars_crossing", "cyclist_crossing"):
        for off in (0.1, -0.1):
            before, after, found = [], [], []
            for seed in range(runs):
                r0, _ = run_once(scenario, seed, (0.0, off), 0.1)
                r1, est = run_once(scenario, seed, (0.0, off), 0.1, estimate=True)
                before += r0["errors"]
                after += r1["errors"]
                found.append(est[1])
            print(f"| {scenario} | {off * 1e3:+.0f} ms | +100 ms | {fmt(np.mean(before))} | "
                  f"{np.mean(found) * 1e3:+.1f} (σ {np.std(found) * 1e3:.1f}) | {fmt(np.mean(after))} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5, help="runs per scenario (the paper: 5)")
    ap.add_argument("--quick", action="store_true", help="1 run per scenario, no offset experiment (smoke test)")
    ap.add_argument("--no-offsets", action="store_true", help="skip the clock-offset experiment")
    ap.add_argument("--offsets-only", action="store_true", help="only the clock-offset experiment")
    ap.add_argument("--offset-runs", type=int, default=None, help="runs per case of the offset experiment (default --runs)")
    args = ap.parse_args()
    runs = 1 if args.quick else args.runs
    load = os.getloadavg()[0]
    print(f"# roadside bench: {runs} run(s) per scenario; 1-min load {load:.2f} on {os.cpu_count()} cores"
          + (" (busy machine: timings inflated)" if load > 0.5 else ""))
    print("\nTargets: mean error ≤ 0.20 m per class, classification ≥ 0.98, MOTA ≥ 0.9, no id switch in single-object "
          "scenarios; ≤ 0.25 m with ±100 ms clock offsets once estimated; a two-scanner cycle ≤ 1 ms.\n")
    t0 = time.perf_counter()
    if args.offsets_only:
        offsets_table(args.offset_runs or runs)
        return
    cycle_ms = np.array(scenario_table(runs))
    print(f"\nCycle processing (C++, 2 × 361 beams, single thread): median {np.median(cycle_ms):.3f} ms, "
          f"p99 {np.percentile(cycle_ms, 99):.3f} ms, max {cycle_ms.max():.3f} ms over {len(cycle_ms)} cycles "
          f"(target ≤ 1 ms; the scanners' period is 26.7 ms)")
    if not (args.quick or args.no_offsets):
        offsets_table(args.offset_runs or runs)
    log(f"done in {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
