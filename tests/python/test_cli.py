"""The `roadpreview` command-line tool, run as a user would."""

import json

import pytest

import roadpreview as rp
from paths import KITTI_FRAMES, KITTI_SENSOR_HEIGHT, PCD_FILE
from paths import run_cli as run


def lines(text):
    return [json.loads(line) for line in text.splitlines()]


def test_version_and_help():
    assert run("--version").stdout.strip() == f"roadpreview {rp.__version__}"
    assert "--sensor-height" in run("run", "--help").stdout
    assert "batch" in run("--help").stdout  # the Python package's commands are named too


def test_directory_input_gives_one_line_per_frame_in_name_order():
    proc = run("run", KITTI_FRAMES[0].parent, "--speed", 5, "--sensor-height", KITTI_SENSOR_HEIGHT)
    out = lines(proc.stdout)
    assert [o["source"] for o in out] == [str(p) for p in KITTI_FRAMES]
    assert [o["frame"] for o in out] == list(range(len(KITTI_FRAMES)))
    # the note on the skipped .label files, progress, summary
    assert len(proc.stderr.strip().splitlines()) == len(KITTI_FRAMES) + 2
    assert "skipped" in proc.stderr.splitlines()[0]
    assert "frame(s)" in proc.stderr.splitlines()[-1]


def test_cli_line_equals_python_to_dict(tmp_path):
    out = tmp_path / "out.jsonl"
    run("run", KITTI_FRAMES[1], "--speed", 7, "--yaw-rate", -0.2, "--sensor-height", KITTI_SENSOR_HEIGHT,
        "--frame-rate", 10, "-o", out)
    line = lines(out.read_text())[0]
    res = rp.Estimator(rp.Config(sensor_height=KITTI_SENSOR_HEIGHT)).process(
        rp.io.read(KITTI_FRAMES[1]), 7.0, -0.2, source=str(KITTI_FRAMES[1]), timestamp=0.0, yaw_rate_source="option")
    expected = res.to_dict()
    for d in (line, expected):
        d.pop("timing_ms")
    assert line == expected


def test_threads_flag_gives_the_same_lines_and_rejects_zero():
    def without_timing(threads):
        out = lines(run("run", KITTI_FRAMES[0].parent, "--speed", 5, "--sensor-height", KITTI_SENSOR_HEIGHT,
                        "--threads", threads, "-q").stdout)
        return [{**line, "timing_ms": None} for line in out]

    assert without_timing(2) == without_timing(1)
    proc = run("run", KITTI_FRAMES[0], "--speed", 5, "--threads", 0, check=False)
    assert proc.returncode != 0 and "--threads" in proc.stderr


def test_flags_override_the_config_file(tmp_path):
    cfg = tmp_path / "cfg.json"
    cfg.write_text(json.dumps({"sensor_height": 1.0, "ground": {"method": "ransac"}, "track_width": 1.4}))
    out = lines(run("run", KITTI_FRAMES[0], "--speed", 5, "--yaw-rate", 0.5, "--config", cfg,
                    "--sensor-height", KITTI_SENSOR_HEIGHT, "--track-width", 1.8).stdout)[0]
    assert out["ground"]["method"] == "ransac"
    assert out["path"]["left_radius"] == pytest.approx(10.0 - 0.9)  # 1.8 m track from the flag


def test_yaml_config_file(tmp_path):
    cfg = tmp_path / "cfg.yaml"
    cfg.write_text(f"sensor_height: {KITTI_SENSOR_HEIGHT}\nground:\n  method: ransac\n")
    out = lines(run("run", KITTI_FRAMES[0], "--speed", 5, "--config", cfg, "-q").stdout)[0]
    assert out["ground"]["method"] == "ransac" and out["ground"]["plane"][3] == pytest.approx(0.0, abs=0.1)


def test_pcd_input():
    out = lines(run("run", PCD_FILE, "--speed", 3, "-q").stdout)[0]  # this cloud's origin is on the ground
    assert out["points"]["input"] == 240000  # organized 1875 × 128; no-return pixels are (0, 0, 0)
    assert 0 < out["points"]["ground"] < out["points"]["roi"] < 205898
    assert out["ground"]["plane"] is not None


