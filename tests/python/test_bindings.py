"""The Python API over the C++ core: inputs, outputs, errors, config."""

import json
import sys
import tracemalloc

import numpy as np
import pytest

import roadpreview as rp
from paths import KITTI_FRAMES, KITTI_SENSOR_HEIGHT


@pytest.fixture(scope="module")
def kitti():
    return rp.io.read(KITTI_FRAMES[0])


@pytest.fixture
def est():
    return rp.Estimator(rp.Config(sensor_height=KITTI_SENSOR_HEIGHT))


def test_result_carries_every_documented_field(est, kitti):
    res = est.process(kitti, speed=5.0, yaw_rate=0.1)
    assert res.ground_mask.shape == (len(kitti),) and res.ground_mask.dtype == bool
    assert res.ground_mask.sum() == res.points["ground"] > 0
    assert res.plane.shape == (4,) and res.plane[2] > 0
    assert res.path["status"] == "arc" and res.path["icr_y"] == pytest.approx(50.0)
    for wheel in (res.left, res.right):
        assert wheel.s.shape == wheel.z.shape == wheel.count.shape == (400,)
        assert wheel.roughness.iso_class in tuple("ABCDEFGH")
        assert wheel.roughness.band[0] >= 0.1 and wheel.roughness.band[1] <= 4.0
        assert wheel.roughness.n.shape == wheel.roughness.psd.shape
    assert res.vehicle.gd_n0 > 0
    assert set(res.timing_ms) == {"ground", "path", "profile", "roughness", "obstacles", "total"}


def test_arrays_are_read_only_views_that_outlive_the_result(est, kitti):
    z = est.process(kitti, 5.0).left.z  # the Result itself is gone
    assert not z.flags.writeable
    with pytest.raises(ValueError):
        z[0] = 1.0
    assert np.isfinite(z).sum() > 50


def test_to_dict_is_the_json_line(est, kitti):
    res = est.process(kitti, 5.0, source="frame.bin", timestamp=1.5)
    d = res.to_dict()
    assert d == json.loads(res.to_json())
    assert d["source"] == "frame.bin" and d["timestamp"] == 1.5
    z = d["profiles"]["left"]["z"]
    assert [v is None for v in z] == list(np.isnan(res.left.z))
    assert d["roughness"]["left"]["class"] == res.left.roughness.iso_class


def test_float32_rows_are_read_in_place(est, kitti):
    """A float32 cloud (or a column slice of one) is not copied; float64 is converted once."""
    xyz = np.ascontiguousarray(kitti[:, :3])
    est.process(xyz, 5.0)  # warm up
    for points, copied in ((kitti, False), (kitti[:, :3], False), (kitti.astype(np.float64), True)):
        tracemalloc.start()
        est.process(points, 5.0)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        converted = peak >= points.shape[0] * 3 * 4
        assert converted == copied, (points.dtype, points.strides, peak)


def test_dtypes_and_column_slices_agree(est, kitti):
    ref = est.process(kitti, 5.0).ground_mask
    assert np.array_equal(est.process(kitti[:, :3].copy(), 5.0).ground_mask, ref)
    assert np.array_equal(est.process(kitti.astype(np.float64), 5.0).ground_mask, ref)
    assert np.array_equal(est.process(np.asfortranarray(kitti), 5.0).ground_mask, ref)


@pytest.mark.parametrize(
    "points, error, words",
    [
        (np.zeros(12, np.float32), ValueError, "2-D"),
        (np.zeros((10, 2), np.float32), ValueError, "at least 3 columns"),
        (np.zeros((2, 3, 4), np.float32), ValueError, "2-D"),
        (np.zeros((10, 3), np.int64), TypeError, "float32 or float64"),
        (np.zeros((10, 3), np.complex64), TypeError, "float32 or float64"),
        ([[1.0, 2.0, 3.0]], TypeError, "numpy array"),
    ],
)
def test_bad_points_raise_clear_errors(est, points, error, words):
    with pytest.raises(error, match=words):
        est.process(points, 5.0)


