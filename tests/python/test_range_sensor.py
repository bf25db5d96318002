"""Point range sensors: calibration known answers and properties, C++ against the numpy reference, the simulator's
targets in miniature, the CLI and its errors on bad input."""

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import roadpreview as rp
from paths import DATA, run_cli
from roadpreview import sim
from roadpreview.reference import range_sensor as ref

A1, A2 = 343.2 / 2 / 1e6, 0.005


def write_drive(dir_, name, drive):
    (dir_ / f"{name}.csv").write_text(drive.readings_csv())
    (dir_ / f"{name}_motion.csv").write_text(drive.motion_csv())
    return dir_ / f"{name}.csv", dir_ / f"{name}_motion.csv"


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    """A laser on the bench track: layout, reference profile, runs at 0.2 and 1.0 m/s."""
    d = tmp_path_factory.mktemp("bench")
    sensor = sim.laser("laser_left", x_m=0.3, height_m=0.25, latency_s=0.008, rate_hz=200.0)
    (d / "sensors.yaml").write_text(sim.layout_yaml([sensor]))
    xz = sim.bench_reference()
    (d / "ref.csv").write_text("x,z\n" + "".join(f"{x:.4f},{z:.6f}\n" for x, z in xz))
    runs = [write_drive(d, f"run{i}", sim.drive_readings(sim.bench_road(), [sensor], v, 4.0, seed=i))
            for i, v in enumerate((0.2, 1.0))]
    return {"dir": d, "sensor": sensor, "reference": xz, "runs": runs}


# --- distance calibration ------------------------------------------------------------------------------------

def test_distance_calibration_exact_on_noise_free_data_in_both_implementations():
    c = np.arange(600.0, 4000.0, 50.0)
    d = A1 * c + A2
    for fit in (rp.range_sensor.calibrate_distance(c, d), ref.calibrate_distance(c, d)):
        assert fit["a1"] == pytest.approx(A1, rel=1e-10)
        assert fit["a2"] == pytest.approx(A2, abs=1e-10)
        assert fit["rejected"] == 0


def test_distance_calibration_rejects_outliers_like_the_reference():
    rng = np.random.default_rng(3)
    c = np.repeat(np.arange(800.0, 3600.0, 200.0), 10)
    d = A1 * c + A2 + rng.normal(0, 0.001, len(c))
    d[[5, 40, 77]] += [0.03, -0.05, 0.02]
    cpp, py = rp.range_sensor.calibrate_distance(c, d), ref.calibrate_distance(c, d)
    assert cpp["rejected"] == py["rejected"] >= 3
    assert cpp["a1"] == pytest.approx(py["a1"], rel=1e-9)
    assert cpp["a2"] == pytest.approx(py["a2"], abs=1e-9)
    assert cpp["rms_m"] == pytest.approx(py["rms_m"], rel=1e-6)


def test_simulated_bench_counts_meet_the_targets():
    us = sim.ultrasonic(a2=A2)
    rows = sim.bench_counts(us, np.linspace(0.15, 0.6, 10), repeats=20, seed=1)
    fit = rp.range_sensor.calibrate_distance(rows[:, 0], rows[:, 1])
    assert abs(fit["a1"] / us.a1 - 1) < 0.005
    assert abs(fit["a2"] - us.a2) < 0.001


@settings(max_examples=20, deadline=None)
@given(st.randoms(use_true_random=False))
def test_distance_calibration_invariant_to_reading_order(random):
    rng = np.random.default_rng(7)
    c = np.repeat(np.arange(900.0, 3000.0, 150.0), 5)
    d = A1 * c + A2 + rng.normal(0, 0.0008, len(c))
    order = list(range(len(c)))
    random.shuffle(order)
    a, b = rp.range_sensor.calibrate_distance(c, d), rp.range_sensor.calibrate_distance(c[order], d[order])
    assert a["a1"] == pytest.approx(b["a1"], rel=1e-12)
    assert a["a2"] == pytest.approx(b["a2"], abs=1e-12)
    assert a["rejected"] == b["rejected"]


