# SPDX-License-Identifier: BSD-3-Clause
"""rp.drive.run through the C++ DriveRunner from every source Python has: a ROS bag's frames fed from Python, and
motion tables and poses held in memory, give the output lines the CLI writes for the same frames as files."""

import json

import numpy as np
import pytest

pytest.importorskip("rosbags")

import roadpreview as rp  # noqa: E402
from roadpreview import drive  # noqa: E402
from paths import KITTI_FRAMES, OS1_128_HEIGHT, OS1_128_PCAP, VELODYNE, run_cli  # noqa: E402
from test_bags import FLOAT32, cloud, write_bag  # noqa: E402

FRAMES = [p for p in KITTI_FRAMES if p.name.startswith("0000")][:3]
# Whole seconds: the bag's header stamps and the files' index / frame rate are then the same doubles.
TIMES_S = [0.0, 1.0, 2.0]
MOTION = {"t": TIMES_S, "speed": [8.0, 8.5, 9.0], "yaw_rate": [0.0, 0.01, 0.02]}
POSES = [(0.0, 0.0, 0.0), (8.25, 0.0, 0.0), (16.5, 0.25, 0.0)]  # exact in a KITTI file's text too


def comparable(lines, keep_source=True):
    """The lines without what differs from run to run (the timings) and, across inputs, the file names."""
    out = []
    for line in lines:
        line = {k: v for k, v in line.items() if k != "timing_ms" and (keep_source or k != "source")}
        if line.get("fusion"):
            line["fusion"] = {k: v for k, v in line["fusion"].items() if k != "time_ms"}
        out.append(line)
    return out


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("drive_sources")
    layout = [("x", FLOAT32), ("y", FLOAT32), ("z", FLOAT32), ("intensity", FLOAT32)]
    messages = [("/points", "sensor_msgs/msg/PointCloud2", t, cloud(np.fromfile(f, np.float32).reshape(-1, 4),
                                                                    layout, t_s=t))
                for f, t in zip(FRAMES, TIMES_S)]
    bag = write_bag(tmp / "kitti.bag", messages)
    motion = tmp / "motion.csv"
    motion.write_text("t,speed,yaw_rate\n" + "".join(f"{t},{v},{w}\n" for t, v, w in zip(*MOTION.values())))
    poses = tmp / "poses.txt"
    poses.write_text("".join(f"1 0 0 {x} 0 1 0 {y} 0 0 1 0\n" for x, y, _ in POSES))
    run_cli("run", *FRAMES, "--motion", motion, "--poses", poses, "--frame-rate", 1, "--fusion", "ema", "-q",
            "-o", tmp / "cli.jsonl")
    cli = [json.loads(x) for x in (tmp / "cli.jsonl").read_text().splitlines()]
    return {"bag": bag, "motion": motion, "poses": poses, "cli": cli}


def config():
    """No mounting given: the runner estimates it from the first frame, as the CLI did."""
    return rp.Config(fusion={"method": "ema", "frame_rate_hz": 1.0})


def table():
    return drive.MotionTable.from_samples(MOTION["t"], MOTION["speed"], MOTION["yaw_rate"], "in memory")


def test_a_bag_with_motion_and_poses_in_memory_gives_the_cli_lines_of_its_frame_files(inputs):
    run = drive.run(inputs["bag"], config(), motion=table(), poses=POSES)
    mine = [r.to_dict() for r in run]
    assert len(mine) == 3
    assert comparable(mine, keep_source=False) == comparable(inputs["cli"], keep_source=False)
    assert {x["source"] for x in mine} == {str(inputs["bag"])}
    assert [x["fusion"]["pose"] for x in mine] == [list(p) for p in POSES]
    assert [x["path"]["yaw_rate_source"] for x in mine] == ["motion"] * 3
    assert any("mounting estimated" in note for note in run.notes)


def test_frame_files_with_motion_and_poses_in_memory_give_the_cli_lines(inputs):
    mine = [r.to_dict() for r in rp.run([str(f) for f in FRAMES], config(), motion=table(), poses=POSES,
                                        frame_rate=1.0)]
    assert comparable(mine) == comparable(inputs["cli"])
    by_file = [r.to_dict() for r in drive.run([str(f) for f in FRAMES], config(), motion=inputs["motion"],
                                              poses=inputs["poses"], frame_rate=1.0)]
    assert comparable(by_file) == comparable(inputs["cli"])


def test_a_bag_frame_range_and_in_memory_errors_name_what_is_wrong(inputs):
    (one,) = list(drive.run(inputs["bag"], config(), motion=table(), poses=POSES, frames=(1, 2)))
    assert one.timestamp == 1.0
    with pytest.raises(RuntimeError, match=r"in memory: frame time 0 s lies outside the table's span \[2, 3\] s"):
        list(drive.run(inputs["bag"], config(), motion=drive.MotionTable.from_samples([2.0, 3.0], [1, 1], [0, 0],
                                                                                       "in memory")))
    with pytest.raises(RuntimeError, match="odometry: the motion table's times must increase"):
        drive.MotionTable.from_samples([0.0, 0.0], [1.0, 1.0], [0.0, 0.0], "odometry")
    with pytest.raises(RuntimeError, match="poses: no pose for frame 2 \\(it has 2\\)"):
        list(drive.run(inputs["bag"], config(), motion=(8.0, 0.0), poses=POSES[:2]))
    with pytest.raises(ValueError, match="poses: pose 1 is not finite"):
        drive.run(inputs["bag"], config(), motion=(8.0, 0.0), poses=[(0, 0, 0), (np.nan, 0, 0)])


def test_frames_from_python_are_checked_like_arrays_given_to_the_estimator():
    class Frames:
        def __iter__(self):
            yield type("F", (), {"points": np.zeros((5, 2), np.float32), "source": "odd.bag"})()

    runner = rp._native.core().DriveRunner(Frames(), rp.Config(sensor_height=1.8).to_json(), speed_mps=1.0)
    with pytest.raises(ValueError, match="frame 0 of odd.bag: points needs at least 3 columns"):
        runner.next([])


@pytest.mark.parametrize("args", [
    [OS1_128_PCAP, "--sensor-height", OS1_128_HEIGHT, "--speed", 2.5],  # IRI with the errors' IRI
    [VELODYNE / "hdl32_example.pcap", "--speed", 5],                      # every class declined
])
def test_the_python_runs_summary_line_is_the_cli_ones(args):
    """Runs the Python package makes (bags, --motion-from lidar) end with the C++ run's summary line: its
    classes, IRI, the IRI of the bins' errors alone and every declined reason (the last two were missing)."""
    from roadpreview.drives_cli import _Summary

    proc = run_cli("run", *args, "--quiet")
    summary = _Summary()
    for line in proc.stdout.splitlines():
        summary.add(json.loads(line))
    (cli_line,) = [line for line in proc.stderr.splitlines() if " frame(s), pipeline median " in line]
    assert "declined classes" in cli_line or "errors alone" in cli_line  # the parts once missing are there to match
    assert f"roadpreview: {summary}" == cli_line
