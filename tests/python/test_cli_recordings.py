"""`roadpreview run` and `roadpreview info` on pcap recordings, as a user runs them."""

import json
import re

import numpy as np
import pytest

import roadpreview as rp
from paths import KITTI_FRAMES, OS1_128_HEIGHT, OS1_128_META, OS1_128_PCAP, OUSTER, VELODYNE
from pcaps import records
from test_cli import lines, one_line_error, run

OS1 = ("--sensor-height", OS1_128_HEIGHT)


def test_run_on_the_os1_128_recording_uses_its_imu_yaw_rate(tmp_path):
    proc = run("run", OS1_128_PCAP, "--speed", 2.5, *OS1)
    out = lines(proc.stdout)
    assert len(out) == 3
    frames = list(rp.io.open(OS1_128_PCAP))
    assert [o["timestamp"] for o in out] == [f.timestamp for f in frames]
    assert [o["points"]["input"] for o in out] == [107647, 107357, 107532]
    for o, f in zip(out, frames):
        assert o["path"]["yaw_rate_source"] == "imu"
        assert o["motion"]["yaw_rate"] == pytest.approx(rp.io.imu_yaw_rate(f, rp.Config(sensor_height=OS1_128_HEIGHT)))
        assert o["ground"]["plane"] is not None and o["source"] == str(OS1_128_PCAP)
    err = proc.stderr.splitlines()
    assert "OS-1-128" in err[0] and "RNG15_RFL8_NIR8" in err[0] and "7502 (metadata)" in err[0]
    assert "#1795" in err[1] and "3 frame(s)" in err[-1]


def test_cli_line_equals_python_for_a_pcap_frame():
    line = lines(run("run", OS1_128_PCAP, "--speed", 2.5, "--yaw-rate", 0.1, "--frames", "1:2", "-q", *OS1).stdout)
    assert len(line) == 1
    frame = list(rp.io.open(OS1_128_PCAP))[1]
    res = rp.Estimator(rp.Config(sensor_height=OS1_128_HEIGHT)).process(
        frame.points, 2.5, 0.1, source=frame.source, timestamp=frame.timestamp, yaw_rate_source="option")
    expected = res.to_dict()
    for d in (line[0], expected):
        d.pop("timing_ms")
    assert line[0] == expected and expected["path"]["yaw_rate_source"] == "option"


def test_frames_range_selects_frames_by_index():
    all_ts = [o["timestamp"] for o in lines(run("run", OS1_128_PCAP, "--speed", 2.5, "-q", *OS1).stdout)]
    assert [o["timestamp"] for o in lines(run("run", OS1_128_PCAP, "--speed", 2.5, "--frames", "1:", "-q").stdout)] == all_ts[1:]
    assert [o["timestamp"] for o in lines(run("run", OS1_128_PCAP, "--speed", 2.5, "--frames", ":1", "-q").stdout)] == all_ts[:1]
    one_line_error(run("run", OS1_128_PCAP, "--speed", 2.5, "--frames", "5:9", "-q", check=False), "no frames from index 5")
    one_line_error(run("run", OS1_128_PCAP, "--speed", 2.5, "--frames", "2:1", "-q", check=False), "--frames")


def test_motion_file_is_interpolated_at_each_frame_time(tmp_path):
    t = [f.timestamp for f in rp.io.open(OS1_128_PCAP)]
    csv = tmp_path / "motion.csv"
    csv.write_text(f"t,speed,yaw_rate\n{t[0] - 1},1.0,0.0\n{t[0] + 1},3.0,0.2\n")
    out = lines(run("run", OS1_128_PCAP, "--motion", csv, "-q", *OS1).stdout)
    for o, ti in zip(out, t):
        w = (ti - (t[0] - 1)) / 2
        assert o["motion"]["speed"] == pytest.approx(1.0 + 2.0 * w)
        assert o["motion"]["yaw_rate"] == pytest.approx(0.2 * w)
        assert o["path"]["yaw_rate_source"] == "motion"
    short = tmp_path / "short.csv"
    short.write_text(f"t,speed,yaw_rate\n{t[0]},1,0\n{t[0] + 0.05},1,0\n")
    one_line_error(run("run", OS1_128_PCAP, "--motion", short, "-q", check=False), "short.csv", "outside")
    proc = run("run", OS1_128_PCAP, "--motion", csv, "--speed", 3, check=False)
    assert proc.returncode != 0 and "excludes" in proc.stderr


def test_info_describes_the_recording():
    out = run("info", OS1_128_PCAP).stdout
    for expected in ("sensor model: OS-1-128", "packet profile: RNG15_RFL8_NIR8", "frames: 3 (3 complete)",
                     "lidar UDP port: 7502 (metadata)", "duration: 0.300 s", "IMU samples: 30",
                     f"metadata: {OS1_128_META}"):
        assert expected in out, out
    out = run("info", VELODYNE / "velodyne_vlp16.pcap").stdout
    assert "sensor model: VLP-16" in out and "packet profile: strongest" in out and "decoded as VLP-16" in out
    out = run("info", VELODYNE / "velodyne_vlp16.pcap", "--sensor-model", "HDL-32E").stdout
    assert "sensor model: HDL-32E" in out


