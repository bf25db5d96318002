"""How right the route's segments are (docs/method.md §10): a simulated drive's frames stitched by the C++
RouteBuilder (as ``roadpreview run --segments 10``), each 10 m segment's vehicle class and G_d(n0) against the true
road's over the same stretch, and the single frames' classes against the road's class.

Two truths per segment: the road's *line* profile under each wheel (sampled every 2.5 cm, the simulated field's
own grid, so its PSD up to the band's 4 cycles/m is not aliased), which ISO 8608 classifies; and the road as the
profile's *strip* sees it (docs/method.md §3, "What the strip does to the short waves"): the relief averaged over
the tire's width and each 0.1 m bin, what a perfect sensor would give through §3's binning. The stitch is judged
against the strip, the whole chain against the line.

Simulated: ISO 8608 roads of classes B, C and D (two seeds each), an HDL-64E 1.73 m high (KITTI's), straight at
8.6 m/s and 10 Hz, exact extrinsics, the default pipeline (obstacles off: the scene has none). Segments from the
drive's start to 60 m are scored; those beyond are backed only by the last frames' far rings.

Usage: ``python bench/route.py [--frames N] [--classes BCD] [--tire-width M]``; prints Markdown.
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy import signal

import roadpreview as rp
from roadpreview import sim
from roadpreview._native import core
from calibration import md_table

CLASSES = "ABCDEFGH"
SPEED_MPS, HEIGHT_M, SEGMENT_M, SCORED_TO_M = 8.6, 1.73, 10.0, 60.0
FINE_M, STRIP_SAMPLES = 0.025, 10  # the line truth's spacing; the strip truth's samples along a bin and across the tire
SPECTRA_M, SPECTRA_CPM = (10.0, 60.0), (0.2, 0.3, 0.4, 0.5, 0.7, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0)


def drive(iso_class: str, seed: int, frames: int, tire_width: float):
    """(single frames' vehicle classes, [(line class, line G_d, stitched class, stitched G_d, strip G_d)] per scored
    segment, (stitched, strip) Welch spectra of both wheels over SPECTRA_M)."""
    scene = sim.Scene(sim.Road.iso8608(iso_class, seed=seed))
    lidar = sim.hdl_64e(height_m=HEIGHT_M)
    cfg = rp.Config(extrinsics=rp.Extrinsics(**lidar.extrinsics()), obstacles={"enabled": False}, tire_width=tire_width)
    estimator, route = rp.Estimator(cfg), core().RouteBuilder(cfg.to_json())
    singles = []
    for frame in sim.drive(scene, lidar, speed_mps=SPEED_MPS, frames=frames, seed=seed):
        result = estimator.process(frame.points, SPEED_MPS, 0.0, timestamp=frame.time_s)
        route.add(result, None)
        singles.append(result.vehicle.iso_class)
    segments = []
    for s in route.segments(SEGMENT_M):
        if s["start_m"] >= SCORED_TO_M:
            continue
        line = truth(scene.road, s["start_m"], s["end_m"], cfg, strip=False)
        strip = truth(scene.road, s["start_m"], s["end_m"], cfg, strip=True)
        stitched = s["vehicle"]["roughness"]
        segments.append((line.iso_class, line.gd_n0, stitched.iso_class, stitched.gd_n0, strip.gd_n0))
    return singles, segments, spectra(scene.road, route, cfg)


def spectra(road, route, cfg: rp.Config) -> list:
    """Per wheel, the Welch PSDs (10 m pieces, their lines removed) of the stitched profile and of the strip's road
    over SPECTRA_M: what the stitch keeps of each wave."""
    ds = cfg.profile.ds_m
    out = []
    for wheel, y in (("left", cfg.track_width / 2), ("right", -cfg.track_width / 2)):
        z = np.asarray(route.stitched(wheel).z)
        j = np.arange(round(SPECTRA_M[0] / ds), min(round(SPECTRA_M[1] / ds), len(z)))  # a short drive's: less
        x, z = (j + 0.5) * ds, z[j]
        known = np.isfinite(z)
        z = np.interp(x, x[known], z[known])  # the few bins no frame backed
        psd = [signal.welch(h, fs=1 / ds, nperseg=round(SEGMENT_M / ds), detrend="linear")
               for h in (z, strip_heights(road, x, y, cfg))]
        out.append((psd[0][0], psd[0][1], psd[1][1]))
    return out


def strip_heights(road, x: np.ndarray, y: float, cfg: rp.Config) -> np.ndarray:
    """The relief at drive distances x (bin centres) averaged over the bin's length and the tire's width at y."""
    ds = cfg.profile.ds_m
    along = (np.arange(STRIP_SAMPLES) + 0.5) / STRIP_SAMPLES - 0.5  # −½ … ½ of a bin, of the tire's width
    return np.mean([road.relief(x + a * ds, np.full_like(x, y + b * cfg.tire_width)) for a in along for b in along],
                   axis=0)


def truth(road, start_m: float, end_m: float, cfg: rp.Config, *, strip: bool):
    """The vehicle roughness of the true road over [start, end) on the straight path (x = drive distance, wheels at
    y = ±track/2): the line profiles at FINE_M, or the strip's (each 0.1 m bin's mean over the tire's width)."""
    half_track = cfg.track_width / 2
    if not strip:
        x = np.arange(start_m + FINE_M / 2, end_m, FINE_M)
        return rp.reference.vehicle_roughness(*(road.relief(x, np.full_like(x, y)) for y in (half_track, -half_track)),
                                              FINE_M, cfg)
    ds = cfg.profile.ds_m
    x = np.arange(start_m + ds / 2, end_m, ds)
    return rp.reference.vehicle_roughness(strip_heights(road, x, half_track, cfg),
                                          strip_heights(road, x, -half_track, cfg), ds, cfg)