# --- offset calibration --------------------------------------------------------------------------------------

def test_bench_offset_calibration_meets_the_targets_and_agrees_with_the_reference(bench):
    (r0, m0), (r1, m1) = bench["runs"]
    out = rp.range_sensor.calibrate_offset([r0, r1], [m0, m1], bench["dir"] / "sensors.yaml",
                                           reference=bench["reference"])["laser_left"]
    s = bench["sensor"]
    assert out["b1_s"] == pytest.approx(-s.latency_s, abs=0.002)
    assert out["b2_m"] == pytest.approx(s.foot_m, abs=0.005)
    # The reference's cross-correlation (numpy) against the C++ shifts of each run.
    runs = []
    for r, m in ((r0, m0), (r1, m1)):
        smp = rp.range_sensor.samples(r, bench["dir"] / "sensors.yaml", motion=m, raw=True)
        runs.append((smp["s"], smp["z"], smp["speed"].mean()))
    xz = bench["reference"]
    py = ref.calibrate_offset(runs, xz[:, 0], xz[:, 1], s.foot_m, 0.5)
    for run, shift in zip(out["runs"], py["shifts_m"]):
        assert run["xcorr_shift_m"] == pytest.approx(shift, abs=0.001)
        assert run["shift_m"] == pytest.approx(shift, abs=0.005)
    assert py["b2_m"] == pytest.approx(s.foot_m, abs=0.005)


def _exact_run(xz, v, shift):
    axle = np.arange(-0.5, 3.5, 0.004)
    return axle, np.interp(axle + shift, xz[:, 0], xz[:, 1]), v


@pytest.mark.parametrize("delta", [-0.15, -0.05, 0.05, 0.15])
def test_shifting_the_reference_moves_b2_by_the_same_amount(delta):
    xz = sim.bench_reference(step_m=0.002)
    runs = [_exact_run(xz, v, 0.45 - 0.01 * v) for v in (0.3, 1.0)]
    speeds = [v for _, _, v in runs]

    def b1_b2(profile, guess):
        shifts = [rp._native.core().range_register_run(x, z, profile[:, 0], profile[:, 1], guess, 0.1)["shift_m"]
                  for x, z, _ in runs]
        return np.polyfit(speeds, shifts, 1)

    b1, b2 = b1_b2(xz, 0.45)
    b1_moved, b2_moved = b1_b2(xz + [delta, 0.0], 0.45 + delta)
    assert b2_moved - b2 == pytest.approx(delta, abs=0.001)
    assert b1_moved == pytest.approx(b1, abs=0.002)


def test_a_single_speed_is_a_clear_error(bench, tmp_path):
    (r0, m0), _ = bench["runs"]
    proc = run_cli("range", "calibrate-offset", "--reference", bench["dir"] / "ref.csv", "--sensors",
                   bench["dir"] / "sensors.yaml", r0, r0, "--motion", m0, m0, "-o", tmp_path / "cal.yaml", check=False)
    assert proc.returncode != 0
    assert "two or more distinct speeds" in proc.stderr and "laser_left" in proc.stderr


def test_a_flat_reference_is_an_error_not_a_calibration(bench, tmp_path):
    """A reference without relief leaves each run's shift undetermined (σ infinite): b2 came out 0.3 m off and
    was written, exit 0."""
    (r0, m0), (r1, m1) = bench["runs"]
    (tmp_path / "flat.csv").write_text("x,z\n" + "".join(f"{x:.2f},0.0\n" for x in np.arange(-1.0, 4.0, 0.01)))
    proc = run_cli("range", "calibrate-offset", "--reference", tmp_path / "flat.csv", "--sensors",
                   bench["dir"] / "sensors.yaml", r0, r1, "--motion", m0, m1, "-o", tmp_path / "cal.yaml", check=False)
    assert proc.returncode != 0 and not (tmp_path / "cal.yaml").exists()
    assert f"{r0}: the reference profile is flat where the run's samples lie" in proc.stderr


