# SPDX-License-Identifier: BSD-3-Clause
"""Mounting sanity: the sensor's height and tilt read off the ground (C++ and numpy reference), used when none
is given and checked against a given one; heights and source options that cannot be right are refused."""

import json
import math
import warnings

import numpy as np
import pytest

import roadpreview as rp
from roadpreview import native
from paths import KITTI_FRAMES, KITTI_SENSOR_HEIGHT, VELODYNE
from paths import run_cli as run

IMPLEMENTATIONS = {"cpp": native.estimate_mounting, "reference": rp.reference.estimate_mounting}


def sensor_frame_ground(height, roll, pitch, seed=0):
    """A flat ground z = 0 in the base frame with some boxes on it, seen from a sensor at (0, 0, height) tilted
    by roll and pitch: p_sensor = Rᵀ(p_base − t)."""
    rng = np.random.default_rng(seed)
    base = np.column_stack([rng.uniform(2, 38, 20000), rng.uniform(-9, 9, 20000), rng.normal(0, 0.005, 20000)])
    boxes = np.column_stack([rng.uniform(10, 12, 500), rng.uniform(3, 4, 500), rng.uniform(0.3, 1.5, 500)])
    base = np.vstack([base, boxes])
    rotation = rp.reference.frames.rotation_matrix(roll, pitch, 0.0)
    return ((base - [0, 0, height]) @ rotation).astype(np.float32)


@pytest.mark.parametrize("impl", IMPLEMENTATIONS)
@pytest.mark.parametrize("height, roll, pitch", [(1.73, 0.0, 0.0), (2.1, 0.03, -0.05), (0.6, -0.02, 0.08)])
def test_height_and_tilt_come_back_from_the_ground(impl, height, roll, pitch):
    m = IMPLEMENTATIONS[impl](sensor_frame_ground(height, roll, pitch))
    assert m["height_m"] == pytest.approx(height, abs=0.01)
    assert m["roll_rad"] == pytest.approx(roll, abs=1e-3) and m["pitch_rad"] == pytest.approx(pitch, abs=1e-3)
    # only ground below the sensor counts: pitched down 4.6° at 0.6 m, the road beyond ~8 m rises above z = 0
    assert m["ground_points"] > (15000 if height > 1 else 2500)


def test_cpp_and_reference_estimates_agree_on_a_kitti_frame():
    points = rp.io.read(KITTI_FRAMES[0])
    cpp, ref = native.estimate_mounting(points), rp.reference.estimate_mounting(points)
    for key in ("height_m", "roll_rad", "pitch_rad"):
        assert cpp[key] == pytest.approx(ref[key], abs=1e-6)
    assert cpp["height_m"] == pytest.approx(KITTI_SENSOR_HEIGHT, abs=0.1)


@pytest.mark.parametrize("impl", IMPLEMENTATIONS)
def test_no_ground_gives_no_estimate(impl):
    """A wall 5 m ahead (60 × 40 points, from 1.7 m below the sensor to 2 m above) is no ground; on a road, it is."""
    y, z = np.meshgrid(np.linspace(-3, 3, 60), np.linspace(-1.7, 2, 40))
    wall = np.column_stack([np.full(y.size, 5.0), y.ravel(), z.ravel()]).astype(np.float32)
    assert IMPLEMENTATIONS[impl](wall) is None
    rng = np.random.default_rng(0)
    road = np.column_stack([rng.uniform(2, 38, 5000), rng.uniform(-9, 9, 5000), np.full(5000, -1.7)])
    assert IMPLEMENTATIONS[impl](np.vstack([wall, road.astype(np.float32)]))["ground_points"] >= 5000


def test_the_cli_estimates_the_mounting_when_none_is_given_and_says_so(tmp_path):
    out = tmp_path / "o.jsonl"
    proc = run("run", KITTI_FRAMES[0], "--speed", 5, "-o", out)
    line = json.loads(out.read_text())
    assert line["mounting"]["source"] == "estimated" and "mounting estimated" in proc.stderr
    assert line["mounting"]["extrinsics"][2] == pytest.approx(KITTI_SENSOR_HEIGHT, abs=0.1)
    # the estimate fits the ground below the sensor, the frame's fit the whole region: within centimetres
    assert abs(line["mounting"]["ground_offset"]) < 0.03 and line["mounting"]["disagrees"] is False