@pytest.mark.parametrize("speed, yaw_rate", [(np.nan, 0.0), (5.0, np.inf), (-np.inf, 0.1)])
def test_non_finite_motion_is_a_value_error(est, kitti, speed, yaw_rate):
    with pytest.raises(ValueError, match="finite"):
        est.process(kitti, speed, yaw_rate)


@pytest.mark.parametrize(
    "points, reason",
    [
        (np.zeros((0, 3), np.float32), "no finite points"),
        (np.full((100, 4), np.nan, np.float32), "no finite points"),
        (np.array([[100.0, 0.0, 0.0]] * 10, np.float32), "no points in the region of interest"),
    ],
)
def test_degenerate_clouds_give_documented_empty_results(est, points, reason):
    res = est.process(points, 5.0)
    assert res.reason == reason
    assert res.plane is None and res.left.z.size == 0 and res.right.z.size == 0
    assert res.left.roughness.iso_class is None and res.left.roughness.reason == reason
    assert res.vehicle.iso_class is None and res.ground_mask.shape == (len(points),)
    assert res.to_dict()["reason"] == reason


def test_zero_speed_keeps_the_ground_and_says_why_there_is_no_profile(est, kitti):
    res = est.process(kitti, 0.0, 0.2)
    assert res.reason == "vehicle stopped" and res.path["status"] == "stopped"
    assert res.points["ground"] > 0 and res.left.z.size == 0


def test_frames_are_counted(est, kitti):
    assert [est.process(kitti[:1000], 5.0).frame for _ in range(3)] == [0, 1, 2]


def test_config_defaults_match_the_cpp_defaults():
    from roadpreview._native import core

    assert rp.Config().to_dict() == json.loads(core().default_config_json())


def test_config_keywords_nested_dicts_and_files(tmp_path):
    cfg = rp.Config(sensor_height=1.73, track_width=1.5, ground={"method": "ransac"})
    assert cfg.ground.method == "ransac" and cfg.ground.pca_iterations == 3
    (tmp_path / "c.json").write_text(json.dumps({"tire_width": 0.25, "profile": {"ds_m": 0.05}}))
    (tmp_path / "c.yaml").write_text("tire_width: 0.25\nprofile:\n  ds_m: 0.05\n")
    assert rp.Config.from_file(tmp_path / "c.json") == rp.Config.from_file(tmp_path / "c.yaml")
    assert rp.Config.from_file(tmp_path / "c.json").profile.ds_m == 0.05


def test_a_yaml_config_without_pyyaml_names_the_extra_not_a_bad_file(tmp_path, monkeypatch):
    (tmp_path / "c.yaml").write_text("tire_width: 0.25\n")
    monkeypatch.setitem(sys.modules, "yaml", None)  # as if pyyaml were not installed
    with pytest.raises(ImportError, match=r"c.yaml: a YAML config needs pyyaml: pip install 'roadpreview\[yaml\]'"):
        rp.Config.from_file(tmp_path / "c.yaml")


@pytest.mark.parametrize(
    "kwargs, words",
    [
        (dict(tire_width=0.0), "tire_width"),
        (dict(sensor_height=1.7, extrinsics=rp.Extrinsics(z_m=1.7)), "not both"),
        (dict(ground={"method": "magic"}), "ground.method"),
        (dict(roughness={"band_min_cpm": 5.0}), "band_min_cpm"),
        (dict(threads=0), "threads must be between 1 and 64, got 0"),
        (dict(threads=65), "threads must be between 1 and 64, got 65"),
        (dict(threads=1.5), "threads"),
    ],
)
def test_invalid_configs_are_rejected_naming_the_field(kwargs, words):
    with pytest.raises(ValueError, match=words):
        rp.Estimator(rp.Config(**kwargs))