@pytest.mark.parametrize("calibration, fragment", [
    ("sensors:\n  laser_left:\n    offset: {b1_s: -12, b2_m: 0.3}\n",
     "sensors.laser_left.offset: b1_s, the sensor's latency, must lie within ±1 s, got -12 (milliseconds given as "
     "seconds?)"),
    ("sensors:\n  laser_left:\n    offset: {b1_s: -0.012, b2_m: 0.3, b3_m: 1}\n",
     "sensors.laser_left.offset: unknown field 'b3_m'"),
    ("distance: {a1: 0.0002, a2: 0.005, temprature_c: 20}\n", "distance: unknown field 'temprature_c'"),
    ("sensors:\n  nobody:\n    offset: {b1_s: -0.012, b2_m: 0.3}\n",
     "the calibration names sensor 'nobody', which the layout does not hold"),
], ids=["latency in ms", "unknown offset field", "unknown distance field", "sensor of another layout"])
def test_a_calibration_file_that_cannot_be_meant_is_an_error(bench, tmp_path, calibration, fragment):
    """Each was taken silently: a sensor of another layout left the real ones on their geometric foot, a latency in
    milliseconds dropped every sample (blaming the motion), a misspelt field kept its default."""
    (tmp_path / "cal.yaml").write_text(calibration)
    readings, motion = bench["runs"][0]
    proc = run_cli("range", "run", readings, "--sensors", bench["dir"] / "sensors.yaml", "--calibration",
                   tmp_path / "cal.yaml", "--motion", motion, "-o", tmp_path / "out.jsonl", check=False)
    assert proc.returncode != 0 and fragment in proc.stderr, proc.stderr


def test_the_python_api_refuses_what_the_cli_refuses(bench):
    """A motion table with a speed beside it (the table won, silently) and a bench pair that is not a number (the
    pair was dropped, silently): the CLI refuses both."""
    readings, motion = bench["runs"][0]
    with pytest.raises(ValueError, match=r"^give the motion as a table \(motion=\) or a constant speed \(speed=\), "
                                         r"not both$"):
        rp.range_sensor.process(readings, bench["dir"] / "sensors.yaml", motion=motion, speed=25.0)
    with pytest.raises(ValueError, match=r"pair 1 is \(nan, 0.2\)"):
        rp.range_sensor.calibrate_distance([1000.0, np.nan, 3000.0], [0.1, 0.2, 0.3])


@pytest.mark.parametrize("search_m, reference, message", [
    (math.nan, None, r"the shift search must be in \(0, 100\] m, got nan m"),
    (-1.0, None, r"the shift search must be in \(0, 100\] m, got -1 m"),
    (1e308, None, r"the shift search must be in \(0, 100\] m, got 1e\+308 m"),
    (0.5, "far", r"the reference profile spans 1e\+308 m; at most 1000 m"),
    (0.5, "nan first", r"x and z be finite \(row 0\)"),
], ids=["nan search", "negative search", "huge search", "reference 1e308 m long", "first reference height nan"])
def test_offset_calibration_refuses_a_search_or_reference_it_cannot_use(bench, search_m, reference, message):
    """A NaN or 1e308 m search aborted the process inside PCL, a negative one asked for an impossible vector, a
    reference row 1e308 m away densified it without end (memory grew until killed), a NaN first height passed."""
    (r0, m0), (r1, m1) = bench["runs"]
    xz = bench["reference"].copy()
    if reference == "far":
        xz = np.vstack([xz, [1e308, 0.0]])
    elif reference == "nan first":
        xz[0, 1] = math.nan
    with pytest.raises(RuntimeError if reference else ValueError, match=message):  # a reference: per sensor and run
        rp.range_sensor.calibrate_offset([r0, r1], [m0, m1], bench["dir"] / "sensors.yaml", reference=xz,
                                         search_m=search_m)