def test_a_capture_cut_within_a_frame_loses_no_packets():
    # This capture holds 8 packets (128 columns) of one frame: the other 896 columns were never sent to it.
    pcap = OUSTER / "OS-1-128_767798045_1024x10_20230712_120049.pcap"
    assert "missing columns: 896 (896 where the capture began or ended within a frame)" in run("info", pcap).stdout
    line = run("run", pcap, "--speed", 2, "--sensor-height", 1.9).stderr
    assert "896 columns missing (896 where the input began or ended within the frame)" in line
    assert "packets lost" not in line
    frame = next(iter(rp.io.open(pcap)))
    assert frame.diagnostics["cut_columns"] == 896 and frame.diagnostics["lost_packets"] == 0


@pytest.mark.parametrize("name", ["velodyne_example", "velodyne_vlp16", "velodyne_vlp32", "hdl32_example"])
def test_info_gives_a_velodyne_capture_its_whole_duration(name):
    # A Velodyne pcap tells no rotation rate: the last frame counts to its last point, not to its first (which gave
    # 0.032 s for a capture of 0.110 s). Within the last packet's own 1.3 ms of the capture's first to last record.
    recs = records(VELODYNE / f"{name}.pcap")
    duration = float(re.search(r"duration: ([0-9.]+) s", run("info", VELODYNE / f"{name}.pcap").stdout).group(1))
    assert duration == pytest.approx(recs[-1][0] - recs[0][0], abs=0.002)


def test_an_obstacle_across_both_paths_at_the_regions_start_is_noted(tmp_path):
    # The capture's roof sensor sees the vehicle's bonnet 1.0-2.1 m ahead: the run says how to start the region past
    # it, and with the region from 2.2 m only the obstacle 15.4 m ahead is left (README, "Obstacles").
    pcap = OUSTER / "OS-0-128-U1_v2.3.0_1024x10.pcap"
    note = "stands in both wheels' paths from the start of the region of interest (1.00 m ahead)"
    assert run("run", pcap, "--speed", 5, "-q").stderr.count(note) == 1
    config = tmp_path / "past_the_bonnet.yaml"
    config.write_text("ground:\n  roi_x_min_m: 2.2\n")
    proc = run("run", pcap, "--speed", 5, "--config", config, "-q")
    assert "region of interest" not in proc.stderr
    out = lines(proc.stdout)[0]["profiles"]
    assert [round(o["s_start"]) for w in ("left", "right") for o in out[w]["obstacles"]] == [15, 15]


def test_a_ground_that_disagrees_with_the_estimated_mounting_is_noted():
    # The mounting comes from frame 0's ground; the capture's last frame, a part of a rotation, fits a ground 10.5°
    # off it. Before, only a given mounting was checked, and an estimate read off something else went unsaid.
    proc = run("run", VELODYNE / "hdl32_example.pcap", "--speed", 5, "-q")
    assert "#6: the fitted ground is 0.31 m below the base origin and tilted 10.5°: the sensor is about 2.49 m up, " \
           "not 2.17 m as estimated from the ground in " in proc.stderr and "hdl32_example.pcap #0; check" in proc.stderr
    assert "1 frame(s) fitted a ground that disagrees with the mounting" in proc.stderr
    assert [o["mounting"]["disagrees"] for o in lines(proc.stdout)] == [False] * 6 + [True]
    # The frame that gave the estimate can disagree with it too: the estimate fits all the points below the sensor,
    # the frame's ground only those of its region ahead (on this capture, whose "ground" is a wall, the two RANSAC
    # planes differ by 14°). The note said "an earlier frame's ground".
    proc = run("run", OUSTER / "OS-1-64_1024x10_fw20.pcap", "--meta", OUSTER / "OS-1-64_sensor_config_reduced.json",
               "--speed", 2.5, "--ground", "ransac", "-q")
    assert "#189: the fitted ground is 0.63 m above the base origin and tilted 14.1°: the sensor is about 0.20 m up, " \
           "not 0.83 m as estimated from all of this frame's points below the sensor" in proc.stderr


def test_velodyne_run_and_legacy_ouster_with_meta():
    out = lines(run("run", VELODYNE / "hdl32_example.pcap", "--speed", 5, "--sensor-height", 1.8, "-q").stdout)
    assert len(out) == 7 and all(o["path"]["yaw_rate_source"] == "default" for o in out)
    out = lines(run("run", OUSTER / "OS-1-64_1024x10_fw20.pcap", "--meta", OUSTER / "OS-1-64_sensor_config_reduced.json",
                    "--speed", 5, "-q").stdout)
    assert [o["points"]["input"] for o in out] == [16749]


