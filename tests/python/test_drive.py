# SPDX-License-Identifier: BSD-3-Clause
"""rp.drive.run: a recording frame by frame as `roadpreview run` processes it (same output lines), and its
motion table and poses inputs."""

import json

import pytest

import roadpreview as rp
from roadpreview import drive
from paths import KITTI_FRAMES, KITTI_SENSOR_HEIGHT, OS1_128_HEIGHT, OS1_128_PCAP, OUSTER, run_cli


def lines_without_timing(lines):
    """The lines without what differs from run to run: the stage timings and the fusion's time."""
    out = []
    for line in lines:
        line = {k: v for k, v in line.items() if k != "timing_ms"}
        if line.get("fusion"):
            line["fusion"] = {k: v for k, v in line["fusion"].items() if k != "time_ms"}
        out.append(line)
    return out


def cli_lines(tmp_path, *args):
    run_cli("run", *args, "-q", "-o", tmp_path / "cli.jsonl")
    return lines_without_timing(json.loads(x) for x in (tmp_path / "cli.jsonl").read_text().splitlines())


def test_a_pcap_with_imu_yaw_rate_gives_the_cli_lines(tmp_path):
    cli = cli_lines(tmp_path, OS1_128_PCAP, "--sensor-height", OS1_128_HEIGHT, "--speed", 2.5)
    mine = [r.to_dict() for r in drive.run(OS1_128_PCAP, rp.Config(sensor_height=OS1_128_HEIGHT), motion=(2.5, None))]
    assert lines_without_timing(mine) == cli


def test_frame_files_with_a_frame_rate_motion_table_poses_and_fusion_give_the_cli_lines(tmp_path):
    frames = [p for p in KITTI_FRAMES if p.name.startswith("0000")]
    motion = tmp_path / "motion.csv"
    motion.write_text("t,speed,yaw_rate\n0,8.0,0.01\n1,9.0,0.03\n")
    poses = tmp_path / "poses.txt"
    poses.write_text("".join(f"1 0 0 {0.86 * k} 0 1 0 0 0 0 1 0\n" for k in range(3)))
    cli = cli_lines(tmp_path, *frames, "--sensor-height", KITTI_SENSOR_HEIGHT, "--motion", motion, "--frame-rate", 10,
                    "--fusion", "ema", "--poses", poses, "--frames", "1:")
    cfg = rp.Config(sensor_height=KITTI_SENSOR_HEIGHT, fusion={"method": "ema", "frame_rate_hz": 10.0})
    mine = [r.to_dict() for r in drive.run([str(f) for f in frames], cfg, motion=str(motion), poses=str(poses),
                                           frames=(1, None), frame_rate=10.0)]
    assert lines_without_timing(mine) == cli
    assert [x["motion"]["speed"] for x in cli] == pytest.approx([8.1, 8.2])


def test_bad_motion_and_poses_are_refused_naming_the_file(tmp_path):
    bad = tmp_path / "m.csv"
    bad.write_text("time,v\n0,1\n")
    with pytest.raises(RuntimeError, match="m.csv: the motion table needs the header t,speed,yaw_rate"):
        drive.MotionTable.read_csv(bad)
    bad.write_text("t,speed,yaw_rate\n1,5,0\n0,5,0\n")
    with pytest.raises(RuntimeError, match="m.csv: the motion table's times must increase"):
        drive.MotionTable.read_csv(bad)
    poses = tmp_path / "p.txt"
    poses.write_text("1 0 0 0 0 1 0 0 0 0 1\n")
    with pytest.raises(RuntimeError, match="p.txt:1: a pose needs 12 finite numbers"):
        drive.read_kitti_poses(poses)
    # What no drive has, refused where it is read rather than by the estimator frames later: a speed in km/h for
    # m/s, a pose in millimetres (the fused map's cell indices would not hold it).
    bad.write_text("t,speed,yaw_rate\n0,5,0\n0.1,5000,0\n")
    with pytest.raises(RuntimeError, match="m.csv:3: speed must be within ±1000 m/s"):
        drive.MotionTable.read_csv(bad)
    poses.write_text("1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 2e8 0 1 0 0 0 0 1 0\n")
    with pytest.raises(RuntimeError, match=r"p.txt:2: pose \(2e\+08 m, 0 m, 0 rad\) must be finite and within"):
        drive.read_kitti_poses(poses)
    with pytest.raises(ValueError, match="give the vehicle's motion"):
        next(drive.run(OS1_128_PCAP))
    with pytest.raises(ValueError, match=r"000000.bin: pose \(1e\+300 m, 0 m, 0 rad\) must be finite"):  # in memory
        next(drive.run(KITTI_FRAMES[:1], rp.Config(sensor_height=KITTI_SENSOR_HEIGHT, fusion={"method": "kalman"}),
                       motion=(5.0, 0.0), poses=[(1e300, 0.0, 0.0)]))
    with pytest.raises(RuntimeError, match="no pose for frame 1"):
        list(drive.run(OS1_128_PCAP, rp.Config(sensor_height=1.97), motion=(2.5, 0.0),
                       poses=[(0.0, 0.0, 0.0)]))
    with pytest.raises(ValueError, match="--topic applies to ROS bags and MCAP files only"):
        drive.open_source(OUSTER / "OS-1-128_v2.3.0_1024x10_lb_n3.pcap", topic="/points")