def test_a_byte_order_mark_before_a_csv_header_is_no_part_of_it(bench, tmp_path):
    """A spreadsheet writes one before the first cell: the header "t,sensor,distance" was refused as not one."""
    readings, motion = bench["runs"][0]
    bom = "\ufeff"
    (tmp_path / "readings.csv").write_text(bom + readings.read_text(), encoding="utf-8")
    (tmp_path / "motion.csv").write_text(bom + motion.read_text(), encoding="utf-8")
    args = ["--sensors", bench["dir"] / "sensors.yaml", "--frame-length-m", 2]
    plain = run_cli("range", "run", readings, *args, "--motion", motion).stdout
    assert run_cli("range", "run", tmp_path / "readings.csv", *args, "--motion", tmp_path / "motion.csv").stdout == \
        plain.replace(str(readings), str(tmp_path / "readings.csv"))
    rows = sim.bench_counts(sim.ultrasonic(), np.linspace(0.15, 0.6, 8), repeats=2)
    (tmp_path / "bench.csv").write_text(bom + "count,distance\n" + "".join(f"{c:.0f},{d:.4f}\n" for c, d in rows),
                                        encoding="utf-8")
    run_cli("range", "calibrate-distance", tmp_path / "bench.csv", "-o", tmp_path / "cal.yaml")


# --- samples, windows, C++ against the reference -------------------------------------------------------------

def test_samples_and_bins_agree_with_the_reference(bench):
    r0, m0 = bench["runs"][0]
    layout = rp.range_sensor.read_layout(bench["dir"] / "sensors.yaml")
    smp = rp.range_sensor.samples(r0, bench["dir"] / "sensors.yaml", motion=m0)
    rows = np.genfromtxt(r0, delimiter=",", names=True, dtype=None, encoding="utf-8")
    py = ref.place(rows["t"], rows["distance"], layout[0], speed=0.2, distance_driven=0.2 * rows["t"])
    assert np.allclose(smp["s"], py["s"], atol=1e-9)
    assert np.allclose(smp["z"], py["z"], atol=1e-12)
    win = rp.range_sensor.process(r0, bench["dir"] / "sensors.yaml", motion=m0, frame_length_m=2.0)[0]
    binned = ref.bin_profile(py["s"], py["z"], 0.0, 2.0)
    left = win["profiles"]["left"]
    assert np.allclose(np.array(left["z"], float), binned["z"], atol=1e-12, equal_nan=True)
    assert left["count"] == binned["count"].tolist()


def test_laser_profile_class_and_iri_on_a_simulated_road(tmp_path):
    road = sim.Road.iso8608("C", seed=2)
    sensors = [sim.laser("l", "left", x_m=1.0), sim.laser("r", "right", x_m=1.0)]
    (tmp_path / "sensors.yaml").write_text(sim.layout_yaml(sensors))
    drive = sim.drive_readings(road, sensors, 10.0, 41.0, seed=0)
    readings, motion = write_drive(tmp_path, "drive", drive)
    cal = tmp_path / "cal.yaml"
    cal.write_text("sensors:\n" + "".join(f"  {s.id}:\n    offset: {{b1_s: {-s.latency_s}, b2_m: {s.foot_m}}}\n"
                                          for s in sensors))
    win = rp.range_sensor.process(readings, tmp_path / "sensors.yaml", calibration=cal, motion=motion)[0]
    left = win["profiles"]["left"]
    s = np.array(left["s"])
    z = np.array(left["z"], float)
    truth = road.height(s, np.full_like(s, 0.8))
    ok = np.isfinite(z)
    err = z[ok] - truth[ok]
    err -= np.polyval(np.polyfit(s[ok], err, 1), s[ok])
    assert np.sqrt(np.mean(err**2)) <= 0.003
    assert win["roughness"]["left"]["class"] in "BCD"
    true_iri = rp.reference.profile_iri(truth[ok], 0.1).value
    iri = win["roughness"]["left"]["iri"]
    assert iri["value"] == pytest.approx(true_iri, rel=0.10)
    assert iri["backed_fraction"] == 1.0 and 0 < iri["noise"] < 0.1 * iri["value"]  # 0.3 mm readings: little noise
    assert all(t == pytest.approx(1.0 / 10.0 - 0.001, abs=1e-9) for t in win["samples"]["time_to_wheel"][:5])