def one_line_error(proc, *words):
    assert proc.returncode != 0
    err = proc.stderr.strip().splitlines()
    assert len(err) == 1, proc.stderr
    for w in words:
        assert w in err[0], err[0]


def test_bad_inputs_exit_non_zero_with_one_line_naming_the_file(tmp_path):
    one_line_error(run("run", tmp_path / "nope.bin", "--speed", 5, check=False), "nope.bin", "no such file")
    cut = tmp_path / "cut.bin"
    cut.write_bytes(b"\0" * 17)
    one_line_error(run("run", cut, "--speed", 5, "-q", check=False), "cut.bin", "multiple of 16")
    junk = tmp_path / "junk.pcd"
    junk.write_text("garbage\n")
    one_line_error(run("run", junk, "--speed", 5, "-q", check=False), "junk.pcd")
    bad_cfg = tmp_path / "bad.json"
    bad_cfg.write_text('{"tire_width": -1}')
    one_line_error(run("run", KITTI_FRAMES[0], "--speed", 5, "--config", bad_cfg, check=False), "bad.json",
                   "tire_width")


def test_missing_speed_and_bad_flags_are_usage_errors(tmp_path):
    # Exit 2 (README, "CLI"), before anything is read or written.
    proc = run("run", KITTI_FRAMES[0], check=False)
    assert proc.returncode == 2 and "give the vehicle's motion: --speed" in proc.stderr
    proc = run("run", KITTI_FRAMES[0], "--speed", 5, "--ground", "magic", check=False)
    assert proc.returncode == 2 and "magic" in proc.stderr
    proc = run("run", KITTI_FRAMES[0], "--speed", 5, "--sensor-height", 1, "--extrinsics", "0,0,1,0,0,0", check=False)
    assert proc.returncode == 2 and "excludes" in proc.stderr
    # The range the help states is the one checked: 0 is refused as the option's value, not later by the config.
    assert "(0, 1]" in run("run", "--help").stdout
    proc = run("run", KITTI_FRAMES[0], "--speed", 5, "--fusion", "ema", "--alpha", 0, check=False)
    assert proc.returncode == 2 and "--alpha: expected a number in (0, 1], got 0" in proc.stderr
    # An EMA weight without the EMA fusion did nothing, silently.
    proc = run("run", KITTI_FRAMES[0], "--speed", 5, "--alpha", 0.3, check=False)
    assert proc.returncode == 2 and "--alpha weighs the newest frame of the EMA fusion: give --fusion ema" in proc.stderr
    # Options the input cannot use were ignored: the stereo calibration with LiDAR frames, a decoder's with a pair.
    proc = run("run", KITTI_FRAMES[0], "--speed", 5, "--calib", "calib.txt", check=False)
    assert proc.returncode == 2 and "--calib is a stereo calibration: it goes with --stereo or --disparity" in proc.stderr
    proc = run("run", "--disparity", "d.png", "--calib", "calib.txt", "--meta", "m.json", "--speed", 5, check=False)
    assert proc.returncode == 2 and "--meta applies to LiDAR inputs; the input is stereo" in proc.stderr
    # A profile directory that cannot be one stops the run before it starts, not after the last frame.
    taken = tmp_path / "taken"
    taken.write_text("a file")
    out = tmp_path / "o.jsonl"
    proc = run("run", KITTI_FRAMES[0], "--speed", 5, "--export-profile", taken, "-o", out, check=False)
    assert proc.returncode == 2 and f"--export-profile {taken}: cannot be made a directory" in proc.stderr
    assert not out.exists()


def test_zero_speed_is_a_documented_result_not_an_error():
    out = lines(run("run", KITTI_FRAMES[0], "--speed", 0, "--sensor-height", KITTI_SENSOR_HEIGHT, "-q").stdout)[0]
    assert out["reason"] == "vehicle stopped" and out["profiles"]["left"]["z"] == []
