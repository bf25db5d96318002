# SPDX-License-Identifier: BSD-3-Clause
"""Beam self-calibration (docs/method.md §8): the numpy reference on small simulated drives, the CLI's
`calibrate` and `--beam-calibration` on real recordings and on bad input."""

import json
import subprocess
import warnings

import numpy as np
import pytest

import roadpreview as rp
from roadpreview import sim
from roadpreview.reference import calibration as cal
from roadpreview.reference import surface_calibration as surface

from paths import KITTI_FRAMES, OS1_128_HEIGHT, OS1_128_PCAP, OUSTER, cli

SPEED_MPS = 10.0


def small_drive(errors_deg, frames=6):
    """A short class B drive of a coarse 64-beam sensor (fast: 512 columns) whose beams are off by errors_deg."""
    lidar = sim.hdl_64e(height_m=1.8, columns=512, beam_errors_deg=tuple(errors_deg))
    scene = sim.Scene(sim.Road.iso8608("B", seed=3), ())
    drive = sim.drive(scene, lidar, SPEED_MPS, 0.0, frames, seed=3)
    return lidar, drive


def gauge_free(values, reach, members):
    """values less their fit by a + b/reach + c·reach over members, as the calibration reports offsets."""
    basis = cal.gauge_columns(reach[members])
    v = values[members]
    return v - basis @ np.linalg.lstsq(basis, v, rcond=None)[0]


@pytest.fixture(scope="module")
def drive():
    errors = np.random.default_rng(7).uniform(-0.1, 0.1, 64)
    return (errors, *small_drive(errors))


@pytest.fixture(scope="module")
def uniform_offsets(drive):
    errors, lidar, frames = drive
    res = cal.calibrate_beams([(f.points, lidar.beam_index()) for f in frames],
                              [(f.pose.x_m, f.pose.y_m, f.pose.yaw_rad) for f in frames], lidar.beams,
                              rp.Config(extrinsics=lidar.extrinsics()))
    return errors, res


def test_reference_recovers_uniform_offsets(uniform_offsets):
    errors, res = uniform_offsets
    d = res.determined
    assert d.sum() >= 30
    truth = gauge_free(errors, res.extra["reach"], d)
    error = res.elevation_offset_deg[d] - truth
    assert np.sqrt(np.mean(error**2)) < 0.005  # offsets of up to 0.1°, on a short coarse drive
    assert np.corrcoef(res.elevation_offset_deg[d], truth)[0, 1] > 0.99
    assert np.all(np.isnan(res.elevation_sigma_deg[~d]))


def test_reference_range_offsets_stay_unestimated_on_a_flat_road(uniform_offsets):
    # every beam meets a flat road at one range: its range offset cannot be told from its elevation offset
    _, res = uniform_offsets
    assert np.all(res.range_offset_m == 0.0)


def test_reference_rejects_a_static_or_short_drive(drive):
    _, lidar, frames = drive
    frames = frames[:2]
    beams = lidar.beam_index()
    with pytest.raises(cal.CalibrationError, match="too short"):
        cal.calibrate_beams([(frames[0].points, beams)], [(0.0, 0.0, 0.0)], 64)
    with pytest.raises(cal.CalibrationError, match="no motion"):
        cal.calibrate_beams([(f.points, beams) for f in frames], [(0.0, 0.0, 0.0)] * 2, 64)


@pytest.mark.skipif(not rp.native_available(), reason="needs the compiled extension")
def test_exact_beams_read_no_offset_at_the_default_cell_size():
    """method.md §8 step 1: range noise moves a point along its ray, so on a steep beam the cell it falls in depends
    on its height error; small cells turn that into a bias of the near beams. A sensor with exact beams reads every
    offset within the 0.005° target with the default cells, and the steep beams stray beyond it with 5 cm cells."""
    lidar = sim.hdl_64e(height_m=1.8, columns=1024)  # 2 cm range noise, no offsets
    frames = sim.drive(sim.Scene(sim.Road.iso8608("B", seed=4), ()), lidar, SPEED_MPS, 0.0, 12, seed=4)
    steep = ring_reach(lidar) < 6.0
    offsets = {}
    for cell in (None, 0.05):
        c = rp.calibrate_beams([(f.points, lidar.beam_index()) for f in frames],
                               poses=[(f.pose.x_m, f.pose.y_m, f.pose.yaw_rad) for f in frames],
                               config=rp.Config(extrinsics=lidar.extrinsics()), beam_count=lidar.beams,
                               **({} if cell is None else {"cell_m": cell}))
        d = np.asarray(c.determined)
        assert d.sum() >= 45
        offsets[cell] = np.where(d, np.asarray(c.elevation_offset_deg), 0.0)
    assert np.abs(offsets[None]).max() <= 0.005
    assert np.abs(offsets[0.05][steep]).max() > 0.008


