"""Inputs that once crashed the process, ran it out of memory, hung it or passed as garbage: each now gets a clear
error naming the input (or a note), quickly. Every CLI run is bounded by run_cli's timeout."""

import json
import math
import os
import shutil
import threading

import numpy as np
import pytest

import roadpreview as rp
from paths import DATA, KITTI_FRAMES, KITTI_SENSOR_HEIGHT, OS1_128_META, OS1_128_PCAP, VELODYNE
from paths import run_cli as run

BILLION_LAUGHS = "a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n" + "".join(
    f"{chr(98 + k)}: &{chr(98 + k)} [{', '.join(['*' + chr(97 + k)] * 10)}]\n" for k in range(8))


def fails(*args, naming):
    """The CLI exits with an error whose last line holds `naming` (a fragment, or each of a list of them)."""
    proc = run(*args, check=False)
    assert proc.returncode != 0, proc.stdout[-300:]
    last = proc.stderr.strip().splitlines()[-1]
    for fragment in [naming] if isinstance(naming, str) else naming:
        assert fragment in last, last
    return last


def test_a_box_of_no_points_or_of_nan_points_is_an_error_not_a_crash():
    with pytest.raises(ValueError, match="no points"):
        rp.roadside.fit_l_shape(np.zeros((0, 2)))
    with pytest.raises(ValueError, match="must be finite: row 1"):
        rp.roadside.fit_l_shape(np.array([[0.0, 0.0], [math.nan, 1.0], [1.0, 1.0]]))
    with pytest.raises(ValueError, match="dilation must be >= 0"):
        rp.roadside.label_points(np.zeros((3, 2)), 0.2, -2)
    with pytest.raises(ValueError, match="cell must be a finite size > 0"):
        rp.roadside.label_points(np.zeros((3, 2)), 0.0, 1)


def test_an_estimator_used_by_two_threads_at_once_refuses_the_second():
    points = np.tile(rp.io.read(KITTI_FRAMES[0]), (8, 1))  # a million points: a call long enough to meet
    est = rp.Estimator(rp.Config(sensor_height=KITTI_SENSOR_HEIGHT))
    errors = []

    def busy():
        for _ in range(3):
            est.process(points, 5.0, 0.0)

    worker = threading.Thread(target=busy)
    worker.start()
    while worker.is_alive() and not errors:
        try:
            est.process(points[:1000], 5.0, 0.0)
        except RuntimeError as e:
            errors.append(str(e))
    worker.join()
    assert errors and "in use by another thread" in errors[0]
    assert est.process(points[:1000], 5.0, 0.0).points["input"] == 1000  # and it works again once free


def test_a_yaml_config_of_aliases_repeating_aliases_is_refused(tmp_path):
    bomb = tmp_path / "laughs.yaml"
    bomb.write_text(BILLION_LAUGHS + "profile: {beam_sigmas_deg: *i}\n")
    fails("run", KITTI_FRAMES[0], "--config", bomb, "--speed", 5, naming=["laughs.yaml", "more than 100000 values"])
    with pytest.raises(ValueError, match="laughs.yaml: not a config: more than 100000 values"):
        rp.Config.from_file(bomb)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
@pytest.mark.parametrize("option, what", [("--config", "config file"), ("--motion", "motion file"),
                                          ("--poses", "poses file")])
def test_a_directory_a_device_or_a_pipe_is_no_input_file(tmp_path, option, what):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)  # opened for reading, it would wait for a writer for ever
    base = ("run", KITTI_FRAMES[0], "--sensor-height", KITTI_SENSOR_HEIGHT, "--fusion", "kalman")
    motion = () if option == "--motion" else ("--speed", 5)
    for path, why in ((tmp_path, "a directory, not a file"), ("/dev/zero", "not a regular file"),
                      (fifo, "not a regular file")):
        fails(*base, *motion, option, path, naming=[str(path), f"cannot read the {what}: {why}"])