def test_a_given_height_far_from_the_ground_is_warned_about(tmp_path):
    out = tmp_path / "o.jsonl"
    proc = run("run", KITTI_FRAMES[0], "--speed", 5, "--sensor-height", KITTI_SENSOR_HEIGHT + 2, "-o", out)
    line = json.loads(out.read_text())
    assert line["mounting"]["source"] == "given" and line["mounting"]["disagrees"] is True
    assert line["mounting"]["ground_offset"] == pytest.approx(-2.0, abs=0.1)
    assert "warning" in proc.stderr and f"not {KITTI_SENSOR_HEIGHT + 2:.2f} m" in proc.stderr
    good = json.loads(run("run", KITTI_FRAMES[0], "--speed", 5, "--sensor-height", KITTI_SENSOR_HEIGHT, "-q").stdout)
    assert good["mounting"]["disagrees"] is False


@pytest.mark.parametrize("height", [-1.73, 0, 25, 1e300])
def test_impossible_heights_are_refused(height):
    proc = run("run", KITTI_FRAMES[0], "--speed", 5, "--sensor-height", height, check=False)
    assert proc.returncode == 2 and "--sensor-height: expected a number in (0, 10]" in proc.stderr  # a usage error
    assert f"got {height:g}\n" in proc.stderr, proc.stderr  # the number as given, not 301 digits
    with pytest.raises(ValueError, match="sensor_height"):
        rp.Estimator(rp.Config(sensor_height=height))


@pytest.mark.parametrize("option", [["--meta", "x.json"], ["--sensor-model", "VLP-16"], ["--cut-angle", "90"]])
def test_pcap_options_with_frame_files_are_an_error(option):
    proc = run("run", KITTI_FRAMES[0], "--speed", 5, "--sensor-height", KITTI_SENSOR_HEIGHT, *option, check=False)
    assert proc.returncode != 0 and f"{option[0]} applies to pcap recordings only" in proc.stderr


def test_a_sensor_model_that_overrides_the_packets_is_reported():
    info = run("info", VELODYNE / "hdl32_example.pcap", "--sensor-model", "VLP-16").stdout
    assert "model given: VLP-16; the packets say HDL-32E" in info
    assert "the packets say" not in run("info", VELODYNE / "hdl32_example.pcap", "--sensor-model", "HDL-32E").stdout


def test_an_implausible_estimate_is_not_used(tmp_path):
    from paths import PCD_FILE  # this cloud's origin sits on the ground: no sensor height to read off

    out = tmp_path / "o.jsonl"
    proc = run("run", PCD_FILE, "--speed", 3, "-o", out)
    assert "lies at the cloud's origin" in proc.stderr and "taken as base-frame points" in proc.stderr
    assert json.loads(out.read_text())["mounting"]["source"] == "none"


def test_a_first_frame_without_road_ahead_leaves_the_mounting_to_the_next_frame(tmp_path):
    """The bundled 64-beam Ouster capture starts with 224 columns of a rotation, none of them ahead: its mounting
    comes from the next, whole frame, and only the first frame is taken as base-frame points."""
    from paths import OUSTER

    out = tmp_path / "o.jsonl"
    proc = run("run", OUSTER / "rust-lidar-utils" / "ouster_example.pcap", "--speed", 5, "--fusion", "kalman",
               "-o", out)
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    assert [line["frame"] for line in lines] == [0, 1, 2]
    assert [line["mounting"]["source"] for line in lines] == ["none", "estimated", "estimated"]
    assert lines[1]["mounting"]["extrinsics"][2] == pytest.approx(1.71, abs=0.02)
    assert lines[1]["fusion"]["reset"] == "mounting estimated"
    assert "#12072 to estimate the mounting from" in proc.stderr
    assert "mounting estimated from the ground in" in proc.stderr and "#12073" in proc.stderr


def test_an_estimator_warns_once_when_the_ground_disagrees_with_the_mounting():
    """Sensor-frame points without a mounting: the result said so (mounting.disagrees) and classed the road, but
    nothing told a Python user, as the CLI and rp.run do."""
    points = rp.io.read(KITTI_FRAMES[0])
    est = rp.Estimator(rp.Config())
    with pytest.warns(RuntimeWarning, match=r"^the fitted ground is 1\.75 m below the base origin and tilted 1\.8°: "
                                            r"the points are not base-frame points, as they were taken to be; give "
                                            r"Config\(sensor_height=\.\.\.\) or Config\(extrinsics=\.\.\.\)$"):
        est.process(points, 5.0, 0.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # once per estimator; none with the mounting given
        est.process(points, 5.0, 0.0)
        rp.Estimator(rp.Config(sensor_height=KITTI_SENSOR_HEIGHT)).process(points, 5.0, 0.0)
    with pytest.warns(RuntimeWarning, match=r"the sensor is about 1\.75 m up, not 1\.20 m; check sensor_height"):
        rp.Estimator(rp.Config(sensor_height=1.2)).process(points, 5.0, 0.0)
