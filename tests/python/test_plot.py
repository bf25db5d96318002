"""roadpreview.plot: the pictures draw what the output line says (matplotlib with the Agg backend)."""

import json
import shutil
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


def plot_cli(jsonl, out_dir, *args):
    return subprocess.run([sys.executable, "-m", "roadpreview.plot", str(jsonl), "-o", str(out_dir), *map(str, args)],
                          capture_output=True, text=True, timeout=300)


def test_straight_run_draws_straight_corridors(tmp_path):
    out_jsonl = tmp_path / "straight.jsonl"
    subprocess.run([cli(), "run", str(KITTI_FRAMES[0]), "--sensor-height", str(KITTI_SENSOR_HEIGHT), "--speed", "5",
                    "-o", str(out_jsonl), "-q"], check=True)
    line = json.loads(out_jsonl.read_text().splitlines()[0])
    assert line["path"]["icr_y"] is None  # the CLI's path object without an arc
    for wheel, y0 in (("left", 0.8), ("right", -0.8)):
        x, y = plot.wheel_paths(line, 1.6, 40.0)[wheel]
        np.testing.assert_allclose(y, y0)
        assert x[0] == 0 and x[-1] == pytest.approx(40.0)
    run = plot_cli(out_jsonl, tmp_path / "png", "--sensor-height", KITTI_SENSOR_HEIGHT)
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "png" / "frame0_birdseye.png").exists()


def test_reversing_corridors_lie_behind(line):
    back = dict(line, motion=dict(line["motion"], speed=-5.0), path=None)
    x, _ = plot.wheel_paths(back, 1.6, 40.0)["left"]
    assert x[-1] == pytest.approx(-40.0)


def test_pcap_output_is_plotted_from_the_recording(tmp_path):
    from paths import OS1_128_HEIGHT, OS1_128_PCAP

    out_jsonl = tmp_path / "demo.jsonl"
    subprocess.run([cli(), "run", str(OS1_128_PCAP), "--sensor-height", str(OS1_128_HEIGHT), "--speed", "2.5",
                    "--frames", "1:3", "-o", str(out_jsonl), "-q"], check=True)
    run = plot_cli(out_jsonl, tmp_path / "png", "--sensor-height", OS1_128_HEIGHT)
    assert run.returncode == 0, run.stderr
    assert "differs" not in run.stderr  # frames 1 and 2 of the recording, found by their timestamps
    for frame in (0, 1):
        for kind in ("psd", "profiles", "birdseye"):
            assert (tmp_path / "png" / f"frame{frame}_{kind}.png").exists()


def test_a_relative_source_is_found_beside_the_output_when_plotted_from_elsewhere(tmp_path):
    """A run started in its data's folder writes the source as given (relative); plotted from another folder, the
    frame is looked for beside the output file too (it was skipped as "not found")."""
    shutil.copy(KITTI_FRAMES[0], tmp_path / "frame.bin")
    subprocess.run([cli(), "run", "frame.bin", "--speed", "5", "--sensor-height", str(KITTI_SENSOR_HEIGHT), "-q",
                    "-o", "run.jsonl"], check=True, cwd=tmp_path)
    assert json.loads((tmp_path / "run.jsonl").read_text())["source"] == "frame.bin"
    run = plot_cli(tmp_path / "run.jsonl", tmp_path / "png", "--sensor-height", KITTI_SENSOR_HEIGHT)
    assert run.returncode == 0 and "skipped" not in run.stderr, run.stderr
    assert (tmp_path / "png" / "frame0_birdseye.png").exists()


def test_a_source_that_cannot_be_read_is_skipped_with_a_note(tmp_path, line):
    jsonl = tmp_path / "moved.jsonl"
    jsonl.write_text(json.dumps(dict(line, source=str(tmp_path / "gone.pcap"))) + "\n")
    run = plot_cli(jsonl, tmp_path / "png")
    assert run.returncode == 0, run.stderr
    assert "gone.pcap" in run.stderr and "bird's-eye view skipped" in run.stderr
    assert (tmp_path / "png" / "frame0_psd.png").exists() and not (tmp_path / "png" / "frame0_birdseye.png").exists()


def test_psd_panels_share_one_y_range_and_keep_class_labels_inside(line):
    ylim = plot.psd_ylim(line["roughness"][side] for side in ("left", "right", "vehicle"))
    fig, axes = matplotlib.pyplot.subplots(1, 3)
    for ax, side in zip(axes, ("left", "right", "vehicle")):
        plot.plot_psd(line["roughness"][side], ax, ylim=ylim)
    assert len({ax.get_ylim() for ax in axes}) == 1
    for ax in axes:
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        labels = [t for t in ax.texts if t.get_text() in "ABCDEFGH"]
        assert labels and all(x0 < t.get_position()[0] < x1 and y0 < t.get_position()[1] < y1 for t in labels)
        legend = [t.get_text() for t in ax.get_legend().get_texts()]
        assert "ISO 8608 classes A–H" in legend and "analysis band" in legend  # every shading is named
    matplotlib.pyplot.close(fig)


def test_long_titles_are_wrapped(line):
    ax = plot.plot_psd(line["roughness"]["left"], title="left: " + "a very long reason " * 8)
    assert "\n" in ax.get_title()


def test_profile_plot_shows_blocked_bins_and_names_every_shading(line):
    blocked = dict(line["profiles"]["left"])
    n = len(blocked["z"])
    blocked["blocked"] = [10 <= k < 30 for k in range(n)]
    blocked["z"] = [None if 10 <= k < 30 else z for k, z in enumerate(blocked["z"])]
    ax = plot.plot_profiles(dict(line, profiles=dict(line["profiles"], left=blocked)))
    hatched = [p for p in ax.patches if p.get_hatch()]
    assert hatched and hatched[0].get_label() == "left: blocked by an obstacle"
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert {"left: missing", "left: blocked by an obstacle", "left wheel"} <= set(legend)


def test_birdseye_keeps_the_icr_marker_in_view_and_the_legend_outside(line):
    points = rp.io.read(KITTI_FRAMES[0])
    cfg = rp.Config(sensor_height=KITTI_SENSOR_HEIGHT)
    base, finite = rp.reference.to_base_frame(points, cfg)
    ground = np.asarray(rp.Estimator(cfg).process(points, 5.0, 0.05).ground_mask)[finite]
    ax = plot.plot_birdseye(base, ground, line)  # ICR at y = 100 m: far off the view
    marker = next(l for l in ax.get_lines() if l.get_label().startswith("ICR"))
    y = marker.get_ydata()[0]
    assert ax.get_ylim()[0] < y < ax.get_ylim()[1] and "off the view" in marker.get_label()
    anchor = ax.get_legend().get_bbox_to_anchor().transformed(ax.transAxes.inverted())
    assert anchor.x0 >= 1.0  # the legend sits right of the axes, clear of the marker and the corridors
