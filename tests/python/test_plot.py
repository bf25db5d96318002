"""roadpreview.plot: the pictures draw what the output line says (matplotlib with the Agg backend)."""

import json
import subprocess
import sys

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

import roadpreview as rp  # noqa: E402
from roadpreview import plot  # noqa: E402
from paths import KITTI_FRAMES, KITTI_SENSOR_HEIGHT, cli  # noqa: E402


@pytest.fixture(scope="module")
def line():
    points = rp.io.read(KITTI_FRAMES[0])
    return rp.Estimator(rp.Config(sensor_height=KITTI_SENSOR_HEIGHT)).process(points, 5.0, 0.05).to_dict()


def test_psd_plot_shows_the_fit_over_the_band_and_the_class_bands(line):
    rough = line["roughness"]["vehicle"]
    assert rough["class"] is not None
    ax = plot.plot_psd(rough)
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    fit = next(l for l in ax.get_lines() if l.get_label().startswith("fit"))
    n, g = fit.get_data()
    assert n[0] == pytest.approx(rough["band"][0]) and n[-1] == pytest.approx(rough["band"][1])
    np.testing.assert_allclose(g, rough["gd_n0"] * (n / 0.1) ** -2, rtol=1e-12)
    assert len(ax.collections) >= 8  # the eight ISO 8608 class bands
    assert rough["class"] in ax.get_title()


def test_profile_plot_marks_backed_bins_and_shades_missing_ones(line):
    ax = plot.plot_profiles(line)
    left = line["profiles"]["left"]
    dots = [l for l in ax.get_lines() if l.get_marker() == "."][0]
    assert len(dots.get_xdata()) == sum(c > 0 for c in left["count"])
    missing = sum(v is None for v in left["z"]) + sum(v is None for v in line["profiles"]["right"]["z"])
    assert missing > 0 and len(ax.patches) > 0  # missing stretches are shaded


def test_wheel_paths_are_the_planned_arcs(line):
    paths = plot.wheel_paths(line, 1.6, 40.0)
    icr = line["path"]["icr_y"]
    for wheel, radius in (("left", line["path"]["left_radius"]), ("right", line["path"]["right_radius"])):
        x, y = paths[wheel]
        np.testing.assert_allclose(np.hypot(x, y - icr), radius, rtol=1e-12)
        assert x[0] == pytest.approx(0.0, abs=1e-12) and x[-1] > 35


def test_command_line_writes_the_three_pictures(tmp_path):
    out_jsonl = tmp_path / "out.jsonl"
    subprocess.run([cli(), "run", str(KITTI_FRAMES[0]), "--sensor-height", str(KITTI_SENSOR_HEIGHT), "--speed", "5",
                    "--yaw-rate", "0.05", "-o", str(out_jsonl), "-q"], check=True)
    run = subprocess.run([sys.executable, "-m", "roadpreview.plot", str(out_jsonl), "-o", str(tmp_path / "png"),
                          "--sensor-height", str(KITTI_SENSOR_HEIGHT)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert "differs" not in run.stderr  # the recomputed ground plane is the run's
    for kind in ("psd", "profiles", "birdseye"):
        png = tmp_path / "png" / f"frame0_{kind}.png"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    bad = subprocess.run([sys.executable, "-m", "roadpreview.plot", str(tmp_path / "missing.jsonl"), "-o",
                          str(tmp_path)], capture_output=True, text=True)
    assert bad.returncode != 0 and "missing.jsonl" in bad.stderr
    json.loads(out_jsonl.read_text().splitlines()[0])  # the input stays a JSONL line