def test_pcap_errors_are_one_line_naming_the_file(tmp_path):
    lonely = tmp_path / "lonely.pcap"
    lonely.write_bytes(OS1_128_PCAP.read_bytes())
    one_line_error(run("run", lonely, "--speed", 2, check=False), "lonely.pcap", "--meta")
    cut = tmp_path / "cut.pcap"
    cut.write_bytes(OS1_128_PCAP.read_bytes()[:1_000_000])
    proc = run("run", cut, "--meta", OS1_128_META, "--speed", 2, check=False)
    assert proc.returncode != 0 and len(lines(proc.stdout)) == 1  # the frame before the cut is written
    assert "cut.pcap: record" in proc.stderr.splitlines()[-1] and "truncated" in proc.stderr.splitlines()[-1]
    bad_meta = tmp_path / "meta.json"
    meta = json.loads(OS1_128_META.read_text())
    meta["data_format"]["udp_profile_lidar"] = "RNG19_RFL8_SIG16_NIR16_DUAL"
    bad_meta.write_text(json.dumps(meta))
    one_line_error(run("run", OS1_128_PCAP, "--meta", bad_meta, "--speed", 2, "-q", check=False),
                   "OS-1-128_v2.3.0_1024x10_lb_n3.pcap", "meta.json", "does not match")
    one_line_error(run("run", OS1_128_PCAP, "--speed", 2, "--sensor-model", "HDL-64E", "-q", check=False),
                   "calibration")
    proc = run("run", OS1_128_PCAP, "-q", check=False)
    assert proc.returncode != 0 and "--motion" in proc.stderr


def test_pcap_results_are_finite_and_use_the_ground():
    out = lines(run("run", OUSTER / "OS-2-128-U1_v2.3.0_1024x10.pcap", "--speed", 5, "--sensor-height", 1.77, "-q").stdout)
    assert out[0]["points"]["ground"] > 1000
    z = np.array([v for v in out[0]["profiles"]["left"]["z"] if v is not None])
    assert len(z) > 20 and np.all(np.abs(z) < 1.0)


def test_roi_columns_give_the_whole_rotations_answers_from_the_columns_that_see_the_road():
    """--roi-columns decodes the OS1-128's columns 261–763 only; with the yaw rate given (the IMU samples a frame
    carries follow its end) every answer is the whole rotation's: the points of the region are the same."""
    args = ("run", OS1_128_PCAP, "--speed", 2.5, "--yaw-rate", 0.05, *OS1)
    whole, windowed = run(*args), run(*args, "--roi-columns")
    assert "columns 261–763 decoded, 503 of the 1024" in windowed.stderr
    got, want = lines(windowed.stdout), lines(whole.stdout)
    assert len(got) == len(want) == 3
    for g, w in zip(got, want):
        assert g["points"]["roi"] == w["points"]["roi"] and g["points"]["input"] < w["points"]["input"] / 2
        assert 0.02 < g["timestamp"] - w["timestamp"] < 0.03  # the frame begins at column 261, not 0
        for key in ("profiles", "roughness", "obstacles", "ground"):
            assert g[key] == w[key], key


def test_roi_columns_need_the_mounting_and_a_recording():
    one_line_error(run("run", OS1_128_PCAP, "--speed", 2.5, "--roi-columns", "-q", check=False), "--sensor-height")
    hdl32 = (VELODYNE / "hdl32_example.pcap", "--speed", 2.5, "--sensor-height", 1.8, "--roi-columns")
    one_line_error(run("run", *hdl32, "--cut-angle", 90, "-q", check=False), "--cut-angle", "--roi-columns")
    assert "sweeps end at 84.3°, where the region of interest has been scanned" in run("run", *hdl32).stderr
    one_line_error(run("run", KITTI_FRAMES[0], "--speed", 2.5, "--sensor-height", 1.73,
                       "--roi-columns", "-q", check=False), "000000.bin", "region of interest")


def test_open_with_roi_columns_keeps_the_region_of_every_frame():
    cfg = rp.Config(sensor_height=OS1_128_HEIGHT)
    source = rp.io.open(OS1_128_PCAP, roi_columns=cfg)
    assert any("columns 261–763 decoded" in n for n in source.info["notes"])
    windowed, whole = list(source), list(rp.io.open(OS1_128_PCAP))

    def in_region(points):
        x, y = points[:, 0], points[:, 1]  # sensor frame = base frame but for the height
        return points[(x >= 1) & (x <= 40) & (np.abs(y) <= 10)]

    for g, w in zip(windowed, whole):
        np.testing.assert_array_equal(in_region(g.points), in_region(w.points))
    behind = rp.io.open(OS1_128_PCAP, roi_columns=cfg, roi_direction="both")
    assert any("every column decoded" in n for n in behind.info["notes"])
    with pytest.raises(ValueError, match="roi_direction"):
        rp.io.open(OS1_128_PCAP, roi_columns=cfg, roi_direction="sideways")
    with pytest.raises(ValueError, match="mounting"):
        rp.io.open(OS1_128_PCAP, roi_columns=rp.Config())
    with pytest.raises(RuntimeError, match="000000.bin"):
        rp.io.open(KITTI_FRAMES[0], roi_columns=cfg)
    hdl32 = rp.io.open(VELODYNE / "hdl32_example.pcap", roi_columns=rp.Config(sensor_height=1.8))
    next(iter(hdl32))  # the model, hence the lasers, come with the first packets
    assert any("sweeps end at 84.3°" in n for n in hdl32.info["notes"])