def test_threads_give_the_answer_of_one_thread(kitti):
    """The crop's runs of rows, the zones' azimuth groups, the obstacles beside the profiles: the same result."""
    one, two = (rp.Estimator(rp.Config(sensor_height=KITTI_SENSOR_HEIGHT, threads=n)) for n in (1, 2))
    a, b = (est.process(kitti, 5.0, 0.1) for est in (one, two))
    assert np.array_equal(a.ground_mask, b.ground_mask) and np.array_equal(a.cluster_labels, b.cluster_labels)
    assert np.array_equal(a.plane, b.plane) and len(a.obstacles.count) > 0
    for wheel in ("left", "right"):
        pa, pb = getattr(a, wheel), getattr(b, wheel)
        assert np.array_equal(pa.z, pb.z, equal_nan=True) and np.array_equal(pa.count, pb.count)
    line_a, line_b = (json.loads(r.to_json()) for r in (a, b))
    assert {**line_a, "timing_ms": None} == {**line_b, "timing_ms": None}


def test_unknown_config_fields_are_rejected(tmp_path):
    with pytest.raises(ValueError, match="methdo"):
        rp.Config(ground={"methdo": "pca"})
    (tmp_path / "bad.json").write_text('{"trackwidth": 1.6}')
    with pytest.raises(ValueError, match=r"bad\.json.*trackwidth"):
        rp.Config.from_file(tmp_path / "bad.json")
    with pytest.raises(ValueError, match="missing.json"):
        rp.Config.from_file(tmp_path / "missing.json")


def test_reader_errors_name_the_file(tmp_path):
    truncated = tmp_path / "cut.bin"
    truncated.write_bytes(b"\0" * 23)
    with pytest.raises(RuntimeError, match=r"cut\.bin.*multiple of 16"):
        rp.io.read(truncated)
    garbage = tmp_path / "junk.pcd"
    garbage.write_bytes(b"not a pcd at all\n\x00\x01")
    with pytest.raises(RuntimeError, match=r"junk\.pcd"):
        rp.io.read(garbage)
    with pytest.raises(RuntimeError, match="no such file"):
        rp.io.read(tmp_path / "absent.bin")


def test_cmake_dir_holds_the_package():
    from pathlib import Path

    assert (Path(rp.cmake_dir()) / "roadpreviewConfig.cmake").is_file()


def test_json_line_carries_the_noise_aware_fields_and_iri(est, kitti):
    res = est.process(kitti, 5.0)
    d = res.to_dict()
    for side, roughness in (("left", res.left.roughness), ("right", res.right.roughness), ("vehicle", res.vehicle)):
        line = d["roughness"][side]
        assert line["band_limit"] == roughness.band_limit in ("requested", "nyquist", "sampling", "noise", "wheels")
        assert line["backed_fraction"] == pytest.approx(roughness.backed_fraction) and 0 < roughness.backed_fraction <= 1
        assert line["noise_floor"] == pytest.approx(roughness.noise_floor) and roughness.noise_floor > 0
        assert line["noise_psd"] == pytest.approx(list(roughness.noise_psd)) and len(line["noise_psd"]) == len(line["psd"])
        assert line["confidence"] == (None if roughness.iso_class is None else pytest.approx(roughness.confidence))
        assert line["iri"] == {"value": roughness.iri.value if roughness.iri.value is None else pytest.approx(roughness.iri.value),
                               "length": pytest.approx(roughness.iri.length), "reason": roughness.iri.reason,
                               "backed_fraction": pytest.approx(roughness.iri.backed_fraction),
                               "noise": pytest.approx(roughness.iri.noise)}
        assert 0 < roughness.iri.backed_fraction <= 1 and 0 < roughness.iri.noise < 10
    spread = d["profiles"]["left"]["spread"]
    assert len(spread) == len(res.left.z)
    assert [v is None for v in spread] == list(np.isnan(res.left.spread))
    assert np.all((res.left.count >= 2) == np.isfinite(res.left.spread))