@pytest.mark.parametrize("rows", [2**31 - 1, -128])
def test_an_ouster_metadata_size_is_checked_before_anything_is_sized_by_it(tmp_path, rows):
    meta = tmp_path / "meta.json"
    meta.write_text(OS1_128_META.read_text().replace('"pixels_per_column": 128', f'"pixels_per_column": {rows}'))
    fails("info", OS1_128_PCAP, "--meta", meta, naming=["meta.json", f"pixels_per_column must be 1..512, got {rows}"])


@pytest.mark.parametrize("field, value, fragment", [
    ("lidar_to_sensor_transform", [0.0] * 16, "lidar_to_sensor_transform must be a rigid transform"),
    ("beam_altitude_angles", None, "beam_altitude_angles must lie within ±180°"),
])
def test_ouster_metadata_values_are_checked(tmp_path, field, value, fragment):
    meta = json.loads(OS1_128_META.read_text())  # the flat layout: fields at the top level
    meta[field] = value if value is not None else [1e300] * len(meta[field])
    path = tmp_path / "meta.json"
    path.write_text(json.dumps(meta))
    fails("info", OS1_128_PCAP, "--meta", path, naming=["meta.json", fragment])


def test_config_values_that_would_run_for_hours_or_place_the_sensor_nowhere_are_refused():
    with pytest.raises(ValueError, match=r"ground.pca_iterations must be in \[1, 100\]"):
        rp.Estimator(rp.Config(ground={"pca_iterations": 10**9}))
    with pytest.raises(ValueError, match="extrinsics: x, y and z must be within ±100 m"):
        rp.Estimator(rp.Config(extrinsics={"z_m": 1e6}))
    # Wheels beside the region roll where it holds no point: every class was declined, with no reason given.
    with pytest.raises(ValueError, match=r"the wheels \(track_width 100 m, tire_width 0.3 m\) must lie within"):
        rp.Estimator(rp.Config(track_width=100.0))
    est = rp.Estimator(rp.Config(sensor_height=KITTI_SENSOR_HEIGHT))
    points = rp.io.read(KITTI_FRAMES[0])
    with pytest.raises(ValueError, match="yaw_rate must be within ±100 rad/s"):
        est.process(points, 5.0, 1e30)
    with pytest.raises(ValueError, match=r"and ±10000 rad"):
        rp.Estimator(rp.Config(fusion={"method": "kalman"})).process(points, 5.0, 0.0, pose=(0.0, 0.0, 1e300))


@pytest.mark.parametrize("bad", [math.inf, math.nan, -1.0])
def test_a_range_variance_that_cannot_weigh_a_point_is_an_error_in_both_implementations(bad):
    points = rp.io.read(KITTI_FRAMES[0])
    variances = np.full(len(points), 1e-4, dtype=np.float32)
    variances[7] = bad
    cfg = rp.Config(sensor_height=KITTI_SENSOR_HEIGHT)
    with pytest.raises(ValueError, match="range variance of point 7 must be finite and >= 0"):
        rp.Estimator(cfg).process(points, 5.0, 0.0, range_variances=variances)
    with pytest.raises(ValueError, match="range variance of point 7 must be finite and >= 0"):
        rp.reference.process(points, 5.0, 0.0, cfg, range_variances=variances)


def test_cloud_files_whose_fields_or_words_would_be_read_wrong_are_errors(tmp_path):
    pcd = tmp_path / "twice.pcd"
    pcd.write_text("FIELDS x x y z\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\nWIDTH 1\nHEIGHT 1\nPOINTS 1\n"
                   "DATA ascii\n1 2 3 4\n")
    fails("run", pcd, "--speed", 5, naming=["twice.pcd", "a field named twice"])
    ply = tmp_path / "words.ply"
    ply.write_text("ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
                   "end_header\n1 2 3\na b c\n")
    fails("run", ply, "--speed", 5, naming=["words.ply", "'a' on data line 2 is not a number"])