def test_sparse_readings_are_classed_over_the_band_their_spacing_resolves(tmp_path):
    """Lasers at 20 Hz at 10 m/s: a reading every 0.5 m, one per bin at most, so the noise is unknown and the plain
    fit is used — over the band the spacing resolves: interpolated between readings, the short waves vanish, and a
    fit up to 4 cycles/m once read this class C road as A (confidence 1.0), with an IRI from 20 % of the bins."""
    road = sim.Road.iso8608("C", seed=2)
    sensors = [sim.laser("l", "left", x_m=1.0, rate_hz=20.0), sim.laser("r", "right", x_m=1.0, rate_hz=20.0)]
    (tmp_path / "sensors.yaml").write_text(sim.layout_yaml(sensors))
    readings, motion = write_drive(tmp_path, "drive", sim.drive_readings(road, sensors, 10.0, 81.0, seed=0))
    cal = tmp_path / "cal.yaml"
    cal.write_text("sensors:\n" + "".join(f"  {s.id}:\n    offset: {{b1_s: {-s.latency_s}, b2_m: {s.foot_m}}}\n"
                                          for s in sensors))
    win = rp.range_sensor.process(readings, tmp_path / "sensors.yaml", calibration=cal, motion=motion)[0]
    for wheel in ("left", "right", "vehicle"):
        r = win["roughness"][wheel]
        assert r["class"] == "C", (wheel, r["class"], r["reason"])
        assert r["band_limit"] == "sampling" and r["band"][1] < 1.0  # readings 0.5 m apart: under 1 cycle/m
        assert 0.15 < r["backed_fraction"] < 0.25
        assert r["iri"]["value"] is None and r["iri"]["reason"] == "too few bins with points for IRI"
        assert r["iri"]["backed_fraction"] == pytest.approx(r["backed_fraction"], abs=0.01)


# --- CLI and bad input ---------------------------------------------------------------------------------------

def test_cli_calibrates_and_runs(bench, tmp_path):
    rows = sim.bench_counts(sim.ultrasonic(), np.linspace(0.15, 0.6, 8), repeats=5)
    (tmp_path / "bench.csv").write_text("count,distance\n" + "".join(f"{c:.0f},{d:.4f}\n" for c, d in rows))
    run_cli("range", "calibrate-distance", tmp_path / "bench.csv", "-o", tmp_path / "cal.yaml")
    assert "a1:" in (tmp_path / "cal.yaml").read_text()
    (r0, m0), (r1, m1) = bench["runs"]
    d = bench["dir"]
    run_cli("range", "calibrate-offset", "--reference", d / "ref.csv", "--sensors", d / "sensors.yaml",
            "--calibration", tmp_path / "cal.yaml", r0, r1, "--motion", m0, m1, "-o", tmp_path / "cal2.yaml")
    text = (tmp_path / "cal2.yaml").read_text()
    assert "b1_s:" in text and "a1:" in text
    proc = run_cli("range", "run", r1, "--sensors", d / "sensors.yaml", "--calibration", tmp_path / "cal2.yaml",
                   "--motion", m1, "--frame-length-m", 2, "-o", tmp_path / "out.jsonl")
    lines = [json.loads(x) for x in (tmp_path / "out.jsonl").read_text().splitlines()]
    assert lines and all(x["source"] == "range" for x in lines)
    assert set(lines[0]["profiles"]["left"]) >= {"s", "z", "count", "spread"}
    assert "readings/s" in proc.stderr


@pytest.mark.parametrize("body, fragment", [
    ("0.0,laser_left,0.25\n0.1,nobody,0.25\n", "unknown sensor id 'nobody'"),
    ("0.2,laser_left,0.25\n0.1,laser_left,0.25\n", "time goes backwards"),
    ("0.0,laser_left,0.25\n0.1,laser_left,nan\n", "not a finite number"),
    ("0.0,laser_left,0.25\n0.1,laser_left,-1\n", "outside the layout's range"),
    ("0.0,laser_left,0.25\n99.0,laser_left,0.25\n", "outside the table's span"),
])
def test_bad_readings_name_the_file_and_line(bench, tmp_path, body, fragment):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,sensor,distance\n" + body)
    proc = run_cli("range", "run", bad, "--sensors", bench["dir"] / "sensors.yaml", "--motion", bench["runs"][0][1],
                   check=False)
    assert proc.returncode != 0
    assert f"{bad}:3" in proc.stderr and fragment in proc.stderr


