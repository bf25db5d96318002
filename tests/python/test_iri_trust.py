"""When an IRI or a vehicle class can be trusted (docs/method.md §4 "Vehicle", §6): the numpy reference on
known answers, and the C++ pipeline against it on real frames (tests/python/test_crosscheck.py)."""

import numpy as np
import pytest

import roadpreview as rp
from roadpreview.reference.iri import CLASS_DECLINED, TOO_SPARSE, iri, vehicle_iri, wheel_iri
from roadpreview.reference.roughness import Roughness, vehicle_from_wheels

DS = 0.1
Z = 0.01 * np.sin(0.3 * np.arange(200))  # 20 m


def counts(backed_every):
    return np.where(np.arange(200) % backed_every == 0, 3, 0)


def test_a_densely_backed_classified_wheel_has_its_iri():
    result = wheel_iri(Z, counts(1), DS, "C")
    assert result.value == pytest.approx(iri(Z, DS)) and result.backed_fraction == 1.0 and result.reason is None


def test_a_mostly_interpolated_stretch_gives_no_iri_but_says_how_much_was_backed():
    result = wheel_iri(Z, counts(5), DS, "C")
    assert result.value is None and result.reason == TOO_SPARSE
    assert result.backed_fraction == pytest.approx(40 / 200) and result.length == pytest.approx(19.9)
    assert wheel_iri(Z, counts(5), DS, "C", rp.Config(iri={"min_backed_fraction": 0.2})).value is not None
    assert wheel_iri(Z, counts(3), DS, "C").value is not None  # 67 of 200 bins backed


def test_a_declined_class_declines_the_iri():
    result = wheel_iri(Z, counts(1), DS, None)
    assert result.value is None and result.reason == CLASS_DECLINED
    mean = vehicle_iri(wheel_iri(Z, counts(1), DS, "C"), result)
    assert mean.value is None and mean.backed_fraction == 1.0


def classified(gd, confidence=0.8, band=(0.1, 2.0)):
    return Roughness(iso_class=rp.reference.roughness.iso_class(gd), gd_n0=gd, confidence=confidence, band=band)


def test_the_vehicle_is_declined_with_both_wheels_and_classified_with_both():
    declined = Roughness(reason="noise dominates the band")
    assert vehicle_from_wheels(classified(300e-6), declined, declined).reason == "both wheels declined"
    assert vehicle_from_wheels(classified(300e-6), declined, classified(1e-4)).iso_class == "C"  # its own fit
    assert vehicle_from_wheels(Roughness(reason="noise dominates the band"), declined, classified(1e-4)).reason == \
        "noise dominates the band"
    short = vehicle_from_wheels(Roughness(reason="valid stretch too short"), classified(200e-6, 0.8, (0.2, 2.0)),
                                classified(1000e-6, 0.6, (0.1, 4.0)))
    assert short.iso_class == "D" and short.gd_n0 == pytest.approx(600e-6) and short.band_limit == "wheels"
    assert short.confidence == 0.6 and short.band == (0.1, 4.0) and short.reason is None


@pytest.mark.parametrize("speed, yaw_rate", [(6.0, 0.0), (6.0, 0.15)])
def test_pipeline_results_never_contradict(speed, yaw_rate):
    from paths import KITTI_FRAMES, KITTI_SENSOR_HEIGHT

    est = rp.Estimator(rp.Config(sensor_height=KITTI_SENSOR_HEIGHT))
    for frame in KITTI_FRAMES:
        res = est.process(rp.io.read(frame), speed, yaw_rate)
        wheels = (res.left.roughness, res.right.roughness)
        if all(w.iso_class is not None for w in wheels):
            assert res.vehicle.iso_class is not None
        if all(w.iso_class is None for w in wheels):
            assert res.vehicle.iso_class is None
        for w in wheels:
            if w.iri.value is not None:
                assert w.iso_class is not None and w.iri.backed_fraction >= 0.25
        if res.vehicle.iri.value is not None:
            assert all(w.iso_class is not None for w in wheels) and res.vehicle.iso_class is not None