@pytest.fixture()
def range_files(tmp_path):
    motion = tmp_path / "motion.csv"
    motion.write_text("t,speed,yaw_rate\n0,10,0\n10,10,0\n")
    readings = tmp_path / "readings.csv"
    readings.write_text("t,sensor,distance\n" + "".join(f"{0.001 * k:.3f},l,0.3\n" for k in range(1, 2000)))

    def layout(x_m=0.5):
        path = tmp_path / f"layout_{x_m}.yaml"
        path.write_text(f"sensors:\n  - {{id: l, kind: laser, wheel: left, x_m: {x_m}, y_m: 0.8, height_m: 0.3}}\n")
        return path

    return tmp_path, motion, readings, layout


def test_range_sensor_inputs_that_would_multiply_the_output_or_read_upside_down_are_errors(range_files):
    d, motion, readings, layout = range_files
    fails("range", "run", readings, "--sensors", layout(1e6), "--motion", motion,
          naming=["layout_1000000.0.yaml", "x_m and y_m must lie within ±20 m"])
    header_only = d / "header_only.csv"  # wrote nothing and said "0 windows", exit 0
    header_only.write_text("t,sensor,distance\n")
    fails("range", "run", header_only, "--sensors", layout(), "--speed", 10,
          naming=["header_only.csv: no window was written (0 readings)"])
    backwards = run("range", "run", readings, "--sensors", layout(), "--speed", -10, "-o", d / "back.jsonl")
    assert "samples fell behind the start of their window and were dropped" in backwards.stderr  # were dropped unsaid
    misspelt = d / "misspelt.yaml"  # pitch_degree: the sensor would have been read level
    misspelt.write_text("sensors:\n  - {id: l, kind: laser, wheel: left, x_m: 0.5, y_m: 0.8, height_m: 0.3, "
                        "pitch_degree: 20}\n")
    fails("range", "run", readings, "--sensors", misspelt, "--motion", motion,
          naming=["misspelt.yaml", "(sensor 'l'): unknown field 'pitch_degree'"])
    fails("range", "run", readings, "--sensors", layout(), "--motion", motion, "--frame-length-m", 1e7,
          naming="frame_length_m / ds_m must be at most 1000000 bins per window")
    cal = d / "upside_down.yaml"
    cal.write_text("distance: {a1: -1, a2: 0}\n")
    fails("range", "run", readings, "--sensors", layout(), "--motion", motion, "--calibration", cal,
          naming=["upside_down.yaml", "a1 must be a finite number of metres per count > 0, got -1"])
    with pytest.raises(ValueError, match="give no usable line"):
        rp.range_sensor.calibrate_distance(np.array([1.0, 2.0, 3.0]) * 1e300, [0.1, 0.2, 0.3])


def test_a_full_disk_is_an_error_not_a_success(tmp_path):
    if not os.path.exists("/dev/full"):
        pytest.skip("needs /dev/full")
    fails("run", KITTI_FRAMES[0], "--speed", 5, "--sensor-height", KITTI_SENSOR_HEIGHT, "--segments", 10,
          "--segments-csv", "/dev/full", "-o", tmp_path / "out.jsonl", naming="/dev/full: write failed")
    with pytest.raises(RuntimeError, match="/dev/full: write failed"):
        rp.range_sensor.calibrate_distance([1.0, 2.0, 3.0], [0.1, 0.2, 0.3], output="/dev/full")


def test_a_scan_row_cut_short_is_an_error_an_empty_range_no_return(tmp_path):
    site = tmp_path / "site.yaml"
    site.write_text("origin: {lat_deg: 0, lon_deg: 0}\nscanners: [{name: a, max_range_m: 30}]\n")
    scans = tmp_path / "scans.csv"
    scans.write_text("t,scanner,angle_deg,range_m\n0,0,0,5\n0,0,1,\n0,0,2\n")
    fails("roadside", "run", "--site", site, scans, naming=["scans.csv:4", "ends before its range_m column"])


