# SPDX-License-Identifier: BSD-3-Clause
"""What a user sees at the prompt: useful reprs of results and sources, and the reference's Result.to_dict()
giving the same output line as the C++ core's."""

import numpy as np
import pytest

import roadpreview as rp
from paths import KITTI_FRAMES, KITTI_SENSOR_HEIGHT, OS1_128_PCAP


@pytest.fixture(scope="module")
def frame():
    return rp.io.read(KITTI_FRAMES[0])


def test_result_roughness_and_iri_reprs_say_what_matters(frame):
    res = rp.Estimator(rp.Config(sensor_height=KITTI_SENSOR_HEIGHT)).process(frame, 5.0, 0.05, source="000000.bin")
    text = repr(res)
    assert text.startswith("<roadpreview.Result frame 0 of 000000.bin:") and "124668 points" in text
    assert f"vehicle {res.vehicle.iso_class}" in text and " ms>" in text
    rough = repr(res.vehicle)
    assert f"class {res.vehicle.iso_class}" in rough and "G_d(n0)" in rough and "confidence" in rough
    assert repr(res.left.roughness.iri).startswith("<roadpreview.Iri ") and "m/km" in repr(res.left.roughness.iri)
    stopped = rp.Estimator(rp.Config(sensor_height=KITTI_SENSOR_HEIGHT)).process(frame, 0.0, 0.0)
    assert "no profiles: vehicle stopped" in repr(stopped)
    assert repr(stopped.vehicle) == "<roadpreview.Roughness no class: vehicle stopped; IRI None (vehicle stopped)>"


def test_result_mounting_is_the_output_lines(frame):
    """`Result.mounting` gives what the output line's `mounting` holds (it was only in to_dict())."""
    for cfg in (rp.Config(sensor_height=KITTI_SENSOR_HEIGHT), rp.Config(sensor_height=KITTI_SENSOR_HEIGHT + 2)):
        res = rp.Estimator(cfg).process(frame, 5.0, 0.0)
        mounting, line = res.mounting, res.to_dict()["mounting"]
        assert list(mounting["extrinsics"]) == pytest.approx(line["extrinsics"])
        assert mounting["source"] == line["source"] and mounting["disagrees"] == line["disagrees"]
        assert mounting["ground_offset"] == pytest.approx(line["ground_offset"], abs=1e-6)
        assert mounting["ground_tilt_deg"] == pytest.approx(line["ground_tilt_deg"], abs=1e-6)
    assert mounting["disagrees"] is True  # the sensor said 2 m higher than its ground lies


def test_readout_and_beam_calibration_reprs_say_what_they_hold(frame):
    readout = rp.ProfileReadout(6.0, rp.Config(sensor_height=KITTI_SENSOR_HEIGHT))
    readout.add(rp.Estimator(rp.Config(sensor_height=KITTI_SENSOR_HEIGHT)).process(frame, 5.0, 0.0))
    assert repr(readout) == "<roadpreview.ProfileReadout 6 m ahead: 1 frame(s), 0.00 m driven>"
    for doc in (rp.Result.frame.__doc__, rp.Result.reason.__doc__, rp.Result.points.__doc__):
        assert doc  # help(rp.Result) says what each attribute is


def test_beam_calibration_repr_says_what_it_holds(tmp_path):
    from paths import OS1_128_HEIGHT, OUSTER, run_cli

    out = tmp_path / "beams.yaml"
    run_cli("calibrate", OS1_128_PCAP, "--sensor-height", OS1_128_HEIGHT, "--poses",
            OUSTER / "OS-1-128_v2.3.0_1024x10_lb_n3_poses_kitti.txt", "-o", out, "-q")
    cal = rp.read_beam_calibration(out)
    text = repr(cal)
    determined = int(np.count_nonzero(cal.determined))
    assert text.startswith("<roadpreview.BeamCalibration OS-1-128 ") and f": {determined} of 128 beams determined" in text
    assert f"from {cal.frames} frame(s) over {cal.travel_m:.2f} m>" in text


def test_frame_source_repr_names_the_recording():
    source = rp.io.open(OS1_128_PCAP)
    assert repr(source).startswith("<roadpreview.FrameSource ouster pcap, OS-1-128, RNG15_RFL8_NIR8")


def assert_same_line(ref, cpp, path="line"):
    if isinstance(cpp, dict):
        assert set(ref) == set(cpp), path
        for key in cpp:
            assert_same_line(ref[key], cpp[key], f"{path}.{key}")
    elif isinstance(cpp, list):
        assert len(ref) == len(cpp), path
        for i, (r, c) in enumerate(zip(ref, cpp)):
            assert_same_line(r, c, f"{path}[{i}]")
    elif isinstance(cpp, float) and ref is not None:
        assert ref == pytest.approx(cpp, rel=1e-4, abs=1e-5), path
    else:
        assert ref == cpp, path


@pytest.mark.parametrize("speed, yaw_rate", [(5.0, 0.05), (5.0, 0.0), (0.0, 0.0)])
def test_reference_to_dict_is_the_output_line(frame, speed, yaw_rate):
    cfg = rp.Config(sensor_height=KITTI_SENSOR_HEIGHT, obstacles={"enabled": False})
    ref = rp.reference.process(frame, speed, yaw_rate, cfg).to_dict()
    cpp = rp.Estimator(cfg).process(frame, speed, yaw_rate).to_dict()
    assert ref["timing_ms"] is None
    cpp.pop("timing_ms"), ref.pop("timing_ms")  # the reference does not time its stages
    assert_same_line(ref, cpp)
    assert "<roadpreview.reference.Result" in repr(rp.reference.process(frame, speed, yaw_rate, cfg))


def test_reference_to_dict_with_obstacles_has_the_same_keys(frame):
    cfg = rp.Config(sensor_height=KITTI_SENSOR_HEIGHT)
    ref = rp.reference.process(frame, 5.0, 0.05, cfg).to_dict()
    cpp = rp.Estimator(cfg).process(frame, 5.0, 0.05).to_dict()
    assert set(ref) == set(cpp)
    assert set(ref["obstacles"][0]) == set(cpp["obstacles"][0])
    assert len(ref["obstacles"]) == len(cpp["obstacles"])
    np.testing.assert_allclose([o["centroid"] for o in ref["obstacles"]], [o["centroid"] for o in cpp["obstacles"]],
                               atol=2e-3)
