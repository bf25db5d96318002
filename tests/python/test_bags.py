# SPDX-License-Identifier: BSD-3-Clause
"""ROS bags and MCAP: PointCloud2 in any field layout (order, offsets, types, byte order, organised, row padding),
the Ouster packet bag through the library's decoder (counts from the data README), Odometry / Imu motion, and the
bad inputs a bag can bring."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rosbags")

from rosbags.rosbag1 import Writer as Writer1  # noqa: E402
from rosbags.rosbag2 import StoragePlugin, Writer as Writer2  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

import roadpreview as rp  # noqa: E402
from roadpreview import drive, io_bags  # noqa: E402
from paths import DATA, SHARED_DATA, cli  # noqa: E402

OUSTER_BAG = DATA / "rosbag" / "512x10_raw.bag"
SICK_BAG = SHARED_DATA / "laserscan2d" / "sick_scan_xd" / "rms_1xxx_lms_1xx_movement_off.bag"
TS = get_typestore(Stores.ROS2_HUMBLE)
M = TS.types
FLOAT32, FLOAT64, UINT16, INT32 = 7, 8, 4, 5
NUMPY = {FLOAT32: "f4", FLOAT64: "f8", UINT16: "u2", INT32: "i4"}


def header(t_s, frame="lidar"):
    return M["std_msgs/msg/Header"](stamp=M["builtin_interfaces/msg/Time"](sec=int(t_s), nanosec=int(t_s % 1 * 1e9)),
                                    frame_id=frame)


def vec(x=0.0, y=0.0, z=0.0):
    return M["geometry_msgs/msg/Vector3"](x=x, y=y, z=z)


def imu_msg(t_s, yaw_rate=0.0):
    q = M["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
    return M["sensor_msgs/msg/Imu"](header=header(t_s), orientation=q, orientation_covariance=np.zeros(9),
                                    angular_velocity=vec(z=yaw_rate), angular_velocity_covariance=np.zeros(9),
                                    linear_acceleration=vec(), linear_acceleration_covariance=np.zeros(9))


def odometry_msg(t_s, speed, yaw_rate):
    pose = M["geometry_msgs/msg/Pose"](position=M["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0),
                                       orientation=M["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0))
    twist = M["geometry_msgs/msg/Twist"](linear=vec(x=speed), angular=vec(z=yaw_rate))
    return M["nav_msgs/msg/Odometry"](header=header(t_s), child_frame_id="base_link",
                                      pose=M["geometry_msgs/msg/PoseWithCovariance"](pose=pose,
                                                                                      covariance=np.zeros(36)),
                                      twist=M["geometry_msgs/msg/TwistWithCovariance"](twist=twist,
                                                                                        covariance=np.zeros(36)))


def cloud(points, layout, *, t_s=1.0, big_endian=False, height=1, row_pad=0, step_pad=3):
    """A PointCloud2 of (N, 4) points with fields laid out as ``layout``: [(name, datatype)] in that order,
    ``step_pad`` spare bytes per point and ``row_pad`` spare bytes per row."""
    offsets, offset = {}, 0
    for name, kind in layout:
        offsets[name] = offset
        offset += np.dtype(NUMPY[kind]).itemsize
    step = offset + step_pad
    order = ">" if big_endian else "<"
    dtype = np.dtype({"names": [n for n, _ in layout], "formats": [order + NUMPY[k] for _, k in layout],
                      "offsets": [offsets[n] for n, _ in layout], "itemsize": step})
    arr = np.zeros(len(points), dtype=dtype)
    for k, name in enumerate("xyz"):
        if name in offsets:
            arr[name] = points[:, k]
    if "intensity" in offsets:
        arr["intensity"] = points[:, 3]
    width = len(points) // height
    rows = arr.view(np.uint8).reshape(height, width * step)
    data = np.concatenate([rows, np.zeros((height, row_pad), np.uint8)], axis=1).reshape(-1)
    fields = [M["sensor_msgs/msg/PointField"](name=n, offset=offsets[n], datatype=k, count=1) for n, k in layout]
    return M["sensor_msgs/msg/PointCloud2"](header=header(t_s), height=height, width=width, fields=fields,
                                            is_bigendian=big_endian, point_step=step, row_step=width * step + row_pad,
                                            data=data, is_dense=True)


def write_bag(path, messages, ros2=False):
    """messages: [(topic, msgtype, t_s, msg)], written as a ROS 1 bag or a ROS 2 bag with MCAP storage."""
    path = Path(path)
    writer = Writer2(path, version=9, storage_plugin=StoragePlugin.MCAP) if ros2 else Writer1(path)
    with writer:
        conns = {}
        for topic, msgtype, t_s, msg in messages:
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, msgtype, typestore=TS)
            data = TS.serialize_cdr(msg, msgtype) if ros2 else TS.serialize_ros1(msg, msgtype)
            writer.write(conns[topic], int(t_s * 1e9), data)
    return path


def some_points(n=60, seed=0):
    rng = np.random.default_rng(seed)
    pts = np.column_stack((rng.uniform(2, 30, n), rng.uniform(-5, 5, n), rng.uniform(-2, 0, n),
                           rng.integers(0, 256, n)))
    return np.round(pts, 3).astype(np.float32)


LAYOUTS = [
    [("x", FLOAT32), ("y", FLOAT32), ("z", FLOAT32), ("intensity", FLOAT32)],
    [("intensity", UINT16), ("z", FLOAT64), ("x", FLOAT64), ("y", FLOAT32)],  # any order, mixed types
    [("y", FLOAT32), ("x", FLOAT32), ("ring", UINT16), ("z", FLOAT32)],        # no intensity
]


@pytest.mark.parametrize("layout", range(len(LAYOUTS)))
@pytest.mark.parametrize("big_endian", [False, True])
@pytest.mark.parametrize("height,row_pad", [(1, 0), (4, 5)])
def test_pointcloud2_layouts_decode_to_the_same_points(tmp_path, layout, big_endian, height, row_pad):
    pts = some_points()
    msg = cloud(pts, LAYOUTS[layout], big_endian=big_endian, height=height, row_pad=row_pad)
    got = io_bags.cloud_points(msg)
    want = pts.copy()
    if not any(n == "intensity" for n, _ in LAYOUTS[layout]):
        want[:, 3] = 0
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-6)


@pytest.mark.parametrize("ros2", [False, True], ids=["ros1-bag", "ros2-mcap"])
def test_a_bag_streams_frames_with_header_stamps_and_runs_the_pipeline(tmp_path, ros2):
    path = tmp_path / ("drive" if ros2 else "drive.bag")
    frames = [cloud(some_points(500, k), LAYOUTS[1], t_s=100.0 + 0.1 * k) for k in range(3)]
    imu = imu_msg(100.0)
    write_bag(path, [("/points", "sensor_msgs/msg/PointCloud2", 100.0 + 0.1 * k + 0.01, f)
                     for k, f in enumerate(frames)] + [("/imu", "sensor_msgs/msg/Imu", 100.2, imu)], ros2=ros2)
    src = drive.open_source(path)
    assert src.info["topic"] == "/points"
    got = list(src)
    assert [f.timestamp for f in got] == pytest.approx([100.0, 100.1, 100.2])  # header stamps, not record times
    assert [f.points.shape for f in got] == [(500, 4)] * 3
    if ros2:  # the bag's .mcap file alone (no metadata.yaml) reads the same
        mcap = next(path.glob("*.mcap"))
        assert [f.timestamp for f in drive.open_source(mcap)] == pytest.approx([100.0, 100.1, 100.2])
    results = list(drive.run(path, rp.Config(sensor_height=1.8), motion=(5.0, 0.0)))
    assert [r.timestamp for r in results] == pytest.approx([100.0, 100.1, 100.2])


def test_the_ouster_packet_bag_decodes_through_the_library_decoder():
    src = drive.open_source(OUSTER_BAG)
    assert src.info["format"] == "ouster bag" and src.info["sensor_model"] == "OS-0-128"
    assert src.info["profile"] == "RNG15_RFL8_NIR8" and src.info["serial"] == "992108000265"
    frames = list(src)
    assert len(frames) == 1  # one complete frame, as the data README counts
    f = frames[0]
    assert f.frame_id == 1798 and f.diagnostics["missing_columns"] == 0 and f.diagnostics["complete"]
    assert f.points.shape == (28751, 4)  # pixels with range > 0 (data README)
    assert f.imu_angular_velocity.shape == (10, 3)  # the bag's 10 IMU packets
    ranges = np.linalg.norm(f.points[:, :3], axis=1)
    assert 0.1 < np.median(ranges) < 50


def test_the_ouster_bag_runs_with_its_imu_yaw_rate_and_declines_a_class_for_its_indoor_scene():
    """The bag is a bench capture (median range 0.6 m, 95 % within 2.6 m): no road to classify, and the output
    says so rather than inventing a class — and warns that its ground does not fit a vehicle's mounting."""
    with pytest.warns(RuntimeWarning, match="fitted ground is .* check --sensor-height"):
        (res,) = list(drive.run(OUSTER_BAG, rp.Config(sensor_height=0.6), motion=(2.0, None)))
    line = res.to_dict()
    assert line["path"]["yaw_rate_source"] == "imu"
    assert line["points"]["input"] == 28751 and line["points"]["ground"] > 300
    assert line["roughness"]["vehicle"]["class"] is None and line["roughness"]["vehicle"]["reason"]