def test_numbers_in_text_inputs_are_decimal_and_whole(tmp_path):
    # strtod took "0x10" as 16 m/s; the readers now take decimal notation only, whatever the locale.
    motion = tmp_path / "motion.csv"
    motion.write_text("t,speed,yaw_rate\n0,0x10,0\n1,16,0\n")
    fails("run", KITTI_FRAMES[0], "--motion", motion, "--frame-rate", 10, "--sensor-height", KITTI_SENSOR_HEIGHT,
          naming=["motion.csv:2", "expected a finite number"])
    site = tmp_path / "site.yaml"
    site.write_text("origin: {lat_deg: 0, lon_deg: 0}\nscanners: [{name: a, max_range_m: 30}]\n")
    scans = tmp_path / "scans.csv"
    scans.write_text("t,scanner,angle_deg,range_m\n0,0,0,5\n0,0,1,0x5\n")
    fails("roadside", "run", "--site", site, scans, naming=["scans.csv:3", "range_m"])


def test_beams_and_velodyne_calibration_files_are_checked(tmp_path):
    beams = tmp_path / "beams.yaml"
    beams.write_text("format: roadpreview beam calibration 1\nbeam_count: 1\nunits: {angles: rad, ranges: m}\n"
                     "beam_index: decoder\nbeams:\n  - {beam: 0, determined: true, elevation_offset_deg: 0.1}\n")
    fails("run", OS1_128_PCAP, "--speed", 5, "--beam-calibration", beams, naming=["beams.yaml", "units must be"])
    beams.write_text(beams.read_text().replace("rad", "deg").replace("0.1}", "1e300}"))
    fails("run", OS1_128_PCAP, "--speed", 5, "--beam-calibration", beams,
          naming=["beams.yaml", "elevation_offset_deg must lie within ±5°"])
    vlp = VELODYNE / "velodyne_vlp16.pcap"
    cal = tmp_path / "vlp.yaml"
    lasers = "".join(f"  - {{laser_id: {min(k, 14)}, vert_correction: 0.0}}\n" for k in range(16))
    cal.write_text("lasers:\n" + lasers)
    fails("run", vlp, "--speed", 5, "--sensor-model", "VLP-16", "--calibration", cal,
          naming=["vlp.yaml", "laser_id 14 listed twice"])


def test_a_replay_closes_its_captures_clock_jumps(tmp_path):
    from pcaps import records, write_pcap

    recs = records(VELODYNE / "velodyne_vlp16.pcap")
    recs[50] = (recs[50][0] + 3600.0, recs[50][1])  # one record an hour late: a clock set while capturing
    capture = write_pcap(tmp_path / "jump.pcap", recs)
    stats = rp.io.replay(capture, "127.0.0.1:17999")
    assert stats["sent"] == len(recs) and stats["clock_jumps"] == 2 and stats["seconds"] < 5
    proc = run("replay", capture, "--to", "127.0.0.1:17999")
    assert "its clock jumped by more than 5 s 2 time(s)" in proc.stderr


def test_points_taken_as_base_frame_points_whose_ground_is_far_off_are_noted(tmp_path):
    x, y = np.meshgrid(np.arange(1.0, 40.0, 0.2), np.arange(-5.0, 5.0, 0.2))
    sky = tmp_path / "ceiling.bin"  # a flat surface 10 m above the sensor, and no mounting given
    np.column_stack([x.ravel(), y.ravel(), np.full(x.size, 10.0), np.zeros(x.size)]).astype(np.float32).tofile(sky)
    proc = run("run", sky, "--speed", 5, "-q")
    assert "the fitted ground is 10.00 m above the base origin" in proc.stderr
    assert "the points are not base-frame points" in proc.stderr


