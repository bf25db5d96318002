"""A LiDAR beam's elevation error, which all of its points share (docs/method.md §3, ``profile.beam_sigma_deg``):
counted, a bin's median is as uncertain as the beam's angle at the bin's distance and counts once per beam; not
counted (σ = 0, the default, or no beams), nothing changes."""

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import roadpreview as rp
from paths import OS1_128_HEIGHT, OS1_128_PCAP, run_cli
from test_crosscheck import assert_profiles_agree, assert_same_profiles

RINGS, ACROSS = 31, 301
Z_ATOL = 1e-8  # m; measured: heights ≤ 1.3e-9 m apart, spreads ≤ 2.5e-8 relative: rounding room, no more


def ringed_road(offsets_deg=None):
    """(points, beams): a flat road 1.7 m below the sensor seen by 31 rings 0.5 m apart from 5.05 to 20.05 m ahead,
    points 2 cm apart across it, heights off by up to 1 mm, each ring x·δθ higher for its beam's error δθ."""
    beam = np.repeat(np.arange(RINGS), ACROSS)
    x = 5.05 + 0.5 * beam
    offsets = np.zeros(RINGS) if offsets_deg is None else np.radians(offsets_deg)
    points = np.zeros((RINGS * ACROSS, 4), np.float32)
    points[:, 0] = x
    points[:, 1] = -3 + 0.02 * np.tile(np.arange(ACROSS), RINGS)
    points[:, 2] = -1.7 + 0.001 * np.sin(12.9898 * np.arange(len(points))) + x * offsets[beam]
    return points, beam.astype(np.int32)


def config(sigma_deg, **kw):
    return rp.Config(sensor_height=1.7, ground={"method": "pca"}, obstacles={"enabled": False},
                     profile={"beam_sigma_deg": sigma_deg}, **kw)


def test_beams_off_by_a_tenth_of_a_degree_read_a_flat_road_rough_unless_counted():
    points, beams = ringed_road(np.random.default_rng(0).uniform(-0.1, 0.1, RINGS))
    plain = rp.Estimator(config(0.0)).process(points, 5.0, 0.0, beams=beams)
    counted = rp.Estimator(config(0.05)).process(points, 5.0, 0.0, beams=beams)
    assert plain.left.roughness.iso_class >= "C"  # a flat road: the beams' steps read as relief
    assert counted.left.roughness.iso_class is None
    assert counted.left.roughness.reason == "noise dominates the band"
    np.testing.assert_array_equal(counted.left.z, plain.left.z)


@pytest.mark.parametrize("fusion", ["none", "kalman"])
def test_beam_errors_cpp_against_reference(fusion):
    points, beams = ringed_road(np.random.default_rng(1).uniform(-0.1, 0.1, RINGS))
    cfg = config(0.02, fusion={"method": fusion})
    est = rp.Estimator(cfg)
    if fusion == "none":
        cpp, ref = est.process(points, 5.0, 0.0, beams=beams), rp.reference.process(points, 5.0, 0.0, cfg, beams=beams)
        assert np.array_equal(cpp.ground_mask, ref.ground_mask)
        assert_profiles_agree(cpp, ref, ground_identical=True)
        assert_same_profiles(cpp, ref, z_atol=Z_ATOL)
        return
    state = rp.reference.FusedMap(cfg)
    for k in range(3):
        shifted = points.copy()
        shifted[:, 0] -= 0.5 * k  # the vehicle drives 0.5 m per frame
        cpp = est.process(shifted, 5.0, 0.0, timestamp=0.1 * k, beams=beams)
        ref = rp.reference.process_fused(state, shifted, 5.0, 0.0, timestamp=0.1 * k, beams=beams)
        assert_same_profiles(cpp, ref, z_atol=Z_ATOL)
        assert cpp.left.roughness.iso_class is not None  # a class (D) to compare, not only a reason


