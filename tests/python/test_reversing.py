# SPDX-License-Identifier: BSD-3-Clause
"""Reversing looks behind the vehicle: the region of interest is mirrored (docs/method.md §1), in the C++ core
and the numpy reference alike."""

import numpy as np
import pytest

import roadpreview as rp
from paths import KITTI_FRAMES, KITTI_SENSOR_HEIGHT

IMPLEMENTATIONS = {
    "cpp": lambda points, speed, yaw_rate, cfg: rp.Estimator(cfg).process(points, speed, yaw_rate),
    "reference": rp.reference.process,
}


@pytest.fixture(scope="module")
def frame():
    return rp.io.read(KITTI_FRAMES[0])


def mirrored(points):
    """The scene seen with the vehicle turned round in place: x → −x, y → −y (a rotation by π about z)."""
    out = np.array(points, copy=True)
    out[:, :2] *= -1
    return out


@pytest.mark.parametrize("impl", IMPLEMENTATIONS)
@pytest.mark.parametrize("yaw_rate", [0.0, 0.05])
def test_reversing_through_a_turned_scene_reads_the_forward_profiles(frame, impl, yaw_rate):
    cfg = rp.Config(sensor_height=KITTI_SENSOR_HEIGHT)
    run = IMPLEMENTATIONS[impl]
    forward = run(frame, 5.0, yaw_rate, cfg)
    backward = run(mirrored(frame), -5.0, yaw_rate, cfg)  # same ICR: y_icr = V/ω turns with the scene
    assert forward.reason is None and backward.reason is None
    assert forward.points["roi"] == backward.points["roi"] > 0
    np.testing.assert_array_equal(forward.ground_mask, backward.ground_mask)
    # the wheels swap sides when the vehicle turns round
    for fwd, bwd in ((forward.left, backward.right), (forward.right, backward.left)):
        np.testing.assert_array_equal(fwd.count, bwd.count)
        np.testing.assert_allclose(fwd.z, bwd.z, atol=1e-5, equal_nan=True)
        assert fwd.roughness.iso_class == bwd.roughness.iso_class
    assert backward.vehicle.iso_class is not None


@pytest.mark.parametrize("impl", IMPLEMENTATIONS)
def test_stopped_keeps_the_front_region(frame, impl):
    cfg = rp.Config(sensor_height=KITTI_SENSOR_HEIGHT)
    stopped = IMPLEMENTATIONS[impl](frame, 0.0, 0.0, cfg)
    forward = IMPLEMENTATIONS[impl](frame, 5.0, 0.0, cfg)
    assert stopped.reason == "vehicle stopped"
    assert stopped.points["roi"] == forward.points["roi"]