def test_python_api_misuse_is_an_error_naming_the_argument(tmp_path):
    """The Python side's own checks (a second audit): each wrong argument is refused by name, not turned into
    garbage or a binding's "incompatible function arguments" listing the whole cloud."""
    est = rp.Estimator(rp.Config(sensor_height=KITTI_SENSOR_HEIGHT))
    points = rp.io.read(KITTI_FRAMES[0])
    with pytest.raises(TypeError, match="speed must be a number, got None"):
        est.process(points, None)
    with pytest.raises(TypeError, match="timestamp must be a number, got 'x'"):
        est.process(points, 5.0, timestamp="x")
    with pytest.raises(ValueError, match="yaw_rate_source must be one of option, motion, imu, default, got 'bogus'"):
        est.process(points, 5.0, yaw_rate_source="bogus")
    with pytest.raises(ValueError, match=r"world_profile: s and z must be 1-D and of one length"):
        rp.world_profile(np.arange(10.0), np.zeros(8), 0.0, np.arange(5.0))
    with pytest.raises(ValueError, match=r"no frames from index 10 on \(the input has 3\)"):
        list(rp.run(OS1_128_PCAP, rp.Config(sensor_height=1.97), speed=2.5, frames=(10, 20)))
    cfg = rp.Config()
    with pytest.raises(AttributeError, match="Config has no field 'sensor_hieght'; did you mean 'sensor_height'"):
        cfg.sensor_hieght = 2.0
    with pytest.raises(AttributeError, match="GroundConfig has no field"):
        cfg.ground.pca_treshold_m = 0.1
    bad = tmp_path / "bad.yaml"
    bad.write_text("sensor_height: 25\n")  # checked when read, naming the file (was: when an Estimator was made)
    with pytest.raises(ValueError, match=r"bad\.yaml: .*sensor_height"):
        rp.Config.from_file(bad)
    binary = tmp_path / "binary.json"
    binary.write_bytes(bytes(range(128, 256)))
    with pytest.raises(ValueError, match=r"binary\.json: not a config file: not UTF-8 text"):
        rp.Config.from_file(binary)


def test_stereo_roadside_and_simulator_misuse_is_an_error_naming_the_input(tmp_path):
    from roadpreview import sim

    calib = DATA / "stereo" / "kitti_object_calib.txt"
    # A KITTI disparity PNG read as an array holds disparity × 256: taken as px, every depth came out 256× short.
    with pytest.raises(ValueError, match="disparity: an array must hold float px, got uint16"):
        rp.io.stereo_points(None, None, calib, disparity=np.full((375, 1242), 40 * 256, np.uint16))
    with pytest.raises(FileNotFoundError, match=r"nosuch\.yaml: no such site file"):
        rp.roadside.Processor(tmp_path / "nosuch.yaml")
    with pytest.raises(ValueError, match="assign: the cost matrix must be rectangular"):
        rp.roadside.assign([[5, 5, 5], [0]], 10)
    for bad in (dict(speed_mps=math.nan), dict(speed_mps=5.0, frames=-1)):
        with pytest.raises(ValueError, match=r"drive: (speed_mps must be a finite number|frames must be a whole)"):
            sim.drive(sim.Scene(sim.Road.iso8608("A", seed=1)), sim.vlp_16(), **bad)
    with pytest.raises(ValueError, match=r"VLP-16: need 0 < height_m < 100 \(above the ground\), got -1.8"):
        sim.vlp_16(height_m=-1.8)
    with pytest.raises(ValueError, match=r"need 0 <= dropout < 1, got 1.0"):
        sim.os1_128(dropout=1.0)


@pytest.mark.parametrize("profile", [{"ds_m": 40.0}, {"ds_m": 20.0, "preview_length_m": 20.0}])
def test_a_stretch_of_one_bin_is_too_short_not_an_error(profile):
    """A bin as long as roughness.min_length_m: the C++ core raised "displacement_psd needs at least 2 samples"
    (the CLI stopped the run); the reference declined it. Both decline it now."""
    cfg = rp.Config(sensor_height=KITTI_SENSOR_HEIGHT, profile=profile)
    points = rp.io.read(KITTI_FRAMES[0])
    for res in (rp.Estimator(cfg).process(points, 5.0, 0.0), rp.reference.process(points, 5.0, 0.0, cfg)):
        assert res.left.roughness.iso_class is None
        assert res.left.roughness.reason == "valid stretch too short"


