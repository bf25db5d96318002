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
frame<N>_profiles.png for each frame, and frame<N>_birdseye.png when the frame's source can be read again: a frame
file, or a pcap recording decoded again up to the frame with the line's timestamp (otherwise the view is skipped
with a note on stderr). The ground mask is computed again, so give the run's config with --config or
--sensor-height.
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


def plot_psd(roughness: dict, ax=None, title: str | None = None, ylim: tuple[float, float] | None = None):
    """The PSD of one roughness object (``line["roughness"]["left"]``, …) with the ISO 8608 classes.

    ``ylim`` fixes the y-range (panels side by side share one, see :func:`psd_ylim`)."""
    ax = _axes(ax)
    n, psd = np.asarray(roughness["n"][1:], float), np.asarray(roughness["psd"][1:], float)
    ax.set_title(_wrapped(title or _roughness_title(roughness)), fontsize=9)
    if len(n) == 0:
        ax.text(0.5, 0.5, roughness.get("reason") or "no PSD", transform=ax.transAxes, ha="center")
        return ax
    grid = _psd_grid(n)
    shape = (grid / N0) ** -2.0
    bounds = _class_bounds()
    ylim = ylim or psd_ylim([roughness])
    for k, cls in enumerate(ISO_CLASSES):
        ax.fill_between(grid, bounds[k] * shape, bounds[k + 1] * shape, color=plt.cm.Greys(0.08 + 0.05 * (k % 2)),
                        lw=0, label="ISO 8608 classes A–H" if k == 0 else None)
        _class_label(ax, cls, math.sqrt(bounds[k] * bounds[k + 1]), grid, ylim)
    ax.loglog(n, psd, color="tab:blue", lw=1, label="PSD of the profile")
    if roughness.get("noise_psd"):
        ax.loglog(n, np.asarray(roughness["noise_psd"][1:], float), "--", color="tab:red", lw=1,
                  label="noise PSD of the bins")
    if roughness.get("band"):
        lo, hi = roughness["band"]
        ax.axvspan(lo, hi, color="tab:green", alpha=0.08, lw=0, label="analysis band")
        fit = np.geomspace(lo, hi, 20)
        ax.loglog(fit, roughness["gd_n0"] * (fit / N0) ** -2.0, color="tab:green", lw=2.5,
                  label=f"fit, G_d(n0) = {roughness['gd_n0'] * 1e6:.0f}·10⁻⁶ m³")
    ax.set_xlim(grid[0], grid[-1])
    ax.set_ylim(*ylim)
    ax.set_xlabel("spatial frequency n (cycles/m)")
    ax.set_ylabel("G_d(n) (m³)")
    ax.legend(fontsize=7, loc="lower left")
    return ax


def psd_ylim(roughnesses) -> tuple[float, float]:
    """One y-range (m³) holding every given roughness object's PSD and the ISO 8608 class bands."""
    lows, highs = [], []
    for r in roughnesses:
        n, psd = np.asarray(r["n"][1:], float), np.asarray(r["psd"][1:], float)
        if len(n) == 0:
            continue
        shape = (_psd_grid(n) / N0) ** -2.0
        positive = psd[psd > 0]
        lows.append(max(positive.min() if len(positive) else 1e-12, ISO_LIMITS[0] / 8 * shape[-1]) / 3)
        highs.append(max(np.nanmax(psd), _class_bounds()[-1] * shape[0]) * 3)
    return (min(lows), max(highs)) if lows else (1e-12, 1.0)


def _psd_grid(n: np.ndarray) -> np.ndarray:
    return np.geomspace(min(n[0], 0.05), max(n[-1], 5.0), 50)


def _class_bounds() -> np.ndarray:
    return np.concatenate(([ISO_LIMITS[0] / 8], ISO_LIMITS, [ISO_LIMITS[-1] * 8]))


def _class_label(ax, cls: str, gd_n0: float, grid: np.ndarray, ylim) -> None:
    """The class letter inside the axes at the left edge of its band (below the PSD's first ordinate, where no
    data are drawn), when the band is in view there."""
    x = grid[0] * 1.04
    y = gd_n0 * (x / N0) ** -2.0
    if ylim[0] * 1.5 < y < ylim[1] / 1.5:
        ax.text(x, y, cls, va="center", ha="left", fontsize=8, color="0.3")


