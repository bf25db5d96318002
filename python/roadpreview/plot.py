"""Pictures of roadpreview results with matplotlib (an optional extra: ``pip install roadpreview[plot]``).

Every function takes one output line as a dict (``Result.to_dict()`` or a parsed line of the CLI's JSONL,
docs/output.md) and draws on a matplotlib Axes:

* ``plot_psd``: one roughness object's PSD on log-log axes, the ISO 8608 class bands shaded, the fitted line
  over the band used, and the noise PSD;
* ``plot_profiles``: both wheels' height profiles along s, points-backed bins marked, missing stretches shaded;
* ``plot_sensor_comparison``: one frame's wheel profiles as several sensors saw it (stereo and LiDAR);
* ``plot_birdseye``: one frame from above, ground and other points, the wheel corridors and the ICR arcs
  (needs the points too).

From the command line, ``python -m roadpreview.plot OUT.jsonl -o DIR`` writes frame<N>_psd.png and
frame<N>_profiles.png for each frame, and frame<N>_birdseye.png when the frame's source file can be read (the
ground mask is computed again, so give the run's config with --config or --sensor-height).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

try:
    import matplotlib
    from matplotlib import pyplot as plt
except ImportError as _err:  # pragma: no cover - the message is the point
    raise ImportError("roadpreview.plot needs matplotlib: pip install 'roadpreview[plot]'") from _err

ISO_CLASSES = "ABCDEFGH"
ISO_LIMITS = 32e-6 * 4.0 ** np.arange(7)  # m³, between classes
N0 = 0.1  # cycles/m
WHEELS = (("left", "tab:blue"), ("right", "tab:orange"))


def _axes(ax):
    return ax if ax is not None else plt.subplots(figsize=(7, 4.5))[1]


def plot_psd(roughness: dict, ax=None, title: str | None = None):
    """The PSD of one roughness object (``line["roughness"]["left"]``, …) with the ISO 8608 classes."""
    ax = _axes(ax)
    n, psd = np.asarray(roughness["n"][1:], float), np.asarray(roughness["psd"][1:], float)
    if len(n) == 0:
        ax.text(0.5, 0.5, roughness.get("reason") or "no PSD", transform=ax.transAxes, ha="center")
        return ax
    grid = np.geomspace(min(n[0], 0.05), max(n[-1], 5.0), 50)
    shape = (grid / N0) ** -2.0
    bounds = np.concatenate(([ISO_LIMITS[0] / 8], ISO_LIMITS, [ISO_LIMITS[-1] * 8]))
    for k, cls in enumerate(ISO_CLASSES):
        ax.fill_between(grid, bounds[k] * shape, bounds[k + 1] * shape, color=plt.cm.Greys(0.08 + 0.05 * (k % 2)),
                        lw=0)
        ax.text(grid[-1], math.sqrt(bounds[k] * bounds[k + 1]) * shape[-1], f" {cls}", va="center", fontsize=8)
    ax.loglog(n, psd, color="tab:blue", lw=1, label="PSD of the profile")
    if roughness.get("noise_psd"):
        ax.loglog(n, np.asarray(roughness["noise_psd"][1:], float), "--", color="tab:red", lw=1,
                  label="noise PSD of the bins")
    if roughness.get("band"):
        lo, hi = roughness["band"]
        ax.axvspan(lo, hi, color="tab:green", alpha=0.08, lw=0)
        fit = np.geomspace(lo, hi, 20)
        ax.loglog(fit, roughness["gd_n0"] * (fit / N0) ** -2.0, color="tab:green", lw=2.5,
                  label=f"fit, G_d(n0) = {roughness['gd_n0'] * 1e6:.0f}·10⁻⁶ m³")
    ax.set_xlim(grid[0], grid[-1])
    ax.set_ylim(max(np.nanmin(psd[psd > 0]) if np.any(psd > 0) else 1e-12, ISO_LIMITS[0] / 8 * shape[-1]) / 3,
                max(np.nanmax(psd), bounds[-1] * shape[0]) * 3)
    ax.set_xlabel("spatial frequency n (cycles/m)")
    ax.set_ylabel("G_d(n) (m³)")
    ax.set_title(title or _roughness_title(roughness), fontsize=10)
    ax.legend(fontsize=8, loc="lower left")
    return ax


def _roughness_title(r: dict) -> str:
    if r.get("class") is None:
        return f"no class: {r.get('reason')}"
    band = f"{r['band'][0]:.2f}–{r['band'][1]:.2f} cycles/m ({r.get('band_limit')})"
    return f"class {r['class']}, confidence {r['confidence']:.2f}, band {band}"


def plot_profiles(line: dict, ax=None):
    """Both wheels' profiles along s: lines through all valid bins, dots where points back a bin, grey where a
    profile is missing."""
    ax = _axes(ax)
    for wheel, color in WHEELS:
        p = line["profiles"][wheel]
        s = np.asarray(p["s"], float)
        z = np.array([np.nan if v is None else v for v in p["z"]], float) * 100
        backed = np.asarray(p["count"]) > 0
        ax.plot(s, z, color=color, lw=1, label=f"{wheel} wheel")
        ax.plot(s[backed], z[backed], ".", color=color, ms=3)
        missing = np.isnan(z)
        for start, stop in _runs(missing):
            ax.axvspan(s[start] - p["ds"] / 2, s[stop - 1] + p["ds"] / 2, color=color, alpha=0.07, lw=0)
    ax.set_xlabel("s, arc length ahead along the wheel path (m)")
    ax.set_ylabel("height above the ground plane (cm)")
    ax.set_title("profiles: dots = bins with points, lines = interpolated, shaded = missing", fontsize=10)
    ax.legend(fontsize=8)
    return ax


def plot_sensor_comparison(lines: dict, title: str | None = None):
    """One frame seen by several sensors ({name: output line}, e.g. a stereo pair and the LiDAR scan of the same
    instant): each wheel's profile per sensor, dots where points back a bin. Returns the figure."""
    fig, axes = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
    colors = ("tab:blue", "tab:orange", "tab:green", "tab:red")
    for ax, (wheel, _) in zip(axes, WHEELS):
        for (name, line), color in zip(lines.items(), colors):
            p = line["profiles"][wheel]
            s = np.asarray(p["s"], float)
            z = np.array([np.nan if v is None else v for v in p["z"]], float) * 100
            backed = np.asarray(p["count"]) > 0
            ax.plot(s, z, color=color, lw=1, label=name)
            ax.plot(s[backed], z[backed], ".", color=color, ms=2.5)
        ax.set_ylabel(f"{wheel} wheel: height (cm)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    axes[-1].set_xlabel("s, arc length ahead along the wheel path (m)")
    if title:
        axes[0].set_title(title, fontsize=10)
    fig.tight_layout()
    return fig


def _runs(mask) -> list[tuple[int, int]]:
    edges = np.flatnonzero(np.diff(np.concatenate(([0], np.asarray(mask, np.int8), [0]))))
    return list(zip(edges[0::2], edges[1::2]))


def wheel_paths(line: dict, track_width_m: float, preview_length_m: float) -> dict:
    """Base-frame (x, y) of each wheel's path over the preview length (straight, or arcs about the ICR)."""
    speed = line["motion"]["speed"]
    s = np.linspace(0.0, preview_length_m, 200)
    paths = {}
    for wheel, y0 in (("left", track_width_m / 2), ("right", -track_width_m / 2)):
        if line["path"] is None:
            paths[wheel] = (math.copysign(1.0, speed) * s, np.full_like(s, y0))
            continue
        icr = line["path"]["icr_y"]
        arm = y0 - icr
        angle = math.copysign(1.0, line["motion"]["yaw_rate"]) * np.minimum(s / abs(arm), math.pi)
        paths[wheel] = (-np.sin(angle) * arm, icr + np.cos(angle) * arm)
    return paths


def plot_birdseye(base_xyz, ground_mask, line: dict, track_width_m: float = 1.6, tire_width_m: float = 0.3,
                  preview_length_m: float = 40.0, ax=None, extent_m: float = 45.0):
    """One frame from above (base frame): ground and other points, the wheel corridors, the ICR arcs."""
    ax = _axes(ax)
    xyz, ground = np.asarray(base_xyz, float), np.asarray(ground_mask, bool)
    near = (np.abs(xyz[:, 0]) < extent_m) & (np.abs(xyz[:, 1]) < extent_m / 2)
    ax.scatter(xyz[near & ~ground, 0], xyz[near & ~ground, 1], s=0.3, color="0.45", lw=0, label="not ground")
    ax.scatter(xyz[near & ground, 0], xyz[near & ground, 1], s=0.3, color="tab:green", lw=0, label="ground")
    for (wheel, color), (x, y) in zip(WHEELS, wheel_paths(line, track_width_m, preview_length_m).values()):
        ax.plot(x, y, color=color, lw=tire_width_m * 20, alpha=0.35, solid_capstyle="butt")
        ax.plot(x, y, color=color, lw=0.8, label=f"{wheel} wheel corridor")
    if line["path"] is not None:
        icr = line["path"]["icr_y"]
        ax.plot([0, 0], [0, icr], ":", color="k", lw=0.8)
        ax.plot(0, icr, "k+", ms=8, label=f"ICR at y = {icr:.0f} m")
    ax.set_aspect("equal")
    ax.set_xlim(-5, extent_m)
    ax.set_ylim(-extent_m / 3, extent_m / 3)
    ax.set_xlabel("x forward (m)")
    ax.set_ylabel("y left (m)")
    ax.set_title(f"frame {line['frame']}: {line['motion']['speed']:g} m/s, {line['motion']['yaw_rate']:g} rad/s",
                 fontsize=10)
    ax.legend(fontsize=7, loc="lower right", markerscale=8)
    return ax


# ------------------------------------------------------------------------------------------------ CLI
def _load_lines(path: Path) -> list[dict]:
    import json

    try:
        lines = [json.loads(text) for text in path.read_text().splitlines() if text.strip()]
    except (OSError, ValueError) as err:
        raise SystemExit(f"{path}: not a readable roadpreview JSONL file ({err})") from None
    if not lines or "roughness" not in lines[0]:
        raise SystemExit(f"{path}: no roadpreview output lines in it")
    return lines


def _birdseye_inputs(line: dict, cfg):
    """(base-frame points, ground mask) of the frame's source file, recomputed with cfg; None if unreadable."""
    from . import Estimator, io, reference

    source = Path(line["source"])
    if not source.is_file():
        return None
    points = io.read(source)
    result = Estimator(cfg).process(points, line["motion"]["speed"], line["motion"]["yaw_rate"])
    plane = line["ground"]["plane"]
    if plane is not None and (result.plane is None or not np.allclose(result.plane, plane, atol=1e-5)):
        print(f"{source}: the ground plane differs from the line's; give the run's config (--config)", file=sys.stderr)
    base, finite = reference.to_base_frame(points, cfg)
    return base, np.asarray(result.ground_mask)[finite]


def main(argv=None) -> int:
    from .config import Config

    parser = argparse.ArgumentParser(prog="python -m roadpreview.plot", description=__doc__.split("\n\n")[0])
    parser.add_argument("jsonl", type=Path, help="output of `roadpreview run`")
    parser.add_argument("-o", "--out", type=Path, required=True, help="directory for the PNG files")
    parser.add_argument("--frames", help="comma-separated frame numbers (default: all)")
    parser.add_argument("--config", type=Path, help="the run's config file (for the bird's-eye view)")
    parser.add_argument("--sensor-height", type=float, help="the run's --sensor-height (for the bird's-eye view)")
    parser.add_argument("--dpi", type=int, default=90)
    args = parser.parse_args(argv)
    matplotlib.use("Agg")
    cfg = Config.from_file(args.config) if args.config else Config()
    if args.sensor_height is not None:
        cfg.sensor_height, cfg.extrinsics = args.sensor_height, None
    wanted = {int(f) for f in args.frames.split(",")} if args.frames else None
    args.out.mkdir(parents=True, exist_ok=True)
    for line in _load_lines(args.jsonl):
        if wanted is not None and line["frame"] not in wanted:
            continue
        stem = args.out / f"frame{line['frame']}"
        fig, axes = plt.subplots(1, 3, figsize=(16, 4.5))
        for ax, side in zip(axes, ("left", "right", "vehicle")):
            plot_psd(line["roughness"][side], ax, title=f"{side}: {_roughness_title(line['roughness'][side])}")
        _save(fig, f"{stem}_psd.png", args.dpi)
        fig, ax = plt.subplots(figsize=(9, 4))
        plot_profiles(line, ax)
        _save(fig, f"{stem}_profiles.png", args.dpi)
        inputs = _birdseye_inputs(line, cfg)
        if inputs is not None:
            fig, ax = plt.subplots(figsize=(9, 6))
            plot_birdseye(*inputs, line, cfg.track_width, cfg.tire_width, cfg.profile.preview_length_m, ax)
            _save(fig, f"{stem}_birdseye.png", args.dpi)
    return 0


def _save(fig, path: str, dpi: int) -> None:
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    print(path, file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