def test_a_run_that_fails_before_its_first_window_leaves_no_empty_output(bench, tmp_path):
    bad, out = tmp_path / "bad.csv", tmp_path / "out.jsonl"
    bad.write_text("t,sensor,distance\n0.0,laser_left,0.25\n0.1,laser_left,-1\n")
    out.write_text("an earlier run's lines\n")
    proc = run_cli("range", "run", bad, "--sensors", bench["dir"] / "sensors.yaml", "--motion", bench["runs"][0][1],
                   "-o", out, check=False)
    assert proc.returncode != 0 and f"{bad}:3" in proc.stderr
    assert not out.exists()  # it was left empty


def test_counts_without_a_distance_calibration_are_an_error(bench, tmp_path):
    bad = tmp_path / "counts.csv"
    bad.write_text("t,sensor,count\n0.0,laser_left,1500\n")
    proc = run_cli("range", "run", bad, "--sensors", bench["dir"] / "sensors.yaml", "--speed", 1, check=False)
    assert proc.returncode != 0 and "no distance calibration" in proc.stderr


def test_usage_errors_exit_2_before_reading(bench, tmp_path):
    readings, motion = bench["runs"][0]
    layout = bench["dir"] / "sensors.yaml"
    proc = run_cli("range", "run", readings, "--sensors", layout, check=False)
    assert proc.returncode == 2 and "range run needs --motion M.csv or --speed V" in proc.stderr
    proc = run_cli("range", "calibrate-offset", "--reference", bench["dir"] / "ref.csv", "--sensors", layout,
                   readings, readings, "--motion", motion, "-o", tmp_path / "cal.yaml", check=False)
    assert proc.returncode == 2 and "give one --motion file per run (2 runs, 1 motion files)" in proc.stderr


def test_a_speed_no_vehicle_has_is_an_error(bench):
    """Once 1e300 m/s wrote one empty 40 m window per reading, the readings 10^298 m down the road."""
    readings = bench["runs"][0][0]
    layout = bench["dir"] / "sensors.yaml"
    proc = run_cli("range", "run", readings, "--sensors", layout, "--speed", "1e300", check=False)
    assert proc.returncode == 1 and "speed must be within ±1000 m/s" in proc.stderr and not proc.stdout


def test_range_samples_enter_the_fusion_map_and_its_profiles():
    est = rp.Estimator(rp.Config(sensor_height=1.8, fusion={"method": "kalman"}))
    est.process(np.full((10, 3), np.nan, np.float32), 5.0, 0.0, timestamp=0.0)  # starts the clock at the origin
    x = np.arange(1.0, 3.0, 0.01)
    z = 0.02 * np.sin(2 * np.pi * x)
    assert rp.range_sensor.fuse_into(est, x, 0.8, z, 0.001) == 20
    cells = rp._native.core().fusion_map_cells(est._impl, np.array([1.55, 2.25, 7.05]), np.array([0.8, 0.8, 0.8]))
    expect = [np.mean(z[(x >= 1.5) & (x < 1.6)]), np.mean(z[(x >= 2.2) & (x < 2.3)])]
    assert np.allclose(cells[:2, 2], expect, atol=1e-6)
    assert np.allclose(cells[:2, 0], [1.545, 2.245], atol=1e-6)  # the samples' mean x in each cell
    assert np.isnan(cells[2]).all()  # no sample there
    res = est.process(np.full((10, 3), np.nan, np.float32), 5.0, 0.0, timestamp=0.0)  # no ground: the map's
    left = np.asarray(res.left.z)
    s = np.asarray(res.left.s)
    near = (s > 1.05) & (s < 2.95)
    assert np.isfinite(left[near]).all()
    assert np.allclose(left[near], 0.02 * np.sin(2 * np.pi * s[near]), atol=0.003)
    with pytest.raises(ValueError, match="fusion"):
        rp.range_sensor.fuse_into(rp.Estimator(rp.Config(sensor_height=1.8)), x, 0.8, z, 0.001)