@pytest.mark.parametrize("fusion", ["none", "kalman"])
def test_each_beams_own_sigma_cpp_against_reference(fusion):
    """profile.beam_sigmas_deg: beams 0–19 with their own σ (some 0), the rest beam_sigma_deg, a tenth of the
    points of no known beam (−1): both implementations count the same errors and groups."""
    rng = np.random.default_rng(4)
    points, beams = ringed_road(rng.uniform(-0.1, 0.1, RINGS))
    beams[rng.random(len(beams)) < 0.1] = -1
    own = np.where(rng.random(20) < 0.3, 0.0, rng.uniform(0.005, 0.05, 20))
    cfg = rp.Config(sensor_height=1.7, ground={"method": "pca"}, obstacles={"enabled": False},
                    profile={"beam_sigma_deg": 0.01, "beam_sigmas_deg": own.tolist()}, fusion={"method": fusion})
    est, state = rp.Estimator(cfg), rp.reference.FusedMap(cfg)
    for k in range(3 if fusion == "kalman" else 1):
        shifted = points.copy()
        shifted[:, 0] -= 0.5 * k
        cpp = est.process(shifted, 5.0, 0.0, timestamp=0.1 * k, beams=beams)
        ref = (rp.reference.process_fused(state, shifted, 5.0, 0.0, timestamp=0.1 * k, beams=beams)
               if fusion == "kalman" else rp.reference.process(shifted, 5.0, 0.0, cfg, beams=beams))
        assert_same_profiles(cpp, ref, z_atol=Z_ATOL)
        assert cpp.vehicle.iso_class is not None  # a class (E) to compare, not only a reason


@settings(max_examples=15, deadline=None)
@given(st.floats(0.001, 0.2), st.integers(0, 2 ** 32 - 1))
def test_every_beam_listed_at_one_sigma_is_that_sigma_for_all(sigma, seed):
    points, beams = ringed_road(np.random.default_rng(seed).uniform(-0.1, 0.1, RINGS))
    common = rp.Estimator(config(sigma)).process(points, 5.0, 0.0, beams=beams).to_dict()
    listed = rp.Estimator(rp.Config(sensor_height=1.7, ground={"method": "pca"}, obstacles={"enabled": False},
                                    profile={"beam_sigmas_deg": [sigma] * RINGS})).process(
        points, 5.0, 0.0, beams=beams).to_dict()
    for line in (common, listed):
        line.pop("timing_ms")
    assert listed == common


@settings(max_examples=25, deadline=None)
@given(st.floats(0.0, 0.2), st.floats(0.0, 0.2), st.integers(0, 2 ** 32 - 1))
def test_more_beam_sigma_never_states_less_noise_and_moves_no_height(a, b, seed):
    lo, hi = sorted((a, b))
    points, beams = ringed_road(np.random.default_rng(seed).uniform(-0.1, 0.1, RINGS))
    beams = np.random.default_rng(seed).permutation(RINGS)[beams]  # beam numbers need not follow the rings
    low = rp.Estimator(config(lo)).process(points, 5.0, 0.0, beams=beams)
    high = rp.Estimator(config(hi)).process(points, 5.0, 0.0, beams=beams)
    for p, q in ((low.left, high.left), (low.right, high.right)):
        np.testing.assert_array_equal(p.z, q.z)
        backed = np.asarray(p.count) >= 1
        assert backed.sum() == 31
        assert (np.asarray(q.spread)[backed] >= np.asarray(p.spread)[backed] * (1 - 1e-6)).all()


def test_beams_change_nothing_while_their_sigma_is_zero():
    points, beams = ringed_road(np.random.default_rng(2).uniform(-0.1, 0.1, RINGS))
    cfg = config(0.0)
    without = rp.Estimator(cfg).process(points, 5.0, 0.0).to_dict()
    with_beams = rp.Estimator(cfg).process(points, 5.0, 0.0, beams=beams).to_dict()
    for line in (without, with_beams):
        line.pop("timing_ms")
    assert with_beams == without