def ring_reach(lidar) -> np.ndarray:
    """Each beam's horizontal range to a level road (inf for beams that never meet it)."""
    elevation = np.radians(np.asarray(lidar.elevations_deg))
    return np.where(elevation < 0, lidar.height_m / np.tan(-np.minimum(elevation, -1e-9)), np.inf)


def run_cli(*args):
    return subprocess.run([cli(), *map(str, args)], capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def os1_beams(tmp_path_factory):
    out = tmp_path_factory.mktemp("beams") / "beams.yaml"
    r = run_cli("calibrate", OS1_128_PCAP, "--sensor-height", OS1_128_HEIGHT, "--poses",
                OUSTER / "OS-1-128_v2.3.0_1024x10_lb_n3_poses_kitti.txt", "-o", out, "-q")
    assert r.returncode == 0, r.stderr
    return out


def test_cli_calibrate_writes_a_beams_file(os1_beams):
    import yaml
    doc = yaml.safe_load(os1_beams.read_text())
    assert doc["format"] == "roadpreview beam calibration 1"
    assert doc["sensor_model"] == "OS-1-128" and doc["serial"] == "122201000998" and doc["beam_count"] == 128
    assert [b["beam"] for b in doc["beams"]] == list(range(128))
    determined = [b for b in doc["beams"] if b["determined"]]
    assert len(determined) == 47  # of 128: those the 3 frames' road reaches (as `calibrate` reports it)
    assert all(b["observations"] > 0 and b["elevation_sigma_deg"] > 0 for b in determined)
    assert all(b["elevation_offset_deg"] == 0 and b["elevation_sigma_deg"] is None
               for b in doc["beams"] if not b["determined"])
    assert doc["drive"]["frames"] == 3


def test_cli_applies_the_beams_file(os1_beams, tmp_path):
    outs = []
    for extra in ((), ("--beam-calibration", os1_beams)):
        out = tmp_path / f"run{len(outs)}.jsonl"
        r = run_cli("run", OS1_128_PCAP, "--sensor-height", OS1_128_HEIGHT, "--speed", 2.5, "--frames", "0:1",
                    "-o", out, "-q", *extra)
        assert r.returncode == 0, r.stderr
        outs.append(json.loads(out.read_text().splitlines()[0]))
    assert outs[0]["points"]["input"] == outs[1]["points"]["input"]
    assert outs[0]["ground"]["plane"] != outs[1]["ground"]["plane"]  # the corrected points fit another plane


def test_cli_counts_each_calibrated_beams_stated_sigma(os1_beams, tmp_path):
    """--beam-sigmas-from-calibration: each determined beam's stated σ, --beam-sigma-deg for the others — the
    profiles' bins state more noise than uncounted, and the same as the Python API given the file's sigmas."""
    cal = rp.read_beam_calibration(os1_beams)
    sigmas = cal.beam_sigmas_deg(0.02)
    assert len(sigmas) == 128
    determined = np.asarray(cal.determined)
    np.testing.assert_array_equal(np.asarray(sigmas)[~determined], 0.02)
    np.testing.assert_array_equal(np.asarray(sigmas)[determined], np.asarray(cal.elevation_sigma_deg)[determined])
    lines = []
    for extra in ((), ("--beam-sigma-deg", 0.02, "--beam-sigmas-from-calibration")):
        out = tmp_path / f"run{len(lines)}.jsonl"
        r = run_cli("run", OS1_128_PCAP, "--sensor-height", OS1_128_HEIGHT, "--speed", 2.5, "--frames", "0:1",
                    "--beam-calibration", os1_beams, "-o", out, "-q", *extra)
        assert r.returncode == 0, r.stderr
        lines.append(json.loads(out.read_text().splitlines()[0]))
    plain, counted = (np.array(line["profiles"]["left"]["spread"], dtype=float) for line in lines)
    backed = np.isfinite(plain) & np.isfinite(counted)
    assert backed.sum() > 50
    assert (counted[backed] >= plain[backed] * (1 - 1e-9)).all() and (counted[backed] > plain[backed]).any()
    cfg = rp.Config(sensor_height=OS1_128_HEIGHT, profile={"beam_sigma_deg": 0.02, "beam_sigmas_deg": sigmas})
    api = next(iter(rp.run(OS1_128_PCAP, cfg, speed=2.5, frames=(0, 1), beam_calibration=os1_beams)))
    np.testing.assert_allclose(np.asarray(api.left.spread, dtype=float), counted, rtol=1e-6, equal_nan=True)
    r = run_cli("run", OS1_128_PCAP, "--speed", 2.5, "--beam-sigmas-from-calibration")
    assert r.returncode != 0 and "--beam-calibration" in r.stderr


def test_cli_rejects_a_beams_file_for_another_sensor(os1_beams, tmp_path):
    other = tmp_path / "other.yaml"
    other.write_text(os1_beams.read_text().replace('serial: "122201000998"', 'serial: "999"'))
    r = run_cli("run", OS1_128_PCAP, "--sensor-height", OS1_128_HEIGHT, "--speed", 2.5, "--beam-calibration", other)
    assert r.returncode != 0 and "other.yaml" in r.stderr and "serial 999" in r.stderr
    pcap_64 = OUSTER / "OS-1-64_1024x10_fw20.pcap"
    r = run_cli("run", pcap_64, "--meta", OUSTER / "OS-1-64_sensor_config_reduced.json", "--speed", 2.5,
                "--beam-calibration", os1_beams)
    assert r.returncode != 0 and "beams.yaml" in r.stderr and "128-beam" in r.stderr
    r = run_cli("run", KITTI_FRAMES[0], "--speed", 2.5, "--beam-calibration", os1_beams)
    assert r.returncode != 0 and "beams.yaml" in r.stderr and "elevation" in r.stderr


def test_cli_calibrate_rejects_a_static_drive(tmp_path):
    r = run_cli("calibrate", OS1_128_PCAP, "--sensor-height", OS1_128_HEIGHT, "--speed", 0, "-o", tmp_path / "b.yaml")
    assert r.returncode != 0 and "no motion" in r.stderr and OS1_128_PCAP.name in r.stderr
    r = run_cli("calibrate", OS1_128_PCAP, "--sensor-height", OS1_128_HEIGHT, "--speed", 2.5, "--frames", "0:1",
                "-o", tmp_path / "b.yaml")
    assert r.returncode != 0 and "too short" in r.stderr


def test_cli_calibrate_without_motion_is_a_usage_error(tmp_path):
    r = run_cli("calibrate", OS1_128_PCAP, "--sensor-height", OS1_128_HEIGHT, "-o", tmp_path / "b.yaml")
    assert r.returncode == 2 and "give the vehicle's motion" in r.stderr and "--method surface" in r.stderr
    assert not (tmp_path / "b.yaml").exists()


@pytest.mark.skipif(not rp.native_available(), reason="needs the compiled extension")
def test_cpp_agrees_with_the_reference(drive, uniform_offsets):
    errors, lidar, frames = drive
    reference = uniform_offsets[1]
    cpp = rp.calibrate_beams([(f.points, lidar.beam_index()) for f in frames],
                             poses=[(f.pose.x_m, f.pose.y_m, f.pose.yaw_rad) for f in frames],
                             config=rp.Config(extrinsics=lidar.extrinsics()), beam_count=lidar.beams)
    determined = reference.determined
    np.testing.assert_array_equal(cpp.determined, determined)  # the same 48 beams
    # Measured: offsets ≤ 3.6e-10° apart (the errors are up to 0.1°), the residual 8e-9 relative, the stated σ
    # 2.4e-5 relative; the bounds leave rounding room and no more.
    np.testing.assert_allclose(np.asarray(cpp.elevation_offset_deg)[determined],
                               reference.elevation_offset_deg[determined], atol=1e-8)
    np.testing.assert_allclose(cpp.residual_m, reference.residual_m, rtol=1e-6)
    np.testing.assert_allclose(np.asarray(cpp.elevation_sigma_deg)[determined],
                               reference.elevation_sigma_deg[determined], rtol=1e-4)


@pytest.mark.skipif(not rp.native_available(), reason="needs the compiled extension")
def test_a_short_motion_drive_is_calibrated_with_a_warning(drive, tmp_path):
    """The motion method links far beams weakly on a short drive, and states σ far below its real error (README:
    two 1.7 m halves of a KITTI drive disagreed by 0.08°, each stating 0.003°): a drive under 15 m is warned of."""
    def calibrate(lidar, frames):
        return rp.calibrate_beams([(f.points, lidar.beam_index()) for f in frames],
                                  poses=[(f.pose.x_m, f.pose.y_m, f.pose.yaw_rad) for f in frames],
                                  config=rp.Config(extrinsics=lidar.extrinsics()), beam_count=lidar.beams)

    errors, lidar, frames = drive
    with pytest.warns(RuntimeWarning, match=r"a drive of 5\.00 m is short for the motion method \(15 m or more\)"):
        calibrate(lidar, frames)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # 16 m: nothing to say
        calibrate(*small_drive(errors, frames=17))
    r = run_cli("calibrate", OS1_128_PCAP, "--sensor-height", OS1_128_HEIGHT, "--speed", 2.5, "-o", tmp_path / "b.yaml",
                "-q")
    assert r.returncode == 0 and "warning: a drive of 0.50 m is short for the motion method" in r.stderr, r.stderr


@pytest.mark.skipif(not rp.native_available(), reason="needs the compiled extension")
def test_python_api_saves_a_beams_file_that_applies(drive, tmp_path):
    errors, lidar, frames = drive
    c = rp.calibrate_beams([(f.points, lidar.beam_index()) for f in frames],
                           poses=[(f.pose.x_m, f.pose.y_m, f.pose.yaw_rad) for f in frames],
                           config=rp.Config(extrinsics=lidar.extrinsics()), beam_count=lidar.beams)
    path = tmp_path / "beams.yaml"
    c.save(str(path))
    back = rp._core.read_beam_calibration(str(path))
    np.testing.assert_allclose(back.elevation_offset_deg, c.elevation_offset_deg, atol=1e-7)
    corrected = c.apply(frames[0].points, lidar.beam_index().astype(np.int32))
    finite = np.isfinite(frames[0].points[:, 0])
    elevation = np.degrees(np.arcsin(corrected[finite, 2] / np.linalg.norm(corrected[finite, :3], axis=1)))
    before = np.degrees(np.arcsin(frames[0].points[finite, 2] / np.linalg.norm(frames[0].points[finite, :3], axis=1)))
    shift = np.asarray(c.elevation_offset_deg)[lidar.beam_index()[finite]]
    np.testing.assert_allclose(elevation - before, shift, atol=2e-4)
    with pytest.raises(rp.CalibrationError, match="no motion"):
        rp.calibrate_beams([(f.points, lidar.beam_index()) for f in frames[:3]], poses=[(0.0, 0.0, 0.0)] * 3,
                           beam_count=lidar.beams)
    for method in ("motion", "surface"):  # once: "no points ahead beyond 4 m", as if the frames were empty
        with pytest.raises(rp.CalibrationError, match="calibrate_beams: no frames given"):
            rp.calibrate_beams([], speed=5.0, method=method)


# KITTI odometry seq 00 ground-truth poses of frames 0-2 (KITTI, CC BY-NC-SA 3.0), turned from the camera's axes
# into the Velodyne's: x, y (m) and heading (rad)
KITTI_POSES = [(0.0, 0.0, 0.0), (0.8587, 0.0469, 0.00207), (1.7163, 0.0937, 0.00413)]


@pytest.mark.skipif(not rp.native_available(), reason="needs the compiled extension")
def test_kitti_beams_found_by_scan_order(tmp_path):
    """KITTI's .bin files list their points ring by ring from the top beam (method.md §8): the ring is the beam."""
    frames = [rp.io.read(f) for f in KITTI_FRAMES[:3]]
    c = rp.calibrate_beams(frames, poses=KITTI_POSES, config=rp.Config(sensor_height=1.73))
    assert "beam_index: scan_order" in c.to_yaml()
    centres = np.asarray(c.elevation_deg)
    assert np.all(np.diff(centres) < 0) and -25.5 < centres[-1] < -23.0  # from the top; the lowest near −24.8°
    path = tmp_path / "kitti_beams.yaml"
    c.save(str(path))
    frame = next(iter(rp.io.open(KITTI_FRAMES[0], beam_calibration=path)))
    np.testing.assert_array_equal(frame.beams, surface.rings_in_scan_order(frames[0]))
    assert [surface.in_scan_order(f, 64) for f in frames] == [True] * 3


@pytest.mark.skipif(not rp.native_available(), reason="needs the compiled extension")
def test_kitti_beams_found_by_elevation_when_out_of_scan_order(tmp_path):
    rng = np.random.default_rng(0)
    frames = [p[rng.permutation(len(p))] for p in (rp.io.read(f) for f in KITTI_FRAMES[:3])]
    assert not any(surface.in_scan_order(f, 64) for f in frames)
    c = rp.calibrate_beams(frames, poses=KITTI_POSES, config=rp.Config(sensor_height=1.73))
    assert "beam_index: elevation" in c.to_yaml()
    centres = np.asarray(c.elevation_deg)
    assert c.beam_count == 64 and np.all(np.diff(centres) <= -0.25)  # numbered from the top, distinct rings
    assert -25.5 < centres[-1] < -23.0  # the HDL-64E's lowest beam is near −24.8°
    path = tmp_path / "kitti_beams.yaml"
    c.save(str(path))
    shuffled = tmp_path / "shuffled.bin"
    frames[0].astype(np.float32).tofile(shuffled)
    frame = next(iter(rp.io.open(shuffled, beam_calibration=path)))
    beams = np.asarray(frame.beams)
    raw = frames[0]
    ahead = (raw[:, 0] > 4) & (np.abs(raw[:, 1]) < 10) & (raw[:, 2] < -1.0)  # the road ahead
    assert np.mean(beams[ahead] >= 0) > 0.9
    moved = np.linalg.norm(frame.points[:, :3] - raw[:, :3], axis=1)
    assert np.all(moved[beams < 0] == 0) and np.any(moved[beams >= 0] > 0)


def test_reference_surface_calibration_recovers_simulated_offsets():
    """No poses: each frame's beams against its smooth road; six frames of a class B road, offsets 0.03° (1σ)."""
    errors = np.random.default_rng(7).normal(0.0, 0.03, 64)
    lidar, frames = small_drive(errors)
    res = surface.calibrate_beams_on_surface([(f.points, lidar.beam_index()) for f in frames], lidar.beams,
                                             rp.Config(extrinsics=lidar.extrinsics()))
    d = res.determined
    assert d.sum() >= 40
    truth = gauge_free(errors, res.extra["reach"], d)
    error = res.elevation_offset_deg[d] - truth
    assert np.sqrt(np.mean(error**2)) < 0.01  # 0.0064° measured: the road's own relief, six frames
    assert np.corrcoef(res.elevation_offset_deg[d], truth)[0, 1] > 0.95
    assert np.all(res.observations[d] >= 3)


@pytest.mark.skipif(not rp.native_available(), reason="needs the compiled extension")
def test_surface_calibration_cpp_agrees_with_the_reference_on_kitti():
    frames = [rp.io.read(f) for f in KITTI_FRAMES[:3]]
    cfg = rp.Config(sensor_height=1.73)
    cpp = rp.calibrate_beams(frames, method="surface", config=cfg)
    ref = surface.calibrate_beams_on_surface([(p, surface.rings_in_scan_order(p)) for p in frames], 64, cfg)
    np.testing.assert_array_equal(cpp.determined, ref.determined)
    assert ref.determined.sum() >= 40
    np.testing.assert_allclose(cpp.elevation_offset_deg, ref.elevation_offset_deg, atol=1e-9)
    np.testing.assert_allclose(cpp.elevation_sigma_deg, ref.elevation_sigma_deg, rtol=1e-6)
    np.testing.assert_allclose(cpp.residual_m, ref.residual_m, rtol=1e-9)
    with pytest.raises(rp.CalibrationError, match="too short"):
        rp.calibrate_beams(frames[:2], method="surface", config=cfg)


@pytest.mark.skipif(not rp.native_available(), reason="needs the compiled extension")
def test_a_surface_calibration_from_one_street_smooths_another(tmp_path):
    """Real data: offsets from three frames of KITTI seq 00, no motion given, applied to the SPVNAS frame (another
    street): its wheel-path profiles lose the beams' steps — the vehicle IRI falls by more than a quarter (13.5 →
    8–8.5 m/km measured) and the roughness G_d(n0) of both wheels falls."""
    beams = tmp_path / "beams.yaml"
    r = run_cli("calibrate", *KITTI_FRAMES[:3], "--sensor-height", 1.73, "--method", "surface", "-o", beams, "-q")
    assert r.returncode == 0, r.stderr
    assert "beam_index: scan_order" in beams.read_text()
    outs = []
    for extra in ((), ("--beam-calibration", beams)):
        out = tmp_path / f"run{len(outs)}.jsonl"
        r = run_cli("run", KITTI_FRAMES[3], "--sensor-height", 1.73, "--speed", 5, "-o", out, "-q", *extra)
        assert r.returncode == 0, r.stderr
        outs.append(json.loads(out.read_text().splitlines()[0])["roughness"])
    before, after = outs
    assert after["vehicle"]["iri"]["value"] < 0.75 * before["vehicle"]["iri"]["value"]
    for wheel in ("left", "right"):
        assert after[wheel]["gd_n0"] < before[wheel]["gd_n0"]


@pytest.mark.skipif(not rp.native_available(), reason="needs the compiled extension")
def test_beam_numbers_for_some_frames_only_are_an_error():
    frames = [rp.io.read(f) for f in KITTI_FRAMES[:3]]
    mixed = [(frames[0], surface.rings_in_scan_order(frames[0])), frames[1], frames[2]]
    with pytest.raises(ValueError, match="frame 1 has no beam numbers"):
        rp.calibrate_beams(mixed, method="surface", config=rp.Config(sensor_height=1.73))


def test_cli_surface_calibration_needs_three_frames_and_scan_order(tmp_path):
    r = run_cli("calibrate", *KITTI_FRAMES[:2], "--sensor-height", 1.73, "--method", "surface", "-o", tmp_path / "b.yaml")
    assert r.returncode != 0 and "too short" in r.stderr and KITTI_FRAMES[0].name in r.stderr
    beams = tmp_path / "beams.yaml"
    assert run_cli("calibrate", *KITTI_FRAMES[:3], "--sensor-height", 1.73, "--method", "surface", "-o", beams,
                   "-q").returncode == 0
    shuffled = tmp_path / "shuffled.bin"
    points = np.fromfile(KITTI_FRAMES[0], np.float32).reshape(-1, 4)
    points[np.random.default_rng(1).permutation(len(points))].tofile(shuffled)
    r = run_cli("run", shuffled, "--sensor-height", 1.73, "--speed", 5, "--beam-calibration", beams)
    assert r.returncode != 0 and "shuffled.bin" in r.stderr and "scan order" in r.stderr


@pytest.mark.skipif(not rp.native_available(), reason="needs the compiled extension")
def test_the_calibration_compares_the_one_plane_ground_whatever_the_ground_method():
    """method.md §8: the zone ground also takes a KITTI street's verges (low vegetation, pavements), which no two
    beams see at one height; the calibration's ground is the paper's one plane under either setting."""
    frames = [rp.io.read(f) for f in KITTI_FRAMES[:3]]
    zones, pca = (rp.Config(sensor_height=1.73, ground={"method": m}) for m in ("zones", "pca"))
    assert np.count_nonzero(rp.reference.fit_ground(_base(frames[0]), zones)[0]
                            != rp.reference.fit_ground(_base(frames[0]), pca)[0]) > 1000  # the masks differ
    by_zones, by_pca = (rp.calibrate_beams(frames, poses=KITTI_POSES, config=c) for c in (zones, pca))
    np.testing.assert_array_equal(by_zones.elevation_offset_deg, by_pca.elevation_offset_deg)
    np.testing.assert_array_equal(cal.ground_mask_of(frames[0], zones), cal.ground_mask_of(frames[0], pca))


def _base(points):
    """A KITTI frame (sensor 1.73 m up, level) in the base frame, finite rows."""
    xyz = points[:, :3].astype(np.float64)
    return xyz[np.isfinite(xyz).all(axis=1)] + [0.0, 0.0, 1.73]