def best_shift_m(xz, relief):
    """The shift of the relief that best matches the profile (1 mm steps), and the RMS at it."""
    shifts = np.arange(-0.05, 0.0505, 0.001)
    rms = [np.sqrt(np.mean((xz[:, 1] - relief(xz[:, 0] + sh)) ** 2)) for sh in shifts]
    return shifts[int(np.argmin(rms))], min(rms)


@pytest.mark.parametrize("first, last", [(0.0, 0.1), (0.01, 0.03)], ids=["evenly", "a quarter of each cell"])
def test_the_maps_profile_sits_where_the_road_is(first, last):
    """A map holding a known relief (1.5 m waves) reads it back along the sensor's line without a shift, whether
    the samples fill each cell or, as a LiDAR ring crossing it, only its near quarter: the profile's x is where each
    cell's samples lay (read at the cells' centres the second map would sit 30 mm off, and read at their edges half
    of the time the first moved by ~25 mm — either taken by the offset self-calibration for b2)."""
    est = rp.Estimator(rp.Config(sensor_height=1.8, fusion={"method": "kalman"}))
    est.process(np.full((10, 3), np.nan, np.float32), 5.0, 0.0, timestamp=0.0)
    x = np.arange(0.0, 20.0, 0.001)
    x = x[((x % 0.1) >= first) & ((x % 0.1) < last)]
    relief = lambda u: 0.02 * np.sin(2 * np.pi * u / 1.5)
    rp.range_sensor.fuse_into(est, x, 0.8, relief(x), 0.001)
    xz = rp.range_sensor.map_profile(est, 0.8, -5.0, 30.0)
    assert len(xz) == 200 and np.all(np.diff(xz[:, 0]) > 0)
    assert xz[0, 0] == pytest.approx(np.mean(x[x < 0.1]), abs=1e-6)
    shift, rms = best_shift_m(xz, relief)
    assert abs(shift) <= 0.002
    assert rms < 0.0005  # the cell means of 1.5 m waves: 0.7 % below their peaks
    at_centres = np.column_stack([(np.arange(200) + 0.5) * 0.1, xz[:, 1]])
    assert abs(best_shift_m(at_centres, relief)[0]) == pytest.approx(0.05 - (first + last) / 2, abs=0.002)


def test_a_real_road_profile_read_by_simulated_lasers_keeps_its_iri(tmp_path):
    """The real profile of tests/data/profiles (Šroubek & Šorel, 0.25 m) laid under both wheels and read at 10 m/s:
    every window's IRI within 10 % of the IRI of the profile itself in the same bins."""
    station, elevation = np.loadtxt(DATA / "profiles" / "sroubek_iri" / "profile_1.txt", unpack=True)
    x = station - station[0]
    elevation = elevation - np.polyval(np.polyfit(x, elevation, 1), x)  # the grade: no roughness, out of range
    road = sim.Road(bumps=(sim.ProfileTrack(x, elevation),))
    sensors = [sim.laser("l", "left", x_m=1.0, height_m=1.0), sim.laser("r", "right", x_m=1.0, height_m=1.0)]
    (tmp_path / "sensors.yaml").write_text(sim.layout_yaml(sensors))
    readings, motion = write_drive(tmp_path, "real", sim.drive_readings(road, sensors, 10.0, 121.0, seed=4))
    windows = rp.range_sensor.process(readings, tmp_path / "sensors.yaml", motion=motion)
    assert len(windows) == 4
    for w in windows[:3]:
        s = np.array(w["profiles"]["left"]["s"])
        ok = np.isfinite(np.array(w["profiles"]["left"]["z"], float))  # window 0 starts at the beam's foot
        expected = rp.reference.profile_iri(np.interp(s[ok], x, elevation), 0.1).value
        assert w["roughness"]["left"]["iri"]["value"] == pytest.approx(expected, rel=0.10)
        assert w["roughness"]["vehicle"]["class"] is not None