def row(iso_class: str, frames: int, tire_width: float, kept: dict) -> list:
    """The class's table row; `kept[iso_class]` gets the stitched / strip power ratio per frequency."""
    singles, segments, psds = [], [], []
    for seed in (3, 4):
        s, g, p = drive(iso_class, seed, frames, tire_width)
        singles += s
        segments += [x for x in g if x[0] is not None]
        psds += p
    n = psds[0][0]
    kept[iso_class] = (n, np.mean([p[1] for p in psds], axis=0) / np.mean([p[2] for p in psds], axis=0))
    classed = [x for x in segments if x[2] is not None]
    same = sum(c == t for t, _, c, _, _ in classed)
    near = sum(abs(CLASSES.index(c) - CLASSES.index(t)) <= 1 for t, _, c, _, _ in classed)
    single = [c for c in singles if c]
    return [iso_class, f"{len(segments)}", f"{len(classed)}", f"{same}", f"{near}",
            spread([cg / tg for _, tg, _, cg, _ in classed]), spread([cg / sg for _, _, _, cg, sg in classed]),
            f"{len(single)} of {len(singles)}, {sum(c == iso_class for c in single)} right"]


def spread(ratios: list) -> str:
    return f"{np.median(ratios):.2f} ({min(ratios):.2f}–{max(ratios):.2f})" if ratios else "–"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--frames", type=int, default=80, help="frames per drive (80: 68.8 m)")
    p.add_argument("--classes", default="BCD")
    p.add_argument("--tire-width", type=float, default=rp.Config().tire_width,
                   help="m, the width of the strip each wheel's profile reads (default: the config's)")
    a = p.parse_args()
    kept = {}
    print(md_table(["road", "segments to 60 m", "classed", "same class", "within one class",
                    "G_d(n0) stitched / line, median (range)", "stitched / strip", "single frames classed"],
                   [row(c, a.frames, a.tire_width, kept) for c in a.classes]))
    print(f"\nWhat the stitched profile keeps of each wave: its power / the strip's road's ({SPECTRA_M[0]:g}–"
          f"{SPECTRA_M[1]:g} m of both wheels and seeds, Welch over {SEGMENT_M:g} m pieces)\n")
    n = next(iter(kept.values()))[0]
    picks = [k for k in range(len(n)) if round(n[k], 2) in SPECTRA_CPM]
    print(md_table(["n (cycles/m)", "wavelength (m)"] + [f"road {c}" for c in kept],
                   [[f"{n[k]:g}", f"{1 / n[k]:.2g}"] + [f"{kept[c][1][k]:.2f}" for c in kept] for k in picks]))


if __name__ == "__main__":
    main()