def test_a_profile_of_forty_thousand_bins_costs_no_quadratic_memory():
    """A legal ds_m of 1 mm: the Estimator planned an FFT for every length up to 40,000 bins — 12.9 GB and 28 s
    before the first frame (bad_alloc under a 4 GB limit). Lengths beyond 1,024 bins are planned as they come:
    the Estimator adds 11 MB to a fresh process's peak memory."""
    import subprocess
    import sys

    grown = subprocess.run([sys.executable, "-c", (
        "import resource, roadpreview as rp\n"
        "before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss\n"
        f"rp.Estimator(rp.Config(sensor_height={KITTI_SENSOR_HEIGHT}, profile={{'ds_m': 0.001}}))\n"
        "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before)")],
        capture_output=True, text=True, check=True, timeout=120).stdout
    assert int(grown) < 100 * 1024  # kB
    cfg = rp.Config(sensor_height=KITTI_SENSOR_HEIGHT, profile={"ds_m": 0.001})
    res = rp.Estimator(cfg).process(rp.io.read(KITTI_FRAMES[0]), 5.0, 0.0)
    assert len(res.left.z) == 40_000
    assert res.left.roughness.iso_class is not None or res.left.roughness.reason


# --- the numpy boundary: what a cast would have turned into other numbers ---------------------------------------

def test_stereo_points_without_images_or_disparity_is_an_error(tmp_path):
    """Neither images nor a disparity once matched an empty pair (undefined behaviour: an empty optional read)."""
    calib = DATA / "stereo" / "kitti_object_calib.txt"
    with pytest.raises(ValueError, match="give the left and right images, or a disparity"):
        rp.io.stereo_points(None, None, calib)
    with pytest.raises(ValueError, match="give both the left and the right image, or neither"):
        rp.io.stereo_points(None, np.zeros((375, 1242), np.uint8), calib, disparity=np.ones((375, 1242), np.float32))


def test_an_infinite_disparity_is_no_point():
    """+inf passed the 'd ≥ the far limit' test: a point at the camera's centre, stated exact (variance 0)."""
    d = np.full((375, 1242), 20.0, np.float32)
    d[300, 100] = np.inf
    found = rp.io.stereo_points(None, None, DATA / "stereo" / "kitti_object_calib.txt", disparity=d, config=rp.Config(sensor_height=1.65))
    assert 300 * 1242 + 100 not in set(found.pixels.tolist()) and 300 * 1242 + 101 in set(found.pixels.tolist())


@pytest.mark.parametrize("variances, error, message", [
    (np.full(5, 1 + 1j), TypeError, "range_variances must hold real numbers, got dtype complex128"),
    (np.ones(5, bool), TypeError, "range_variances must hold real numbers, got dtype bool"),
    (np.full(5, 1e308), ValueError, "range_variances must fit in float32, got 1e\\+308"),
], ids=["complex", "bool", "beyond float32"])
def test_range_variances_the_core_cannot_read_are_refused(variances, error, message):
    points = np.array([[5.0, 0.0, -1.7], [6, 0, -1.7], [7, 1, -1.7], [8, -1, -1.7], [9, 0, -1.7]], np.float32)
    with pytest.raises(error, match=message):
        rp.Estimator(rp.Config(sensor_height=1.7)).process(points, 5.0, 0.0, range_variances=variances)


def test_calibrate_beams_refuses_numbers_it_would_have_cast():
    """Int points read as a drive without ground; beam numbers beyond int32 wrapped into other beams; NaN motion
    read as 'too few beams on the ground'; (x, y) poses gave pybind's generic error."""
    points = rp.io.read(KITTI_FRAMES[0])
    beams = np.arange(len(points)) % 64
    with pytest.raises(TypeError, match="frame 0's points must be float32 or float64, got int64"):
        rp.calibrate_beams([(points.astype(np.int64), beams)], speed=5.0)
    with pytest.raises(ValueError, match="frame 0's beams must fit in int32"):
        rp.calibrate_beams([(points, beams + 2**33)], speed=5.0)
    with pytest.raises(TypeError, match="frame 0's beams must be one integer per point"):
        rp.calibrate_beams([(points, beams + 0.5)], speed=5.0)
    with pytest.raises(ValueError, match="speed must be finite, got nan"):
        rp.calibrate_beams([(points, beams)] * 2, speed=math.nan)
    with pytest.raises(ValueError, match=r"pose 1 must be three finite numbers \(x, y, yaw\)"):
        rp.calibrate_beams([(points, beams)] * 2, poses=[(0.0, 0.0, 0.0), (1.0, 0.0)])


