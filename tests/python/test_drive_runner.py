"""rp.run (roadpreview.drive_runner): a recording through the C++ DriveRunner gives the CLI's output lines, frame for frame (docs/method.md,
"Drives"): motion from a table, the IMU or the options, the mounting from the first frame, frame ranges, poses."""

import json
import warnings

import pytest

import roadpreview as rp

from paths import KITTI_FRAMES, KITTI_SENSOR_HEIGHT, OS1_128_PCAP
from paths import run_cli as run


def cli_lines(*args):
    return [json.loads(line) for line in run("run", *args, "-q").stdout.splitlines()]


def same_lines(results, lines):
    got = [r.to_dict() for r in results]
    assert len(got) == len(lines) > 0
    for d in got + lines:  # times differ from run to run
        d.pop("timing_ms")
        if d.get("fusion"):
            d["fusion"].pop("time_ms")
    assert got == lines


def test_a_pcap_with_an_estimated_mounting_and_its_imu_gives_the_cli_lines():
    drive = rp.run(OS1_128_PCAP, speed=2.5)
    same_lines(drive, cli_lines(OS1_128_PCAP, "--speed", 2.5))
    assert any("mounting estimated" in note for note in drive.notes)
    assert drive.config.extrinsics is not None and drive.frames_read == 3


def test_files_with_a_motion_table_a_frame_rate_and_a_range_give_the_cli_lines(tmp_path):
    motion = tmp_path / "motion.csv"
    motion.write_text("t,speed,yaw_rate\n0.0,4.0,0.0\n1.0,6.0,0.2\n")
    cfg = rp.Config(sensor_height=KITTI_SENSOR_HEIGHT)
    results = list(rp.run(KITTI_FRAMES[:4], cfg, motion=motion, frame_rate=10, frames=(1, 3)))
    same_lines(results, cli_lines(*KITTI_FRAMES[:4], "--motion", motion, "--frame-rate", 10, "--frames", "1:3",
                                  "--sensor-height", KITTI_SENSOR_HEIGHT))
    assert [r.timestamp for r in results] == pytest.approx([0.1, 0.2])


def test_fused_with_poses_gives_the_cli_lines(tmp_path):
    poses = tmp_path / "poses.txt"
    poses.write_text("".join(f"1 0 0 {0.8 * i} 0 1 0 0 0 0 1 0\n" for i in range(3)))
    cfg = rp.Config(sensor_height=KITTI_SENSOR_HEIGHT)
    cfg.fusion.method = "kalman"
    results = list(rp.run(KITTI_FRAMES[:3], cfg, speed=8.0, yaw_rate=0.0, poses=poses))
    same_lines(results, cli_lines(*KITTI_FRAMES[:3], "--speed", 8, "--yaw-rate", 0, "--poses", poses,
                                  "--fusion", "kalman", "--sensor-height", KITTI_SENSOR_HEIGHT))
    assert [r.to_dict()["fusion"]["frames"] for r in results] == [1, 2, 3]


def test_a_source_from_rp_io_open_is_run_as_it_is():
    frames = rp.io.open(OS1_128_PCAP)
    drive = rp.run(frames, rp.Config(sensor_height=1.97), speed=2.5, frames=(0, 1))
    assert len(list(drive)) == 1 and drive.frame.source == str(OS1_128_PCAP)


def test_a_given_mounting_far_from_the_ground_warns_once():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        drive = rp.run(OS1_128_PCAP, rp.Config(sensor_height=1.0), speed=2.5)
        list(drive)
    messages = [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)]
    assert len(messages) == 1 and "the fitted ground is" in messages[0]
    assert drive.mounting_disagreements == 3


@pytest.mark.parametrize("kwargs, message", [
    ({}, "give the vehicle's motion"),
    ({"speed": 2.0, "poses": "poses.txt"}, "fusion"),
    ({"speed": float("nan")}, "speed must be finite"),
    ({"speed": 5000.0}, "speed must be within ±1000 m/s"),  # km/h for m/s, or a field mixed up
    ({"speed": 2.0, "frames": (2, 1)}, "frame range"),
])
def test_missing_or_contradicting_options_are_value_errors(kwargs, message, tmp_path):
    if "poses" in kwargs:
        kwargs["poses"] = tmp_path / "poses.txt"
        kwargs["poses"].write_text("1 0 0 0 0 1 0 0 0 0 1 0\n")
    with pytest.raises(ValueError, match=message):
        rp.run(KITTI_FRAMES[:1], **kwargs)


def test_a_motion_that_is_neither_a_file_nor_a_table_is_a_type_error_saying_what_is():
    """(speed, yaw rate), as rp.drive.run takes it, reached the C++ constructor: a TypeError listing its signature
    and the whole config as JSON."""
    with pytest.raises(TypeError, match=r"^motion must be a CSV path or an rp.drive.MotionTable, got tuple \(a "
                                        r"constant motion is speed= and yaw_rate=\)$"):
        rp.run(KITTI_FRAMES[:1], motion=(5.0, 0.0))


def test_a_missing_file_names_it():
    with pytest.raises(RuntimeError, match="no_such.pcap"):
        list(rp.run("no_such.pcap", speed=1.0))