def _wrapped(text: str, width: int = 60) -> str:
    import textwrap

    return "\n".join(textwrap.wrap(text, width)) if text else text


def _roughness_title(r: dict) -> str:
    if r.get("class") is None:
        return f"no class: {r.get('reason')}"
    band = f"{r['band'][0]:.2f}–{r['band'][1]:.2f} cycles/m ({r.get('band_limit')})"
    return f"class {r['class']}, confidence {r['confidence']:.2f}, band {band}"


def plot_profiles(line: dict, ax=None):
    """Both wheels' profiles along s: lines through all valid bins, dots where points back a bin, light shading
    where a profile is missing, hatching where an obstacle blocks it."""
    ax = _axes(ax)
    for wheel, color in WHEELS:
        p = line["profiles"][wheel]
        s = np.asarray(p["s"], float)
        z = np.array([np.nan if v is None else v for v in p["z"]], float) * 100
        backed = np.asarray(p["count"]) > 0
        ax.plot(s, z, color=color, lw=1, label=f"{wheel} wheel")
        ax.plot(s[backed], z[backed], ".", color=color, ms=3, label=f"{wheel}: bins with points")
        blocked = np.asarray(p.get("blocked") or np.zeros(len(s), bool), bool)
        _shade(ax, s, np.isnan(z) & ~blocked, p["ds"], dict(color=color, alpha=0.07), f"{wheel}: missing")
        _shade(ax, s, blocked, p["ds"], dict(facecolor="none", edgecolor=color, hatch="///", alpha=0.6),
               f"{wheel}: blocked by an obstacle")
    ax.set_xlabel("s, arc length ahead along the wheel path (m)")
    ax.set_ylabel("height above the ground plane (cm)")
    ax.set_title("profiles: dots = bins with points, lines = interpolated", fontsize=10)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    return ax


def _shade(ax, s, mask, ds: float, style: dict, label: str) -> None:
    """Spans over the runs of ``mask``; the first one carries the legend label."""
    for i, (start, stop) in enumerate(_runs(mask)):
        ax.axvspan(s[start] - ds / 2, s[stop - 1] + ds / 2, lw=0, label=label if i == 0 else None, **style)


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
    """Base-frame (x, y) of each wheel's path over the preview length: straight ahead (behind when reversing),
    or arcs about the ICR; a stopped vehicle's paths have no length."""
    speed = line["motion"]["speed"]
    icr = (line.get("path") or {}).get("icr_y")
    s = np.linspace(0.0, preview_length_m if speed != 0 else 0.0, 200)
    paths = {}
    for wheel, y0 in (("left", track_width_m / 2), ("right", -track_width_m / 2)):
        if icr is None:
            paths[wheel] = (math.copysign(1.0, speed) * s, np.full_like(s, y0))
            continue
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
        ax.plot(x, y, color=color, lw=tire_width_m * 20, alpha=0.35, solid_capstyle="butt",
                label=f"{wheel} wheel corridor (tire width)")
        ax.plot(x, y, color=color, lw=0.8, label=f"{wheel} wheel path")
    x_min, x_max = (-5, extent_m) if line["motion"]["speed"] >= 0 else (-extent_m, 5)
    y_max = extent_m / 3
    icr = (line.get("path") or {}).get("icr_y")
    if icr is not None:
        shown = float(np.clip(icr, -0.95 * y_max, 0.95 * y_max))  # an ICR off the view sits on its edge
        ax.plot([0, 0], [0, shown], ":", color="k", lw=0.8)
        ax.plot(0, shown, "k+" if shown == icr else "k^" if icr > 0 else "kv", ms=8,
                label=f"ICR at y = {icr:.1f} m" + ("" if shown == icr else " (off the view)"))
    ax.set_aspect("equal")
    ax.set_xlim(x_min, x_max)
    ax.set_ylim(-y_max, y_max)
    ax.set_xlabel("x forward (m)")
    ax.set_ylabel("y left (m)")
    ax.set_title(f"frame {line['frame']}: {line['motion']['speed']:g} m/s, {line['motion']['yaw_rate']:g} rad/s",
                 fontsize=10)
    legend = ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    for handle in getattr(legend, "legend_handles", None) or legend.legendHandles:
        if hasattr(handle, "set_sizes"):  # the point clouds' dots, large enough to see their colour
            handle.set_sizes([12])
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