def test_stage_functions_refuse_what_a_cast_would_change():
    """rp.native's stage functions cast: label −0.5 joined cluster 0, a count of 2⁴⁰ wrapped, a mask of 0.5 was
    True and an (N, 1) mask a mask of N; a zero plane 'levelled' every point to z = 0; ds = 0 gave NaN spectra."""
    base = np.array([[5.0, 0.0, 0.5], [5.1, 0.0, 0.5], [9.0, 1.0, 0.0]])
    plane = [0.0, 0.0, 1.0, 0.0]
    with pytest.raises(TypeError, match="ground_mask must be a bool array, got dtype float64"):
        rp.native.find_obstacles(base, np.array([0.5, 0.0, 1.0]), plane)
    with pytest.raises(ValueError, match=r"ground_mask must be 1-D, got shape \(3, 1\)"):
        rp.native.find_obstacles(base, np.zeros((3, 1), bool), plane)
    z = np.cumsum(np.random.default_rng(0).normal(0, 0.003, 200))
    count, spread = np.full(200, 3, np.int64), np.full(200, 0.01)
    with pytest.raises(ValueError, match="count must fit in int32, got 1099511627779 at 0"):
        rp.native.analyze_roughness(z, 0.1, rp.Config(), count=count + 2**40, spread=spread)
    with pytest.raises(ValueError, match=r"count must be 1-D, got shape \(2, 100\)"):
        rp.native.noise_psd(count.reshape(2, 100), spread, 0.1)
    with pytest.raises(TypeError, match="count must be an array of integers, got dtype float64"):
        rp.native.resolved_fraction(count + 0.5, 0.1, np.array([0.1]))
    for plane in ([0.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.0], [0.0, 0.0, 2.0, 0.0]):  # NaN x, y; doubled z
        with pytest.raises(ValueError, match=r"plane must be \(a, b, c, d\) with a unit normal pointing up"):
            rp.native.level_points(base, plane)
    with pytest.raises(TypeError, match="spread must be an array of real numbers, got dtype <U3"):
        rp.native.analyze_roughness(z, 0.1, rp.Config(), count=count, spread="abc")  # once a segmentation fault
    with pytest.raises(ValueError, match=r"spread must be 1-D, got shape \(2, 100\)"):
        rp.native.noise_psd(count, spread.reshape(2, 100), 0.1)
    with pytest.raises(ValueError, match="count must fit in int32, got 18446744073709551615 at 0"):
        rp.native.noise_psd(np.full(200, 2**64 - 1, np.uint64), spread, 0.1)
    assert rp.native.resolved_fraction([], 0.1, np.array([0.1])).shape == (1,)  # an empty list is an empty count
    for name, call in {"displacement_psd": lambda ds: rp.native.displacement_psd(z, ds),
                       "roughness": lambda ds: rp.native.analyze_roughness(z, ds, rp.Config()),
                       "noise_psd": lambda ds: rp.native.noise_psd(count, spread, ds),
                       "resolved_fraction": lambda ds: rp.native.resolved_fraction(count, ds, np.array([0.1])),
                       "profile_iri": lambda ds: rp.native.profile_iri(z, ds)}.items():
        for ds in (0.0, -0.1, math.nan, math.inf):  # −0.1 gave negative spectra, 0 and NaN NaN ones
            with pytest.raises(ValueError, match=f"{name}: the bin spacing ds must be a finite length > 0 m"):
                call(ds)
    with pytest.raises(ValueError, match=r"count_left and spread_left and count_right and spread_right: give all"):
        rp.native.vehicle_roughness(z, z, 0.1, rp.Config(), count_left=count)