def test_bad_beams_are_clear_errors():
    points, beams = ringed_road()
    est, cfg = rp.Estimator(config(0.05)), config(0.05)
    with pytest.raises(ValueError, match="beams must be a 1-D array with one entry per point"):
        est.process(points, 5.0, 0.0, beams=beams[:-1])
    with pytest.raises(ValueError, match="beams must have one entry per point"):
        rp.reference.process(points, 5.0, 0.0, cfg, beams=beams[:-1])
    with pytest.raises(TypeError, match="beams must be an integer array"):
        est.process(points, 5.0, 0.0, beams=beams.astype(float))
    with pytest.raises(ValueError, match="beams must fit in int32"):
        est.process(points, 5.0, 0.0, beams=beams.astype(np.int64) + 2 ** 31)
    for bad in (-0.1, float("nan"), 11.0):
        with pytest.raises(ValueError, match="profile.beam_sigma_deg must be"):
            rp.Estimator(config(bad))
    for bad in ([0.01, -0.1], [11.0]):
        with pytest.raises(ValueError, match=r"profile.beam_sigmas_deg\[\d\] must be in \[0, 10\]"):
            rp.Estimator(rp.Config(profile={"beam_sigmas_deg": bad}))
    with pytest.raises(ValueError, match="profile.beam_sigmas_deg may list at most 4096 beams, got 4097"):
        rp.Estimator(rp.Config(profile={"beam_sigmas_deg": [0.0] * 4097}))


def test_a_recordings_decoded_beams_are_counted_through_run_and_the_cli(tmp_path):
    """The OS1-128 recording's frames carry their decoder's beams: with σ = 0.02° (the beams' calibration state
    unknown to better than that), each frame's wheels decline where they read class C–D uncounted."""
    def classes(sigma):
        cfg = rp.Config(sensor_height=OS1_128_HEIGHT, profile={"beam_sigma_deg": sigma})
        return [(r.left.roughness.iso_class, r.left.roughness.reason) for r in rp.run(OS1_128_PCAP, cfg, speed=2.5)]
    plain, counted = classes(0.0), classes(0.02)
    assert len(plain) == len(counted) == 3
    assert all(c in "CD" for c, _ in plain)
    assert counted == [(None, "noise dominates the band")] * 3
    out = tmp_path / "out.jsonl"
    run_cli("run", OS1_128_PCAP, "--sensor-height", OS1_128_HEIGHT, "--speed", 2.5, "--beam-sigma-deg", 0.02,
            "-o", out)
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    assert [line["roughness"]["left"]["reason"] for line in lines] == ["noise dominates the band"] * 3
    bad = run_cli("run", OS1_128_PCAP, "--speed", 2.5, "--beam-sigma-deg", -1, check=False)
    assert bad.returncode != 0 and "--beam-sigma-deg" in bad.stderr


def test_frames_without_beams_say_their_beams_errors_are_not_counted():
    from paths import KITTI_FRAMES, KITTI_SENSOR_HEIGHT
    cfg = rp.Config(sensor_height=KITTI_SENSOR_HEIGHT, profile={"beam_sigma_deg": 0.02})
    drive = rp.run(KITTI_FRAMES[0], cfg, speed=5.0)
    with pytest.warns(RuntimeWarning, match="carry no beam numbers"):
        results = list(drive)
    assert results[0].left.roughness.iso_class is not None  # as if σ were 0: nothing to count it on
    assert sum("carry no beam numbers" in note for note in drive.notes) == 1
    proc = run_cli("run", *KITTI_FRAMES[:2], "--sensor-height", KITTI_SENSOR_HEIGHT, "--speed", 5,
                   "--beam-sigma-deg", 0.02, "-o", "/dev/null")
    assert proc.stderr.count("carry no beam numbers") == 1
