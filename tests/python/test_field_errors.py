"""Python-side errors a new user meets: invalid class arguments, NaN in a config, byte order of the points."""

import math

import numpy as np
import pytest

import roadpreview as rp
from paths import KITTI_FRAMES, KITTI_SENSOR_HEIGHT


@pytest.mark.parametrize("bad", [math.nan, -1.0, -1e-9, math.inf])
def test_iso_class_rejects_values_that_are_no_psd(bad):
    with pytest.raises(ValueError, match="G_d"):
        rp.native.iso_class(bad)
    with pytest.raises(ValueError, match="gd_n0"):
        rp.reference.roughness.iso_class(bad)


def test_iso_class_of_zero_is_a():
    assert rp.native.iso_class(0.0) == "A" == rp.reference.roughness.iso_class(0.0)


def test_nan_extrinsics_name_the_field():
    cfg = rp.Config(extrinsics={"x_m": 0.0, "z_m": math.nan})
    with pytest.raises(ValueError, match=r"Config\.extrinsics\.z_m must be finite"):
        rp.Estimator(cfg)


def test_big_endian_points_give_the_native_result():
    points = rp.io.read(KITTI_FRAMES[0])
    est = rp.Estimator(rp.Config(sensor_height=KITTI_SENSOR_HEIGHT))
    native = est.process(points, 5.0, 0.0).to_dict()
    swapped = est.process(points.astype(">f4"), 5.0, 0.0).to_dict()
    assert swapped["points"] == native["points"] and swapped["ground"]["plane"] == native["ground"]["plane"]
    assert swapped["roughness"]["left"]["class"] == native["roughness"]["left"]["class"]
    big64 = est.process(points.astype(">f8"), 5.0, 0.0).to_dict()
    assert big64["points"] == native["points"]


def test_a_flat_noiseless_road_is_class_a_in_both_implementations():
    """Zero PSD and zero noise made the likelihood fit 0/0: G_d(n0) was NaN, read as 'A' only by accident."""
    rng = np.random.default_rng(1)
    x, y = rng.uniform(1, 40, 20000), -rng.uniform(0.2, 3.2, 20000)
    points = np.column_stack([x, y, np.full(len(x), -1.8)]).astype(np.float32)
    cfg = rp.Config(sensor_height=1.8)
    cpp = rp.Estimator(cfg).process(points, 5.0, 0.0)
    ref = rp.reference.process(points, 5.0, 0.0, cfg)
    assert cpp.right.roughness.iso_class == ref.right.roughness.iso_class == "A"
    assert math.isfinite(cpp.right.roughness.gd_n0) and math.isfinite(ref.right.roughness.gd_n0)