def test_a_bag_run_on_the_command_line_speaks_as_every_run_does(tmp_path):
    """`roadpreview run BAG` (the Python side): warnings as one `roadpreview: warning:` line each (not Python's
    file:line warnings), a progress line per frame with its points, ground, clusters, classes and time, and the
    summary line with the classes and IRI. The bench capture's ground lies at the origin but 11.8° off level: no
    base frame, said once (before, it was "taken as base-frame points", then "not base-frame points")."""
    proc = subprocess.run([cli(), "run", str(OUSTER_BAG), "--speed", "2.5", "-o", str(tmp_path / "o.jsonl")],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    err = proc.stderr.splitlines()
    assert "RuntimeWarning" not in proc.stderr and "drives_cli.py" not in proc.stderr
    assert any(line.startswith("roadpreview: warning: ") and "lies at the cloud's origin but tilted 11.8°" in line
               for line in err), proc.stderr
    assert "taken as base-frame points\n" not in proc.stderr
    progress = [line for line in err if line.startswith("[1] ")]
    assert len(progress) == 1 and "512x10_raw.bag #0: 28751 points, " in progress[0], proc.stderr
    assert " clusters (L " in progress[0] and ", class L=- R=- vehicle=-" in progress[0]
    assert err[-1].startswith("roadpreview: 1 frame(s), pipeline median ") and "vehicle classes: -×1" in err[-1]


@pytest.mark.parametrize("command, missing", [("run", "rosbags"), ("batch", "distributed")])
def test_a_missing_optional_package_is_named_with_its_extra(command, missing, monkeypatch, capsys, tmp_path):
    """Without the [drives] extra a bag run or a batch ended in a 33-line traceback."""
    from roadpreview import drives_cli

    for name in [missing] + [m for m in sys.modules if m.startswith(missing + ".")]:  # imported by earlier tests too
        monkeypatch.setitem(sys.modules, name, None)  # `import name` now fails as if it were not installed
    args = [str(OUSTER_BAG), "--speed", "2.5"] + (["-o", str(tmp_path / "out")] if command == "batch" else [])
    assert drives_cli.main([command, *args]) == 1
    assert capsys.readouterr().err == (f"roadpreview: error: `{command}` needs the Python package '{missing}', "
                                       "which is not installed: pip install 'roadpreview[drives]'\n")


def test_a_two_dimensional_scan_made_a_cloud_is_noted(tmp_path):
    """A 2-D scanner's LaserScan made a PointCloud2 (every z = 0) holds no road heights: the run says so once
    (before, every point of it in the region was ground, silently)."""
    rng = np.random.default_rng(3)
    angle = np.linspace(-2.0, 2.0, 541)
    ranges = rng.uniform(1.0, 4.0, angle.size)
    pts = np.column_stack([ranges * np.cos(angle), ranges * np.sin(angle), np.zeros_like(angle),
                           np.zeros_like(angle)]).astype(np.float32)
    path = write_bag(tmp_path / "scan.bag", [("/cloud", "sensor_msgs/msg/PointCloud2", 10.0 + 0.02 * k,
                                              cloud(pts, LAYOUTS[0], t_s=10.0 + 0.02 * k)) for k in range(3)])
    proc = subprocess.run([cli(), "run", str(path), "--speed", "1", "-q", "-o", str(tmp_path / "o.jsonl")],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.count("every point has z = 0, as a 2-D scanner's scan made a point cloud has") == 1, proc.stderr


@pytest.mark.skipif(not SICK_BAG.exists(), reason="shared data not present")
def test_real_pointcloud2_topic_of_the_sick_bag():
    with pytest.raises(ValueError, match="several point-cloud topics.*--topic"):
        drive.open_source(SICK_BAG)
    frames = list(drive.open_source(SICK_BAG, topic="/cloud"))
    assert len(frames) == 89  # data README: 89 messages × 541 points
    assert all(len(f.points) <= 541 for f in frames) and max(len(f.points) for f in frames) > 500
    assert frames[-1].timestamp - frames[0].timestamp == pytest.approx(88 / 50.0, abs=0.05)  # 50 Hz
    assert np.abs(frames[0].points[:, :3]).max() < 4.0  # indoor: at most 3.82 m


def test_odometry_and_imu_topics_give_the_motion(tmp_path):
    odo = [odometry_msg(10.0 + k, 5.0 + k, 0.1 * k) for k in range(3)]
    path = write_bag(tmp_path / "odo.bag", [("/odom", "nav_msgs/msg/Odometry", 10.0 + k, m) for k, m in enumerate(odo)])
    table = io_bags.motion_table(path)
    assert table.at(10.5) == pytest.approx((5.5, 0.05))
    with pytest.raises(RuntimeError, match="outside the table's span"):
        table.at(13.0)
    imu = [imu_msg(10.0 + k, 0.2) for k in range(2)]
    path = write_bag(tmp_path / "imu.bag", [("/imu", "sensor_msgs/msg/Imu", 10.0 + k, m) for k, m in enumerate(imu)])
    with pytest.raises(ValueError, match="yaw rate only: give the speed"):
        io_bags.motion_table(path)
    assert io_bags.motion_table(path, speed_mps=3.0).at(10.5) == pytest.approx((3.0, 0.2))


def test_bad_bags_are_refused_naming_the_file_and_topic(tmp_path):
    imu = imu_msg(1.0)
    only_imu = write_bag(tmp_path / "imu_only.bag", [("/imu", "sensor_msgs/msg/Imu", 1.0, imu)])
    with pytest.raises(ValueError, match=r"imu_only.bag: no point clouds in this bag .*/imu"):
        drive.open_source(only_imu)
    pts = some_points()
    no_z = cloud(pts, [("x", FLOAT32), ("y", FLOAT32), ("intensity", FLOAT32)])
    path = write_bag(tmp_path / "no_z.bag", [("/points", "sensor_msgs/msg/PointCloud2", 1.0, no_z)])
    with pytest.raises(ValueError, match=r"no_z.bag: /points message 0: the PointCloud2 has no z field"):
        list(drive.open_source(path))
    with pytest.raises(ValueError, match=r"no_z.bag: no topic /lidar; the bag has /points"):
        drive.open_source(path, topic="/lidar")
    short = cloud(pts, LAYOUTS[0])
    short.data = short.data[:-7]  # a header that declares more than the message holds
    path = write_bag(tmp_path / "short.bag", [("/points", "sensor_msgs/msg/PointCloud2", 1.0, short)])
    with pytest.raises(ValueError, match="the data holds .* bytes, the header declares"):
        list(drive.open_source(path))
    with pytest.raises(ValueError, match="a bag cannot be mixed with other inputs"):
        drive.open_source([str(path), str(DATA / "semantickitti" / "000000.bin")])
    (tmp_path / "junk.bag").write_bytes(b"#ROSBAG V2.0\n" + b"\0" * 20)
    with pytest.raises(RuntimeError, match="junk.bag: not a readable ROS bag"):
        drive.open_source(tmp_path / "junk.bag")


def test_cli_info_of_a_bag_of_2d_scans_lists_it_and_says_where_scans_go(tmp_path):
    scan = M["sensor_msgs/msg/LaserScan"](header=header(1.0), angle_min=-1.0, angle_max=1.0, angle_increment=0.5,
                                          time_increment=0.0, scan_time=0.02, range_min=0.1, range_max=20.0,
                                          ranges=np.ones(5, np.float32), intensities=np.zeros(5, np.float32))
    path = write_bag(tmp_path / "scans.bag", [("/scan", "sensor_msgs/msg/LaserScan", 1.0, scan)])
    info = subprocess.run([cli(), "info", str(path)], capture_output=True, text=True, timeout=60)
    assert info.returncode == 0, info.stderr  # the listing is the answer (it was an error after it)
    assert "/scan\tsensor_msgs/msg/LaserScan\t1 messages" in info.stdout
    assert "note: " in info.stdout and "no point clouds in this bag" in info.stdout
    assert "2-D scans are read by `roadpreview roadside`" in info.stdout


def test_cli_info_and_run_of_a_bag(tmp_path):
    exe = str(Path(sys.executable).parent / "roadpreview")
    info = subprocess.run([exe, "info", str(OUSTER_BAG)], capture_output=True, text=True, timeout=60)
    assert info.returncode == 0, info.stderr
    assert "/os_node0/lidar_packets\touster_ros/msg/PacketMsg\t32 messages" in info.stdout
    assert "sensor model: OS-0-128\n" in info.stdout and "beams: 128\n" in info.stdout  # as `info` of a pcap
    run = subprocess.run([exe, "run", str(OUSTER_BAG), "--speed", "2", "--sensor-height", "1.9", "-q",
                          "-o", str(tmp_path / "o.jsonl")], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    (line,) = [json.loads(x) for x in (tmp_path / "o.jsonl").read_text().splitlines()]
    assert line["motion"]["speed"] == 2.0 and line["points"]["input"] == 28751
    bad = subprocess.run([exe, "run", str(OUSTER_BAG), "--speed", "2", "--topic", "/nope"], capture_output=True,
                         text=True, timeout=60)
    assert bad.returncode == 2 and "no topic /nope" in bad.stderr
