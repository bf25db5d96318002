# SPDX-License-Identifier: BSD-3-Clause
"""Beam offsets on real recordings (bench/beam_pattern.py): on the bundled OS-0-128 frame the road heights repeat
every fourth beam across the whole lane — the sensor's, not the road's — and on the OS1-128 recording they do not;
KITTI's beams keep their offsets from frame to frame while the road under them moves on; on a smooth simulated road
the error the strips share is the beams'."""

import sys

import numpy as np

import roadpreview as rp
from paths import OS1_128_HEIGHT, OS1_128_META, OS1_128_PCAP, OUSTER, REPO, run_bench

sys.path.insert(0, str(REPO / "bench"))
from beam_pattern import beam_residuals, chance_share, column_offsets_rad, drive_beam_angles, explained_by_index, \
    first_frame, frame_to_frame_correlations, shared_sigma_deg, simulated_shared_sigma_deg, \
    without_column_offsets  # noqa: E402


def test_the_share_explained_by_the_index_is_that_of_the_group_means():
    ids = np.arange(16)
    alternating = np.where(ids % 2 == 0, 1.0, -1.0)
    assert explained_by_index(ids, alternating, 2) == 1.0
    assert explained_by_index(ids, alternating, 4) == 1.0  # period 2 repeats with period 4 too
    assert explained_by_index(ids, alternating, 3) < 0.2
    ramp = ids - ids.mean()
    assert 0.0 < explained_by_index(ids, ramp, 4) < 0.1


def test_the_shared_error_is_the_beams_common_offset_not_the_strips_own_noise():
    rng = np.random.default_rng(1)
    ranges = rng.uniform(4.0, 15.0, 400)
    common = np.radians(0.05) * rng.standard_normal(400)  # the beams' elevation errors
    z = ranges[:, None] * (common[:, None] + np.radians(0.08) * rng.standard_normal((400, 3)))  # + each strip's own
    assert abs(shared_sigma_deg(ranges, z) - 0.05) < 0.006


def test_the_os0_128_frames_beams_are_offset_every_fourth_beam_across_the_lane():
    ids, ranges, z = beam_residuals(OUSTER / "OS-0-128-U1_v2.3.0_1024x10.pcap",
                                    OUSTER / "OS-0-128-U1_v2.3.0_1024x10.json", 1.97)
    assert len(ids) >= 20 and ranges.min() < 5 and ranges.max() > 12
    assert np.all(np.sqrt(np.mean(z**2, axis=0)) > 0.01)  # > 1 cm from beam to beam in every strip
    assert np.corrcoef(z.T)[np.triu_indices(3, 1)].min() > 0.75  # the same offsets at both wheels and between
    mean = z.mean(axis=1)
    assert explained_by_index(ids, mean, 4) > max(0.6, chance_share(ids, mean, 4, 0.99))
    assert 0.08 < shared_sigma_deg(ranges, z) < 0.14  # about 0.1° of elevation, the same across the lane


def test_the_os1_128_recordings_beams_show_no_such_pattern():
    ids, _, z = beam_residuals(OS1_128_PCAP, OS1_128_META, OS1_128_HEIGHT)
    assert len(ids) >= 30
    assert np.all(np.sqrt(np.mean(z**2, axis=0)) < 0.008)
    mean = z.mean(axis=1)
    assert explained_by_index(ids, mean, 4) < chance_share(ids, mean, 4, 0.99)


def test_beam_pattern_bench_prints_both_recordings():
    out = run_bench("beam_pattern.py")
    assert "| OS-0-128-U1_v2.3.0_1024x10.pcap | 27 |" in out and "| OS-1-128_v2.3.0_1024x10_lb_n3.pcap |" in out


def test_taking_out_column_offsets_lowers_each_point_by_its_range_times_its_columns_angle():
    points = np.array([[3.0, 4.0, -1.0], [6.0, 8.0, -1.5], [1.0, 0.0, 0.0]], np.float32)
    beams = np.array([1, 6, -1])  # columns 1 and 2; the last point's beam unknown: left as it is
    out = without_column_offsets(points, beams, np.array([0.0, 0.01, -0.02, 0.0]))
    np.testing.assert_allclose(out[:, 2], [-1.0 - 5.0 * 0.01, -1.5 + 10.0 * 0.02, 0.0], atol=1e-6)
    np.testing.assert_array_equal(out[:, :2], points[:, :2])


def test_the_os0_128_frame_reads_smoother_once_its_column_offsets_are_taken_out():
    pcap, meta = OUSTER / "OS-0-128-U1_v2.3.0_1024x10.pcap", OUSTER / "OS-0-128-U1_v2.3.0_1024x10.json"
    offsets = column_offsets_rad(*beam_residuals(pcap, meta, 1.97))
    assert np.degrees(np.ptp(offsets)) > 0.15  # the columns disagree by more than 0.15°
    frame = first_frame(pcap, meta)
    points = np.asarray(frame.points[:, :3], np.float32)

    def left_gd(pts):
        return rp.Estimator(rp.Config(sensor_height=1.97)).process(pts, 5.0, 0.0).left.roughness.gd_n0

    assert left_gd(without_column_offsets(points, np.asarray(frame.beams), offsets)) < 0.5 * left_gd(points)


def test_on_a_smooth_simulated_road_the_shared_error_is_the_beams():
    assert simulated_shared_sigma_deg("os1_128", "A", 0.0) < 0.01
    assert 0.02 < simulated_shared_sigma_deg("os1_128", "A", 0.03) < 0.045


def test_kittis_beams_keep_their_offsets_from_frame_to_frame_where_the_road_moves_on():
    angles = drive_beam_angles()["KITTI seq 00 frames 0–2"]
    assert angles.shape == (3, 30)
    assert np.all(frame_to_frame_correlations(angles) > 0.95)  # the rings 0.86 m further on: the beams', not the road's
    assert np.all(np.degrees(np.sqrt(np.mean(angles**2, axis=1))) > 0.05)


def test_frame_to_frame_correlations_pair_consecutive_frames():
    angles = np.array([[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [3.0, 2.0, 1.0]])
    np.testing.assert_allclose(frame_to_frame_correlations(angles), [1.0, -1.0])