class _Sources:
    """The points of each line's frame: a frame file read again, or a recording decoded again up to the frame
    whose timestamp is the line's (recordings are read on, in order, and reopened when a line goes back)."""

    def __init__(self, beside: Path = Path(".")):
        self._beside = beside  # where a relative source is looked for when not here: the output file's folder
        self._open = {}  # recording → (frame iterator, last frame read)

    def points(self, line: dict):
        """(N, C) points of the line's frame, or a note saying why there are none."""
        from . import io

        source = Path(line["source"])
        if not source.is_file() and not source.is_absolute() and (self._beside / source).is_file():
            source = self._beside / source  # the run was started beside its output, plotted from elsewhere
        if not source.is_file():
            return f"{source}: not found" + ("" if source.is_absolute() else f" here nor in {self._beside}")
        try:
            if source.suffix.lower() not in (".pcap", ".pcapng"):
                return io.read(source)
            return self._recorded(source, line.get("timestamp"))
        except (RuntimeError, ValueError) as err:
            return str(err)

    def _recorded(self, source: Path, timestamp):
        if timestamp is None:
            return f"{source}: the line has no timestamp to find its frame by"
        frames, last = self._open.get(source, (None, None))
        if frames is None or last is None or last.timestamp >= timestamp:
            from . import io

            frames, last = iter(io.open(source)), None
        for frame in frames:
            self._open[source] = (frames, frame)
            if frame.timestamp == timestamp:
                return frame.points
            if frame.timestamp > timestamp:
                break
        self._open.pop(source, None)
        return f"{source}: no frame at t = {timestamp:.6f} s"


def _line_config(cfg, line: dict):
    """cfg with the run's mounting from the line (``mounting.extrinsics``) when the plot was given none."""
    import dataclasses

    from .config import Extrinsics

    mounting = line.get("mounting") or {}
    if cfg.sensor_height is not None or cfg.extrinsics is not None or mounting.get("source") in (None, "none"):
        return cfg
    return dataclasses.replace(cfg, extrinsics=Extrinsics(*mounting["extrinsics"]))


def _birdseye_inputs(line: dict, cfg, sources: _Sources):
    """(base-frame points, ground mask) of the line's frame, recomputed with cfg (or the line's mounting); a note
    when unreadable."""
    from . import Estimator, reference

    cfg = _line_config(cfg, line)
    points = sources.points(line)
    if isinstance(points, str):
        return points
    result = Estimator(cfg).process(points, line["motion"]["speed"], line["motion"]["yaw_rate"])
    plane = line["ground"]["plane"]
    if plane is not None and (result.plane is None or not np.allclose(result.plane, plane, atol=1e-5)):
        print(f"{line['source']}: frame {line['frame']}: the ground plane differs from the line's; give the run's "
              "config (--config or --sensor-height)", file=sys.stderr)
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
    sources = _Sources(args.jsonl.parent)
    for line in _load_lines(args.jsonl):
        if wanted is not None and line["frame"] not in wanted:
            continue
        stem = args.out / f"frame{line['frame']}"
        sides = ("left", "right", "vehicle")
        ylim = psd_ylim(line["roughness"][side] for side in sides)
        fig, axes = plt.subplots(1, 3, figsize=(16, 5))
        for ax, side in zip(axes, sides):
            plot_psd(line["roughness"][side], ax, f"{side}: {_roughness_title(line['roughness'][side])}", ylim)
        _save(fig, f"{stem}_psd.png", args.dpi)
        fig, ax = plt.subplots(figsize=(11, 4))
        plot_profiles(line, ax)
        _save(fig, f"{stem}_profiles.png", args.dpi)
        inputs = _birdseye_inputs(line, cfg, sources)
        if isinstance(inputs, str):
            print(f"frame {line['frame']}: bird's-eye view skipped ({inputs})", file=sys.stderr)
            continue
        fig, ax = plt.subplots(figsize=(11, 6))
        plot_birdseye(*inputs, line, cfg.track_width, cfg.tire_width, cfg.profile.preview_length_m, ax)
        _save(fig, f"{stem}_birdseye.png", args.dpi)
    return 0


def _save(fig, path: str, dpi: int) -> None:
    fig.tight_layout()
    fig.savefig(path, dpi=dpi, bbox_inches="tight")  # keeps the legends outside the axes in the picture
    plt.close(fig)
    print(path, file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
