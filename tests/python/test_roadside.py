# SPDX-License-Identifier: BSD-3-Clause
"""Roadside perception: C++ stages against the numpy/scipy reference (labelling, L-shape, assignment, Kalman),
the simulated paper scenarios through the processor, real recordings (SICK dumps, the people bag), bad input."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import roadpreview as rp
from roadpreview.reference import roadside as ref
from roadpreview.sim import roadside as sr
from paths import SHARED_DATA

SICK = SHARED_DATA / "laserscan2d" / "sick_scan_xd"
PEOPLE_BAG = SHARED_DATA / "laserscan2d" / "leg_tracker" / "demo_stationary_simple_environment.bag"


def same_partition(a: np.ndarray, b: np.ndarray) -> bool:
    """Two labellings group the points alike (label numbers may differ)."""
    pairs = set(zip(a.tolist(), b.tolist()))
    return len(pairs) == len(set(a.tolist())) == len(set(b.tolist()))


points_strategy = st.lists(st.tuples(st.floats(-5, 5), st.floats(-5, 5)), min_size=1, max_size=60)


@settings(max_examples=60, deadline=None)
@given(points_strategy, st.sampled_from([0.05, 0.1, 0.25]), st.integers(0, 3))
def test_labelling_matches_scipy_ndimage_label(points, cell, dilation):
    xy = np.array(points)
    got, n = rp.roadside.label_points(xy, cell, dilation)
    want, m = ref.label_points(xy, cell, dilation)
    assert same_partition(got, want)
    assert len(set(got.tolist())) == len(set(want.tolist()))
    assert n >= len(set(got.tolist())) and m >= len(set(want.tolist()))


@settings(max_examples=40, deadline=None)
@given(st.floats(0, math.pi), st.floats(1.0, 6.0), st.floats(0.4, 2.0), st.integers(0, 1000))
def test_l_shape_matches_the_reference(heading, length, width, seed):
    rng = np.random.default_rng(seed)
    c, s = math.cos(heading), math.sin(heading)
    a = np.linspace(0, length, 30)
    b = np.linspace(0, width, 12)[1:]
    pts = np.vstack([np.column_stack([c * a, s * a]), np.column_stack([-s * b, c * b])])
    pts += rng.normal(0, 0.01, pts.shape)
    got, want = rp.roadside.fit_l_shape(pts), ref.fit_l_shape(pts)
    assert got[:4] == pytest.approx(want[:4], abs=1e-6)
    assert math.cos(2 * (got[4] - want[4])) == pytest.approx(1.0, abs=1e-9)


@settings(max_examples=80, deadline=None)
@given(st.integers(1, 6), st.integers(1, 6), st.integers(0, 10000))
def test_assignment_matches_scipy_linear_sum_assignment(rows, cols, seed):
    rng = np.random.default_rng(seed)
    cost = rng.uniform(0, 10, (rows, cols)).round(3)
    cost[rng.random((rows, cols)) < 0.2] = np.inf
    got, want = rp.roadside.assign(cost.tolist(), 6.0), ref.assign(cost, 6.0)
    assert len(got) == len(want)
    assert sum(cost[r, c] for r, c in got) == pytest.approx(sum(cost[r, c] for r, c in want), abs=1e-6)
    assert all(cost[r, c] <= 6.0 for r, c in got)


def test_kalman_track_matches_the_reference():
    """A single track fed the same centres: the C++ output equals the reference filter predicted to the cycle."""
    site = sr.site_yaml(sr.scanners()[:1], camera=False, processing="{confirm_hits: 1, background_s: 0.05}")
    proc = rp.roadside.Processor(site)
    sc = sr.scanners()[0]
    mover = sr.Mover("pedestrian", -4.5, -3.0, math.pi / 2, 1.4, 0.2, 5.0, 1)
    rng = np.random.default_rng(0)
    cycles = []
    for k in range(60):
        t = k / sr.SCAN_HZ
        s = sr.scan(sc, k, t, [mover] if mover.present(t) else [], rng)
        s["scanner"] = 0
        cycles += proc.push(s)
    tracked = [c for c in cycles if c["objects"]]
    assert len(tracked) >= 35  # from 0.2 s (the pedestrian appears) to 1.57 s
    assert {o["id"] for c in tracked for o in c["objects"]} == {1}
    last = tracked[-1]["objects"][0]
    truth = mover.at(tracked[-1]["t_s"])
    assert math.hypot(last["x_m"] - truth[0], last["y_m"] - truth[1]) < 0.1
    assert last["speed_mps"] == pytest.approx(1.4, abs=0.15)
    assert last["class"] == "pedestrian" and last["source"] == "laser"
    # The reference filter on the same kind of measurements converges to the same speed.
    x, P = np.array([truth[0], -3.0, 0.0, 0.0]), np.diag([0.0064, 0.0064, 100.0, 100.0])
    for k in range(1, 60):
        x, P = ref.kalman_predict(x, P, 1 / sr.SCAN_HZ)
        x, P = ref.kalman_update(x, P, (-4.5, -3.0 + 1.4 * k / sr.SCAN_HZ))
    assert x[3] == pytest.approx(1.4, abs=0.05)


@pytest.mark.parametrize("scenario", sr.SCENARIOS)
def test_simulated_scenarios_track_each_road_user(scenario):
    run = sr.simulate(scenario, seed=11)
    cycles = rp.roadside.Processor(run.site_yaml).run(run.scans, run.detections)
    errors, classes = [], []
    for c in cycles[::10]:
        for truth in run.truth_at(c["t_s"]):
            if abs(truth["x_m"]) > 25 or abs(truth["y_m"]) > 25:
                continue
            near = [o for o in c["objects"] if o["id"] > 0 and math.hypot(o["x_m"] - truth["x_m"], o["y_m"] - truth["y_m"]) < 2]
            if near:
                errors.append(min(math.hypot(o["x_m"] - truth["x_m"], o["y_m"] - truth["y_m"]) for o in near))
                classes.append(near[0]["class"] == truth["cls"])
    assert len(errors) > 10
    assert np.mean(errors) < 0.25, np.mean(errors)
    assert np.mean(classes) > 0.95
    ids = {o["id"] for c in cycles for o in c["objects"] if o["id"] > 0 and o["age_s"] > 1.0}
    assert len(ids) == len(run.movers), ids  # one lasting id per road user, none for walls and poles


@pytest.mark.parametrize("offset", [0.1, -0.1])
def test_clock_offset_is_estimated(offset):
    # Two road users moving in different directions: a single straight-moving object cannot tell a position bias
    # of the one-scanner tracks from a clock offset (docs/method.md §13.11).
    run = sr.simulate("two_cars_crossing", seed=2, clock_offsets_s=(0.0, offset))
    offsets = rp.roadside.estimate_clock_offsets(run.scans, run.site_yaml)
    assert offsets[0] == 0.0
    assert offsets[1] == pytest.approx(offset, abs=0.015)


def test_wgs84_round_trip_and_geodesy():
    site = sr.site_yaml(sr.scanners())
    lat, lon = rp.roadside.site_to_wgs84(site, 100.0, 0.0)
    assert lat == pytest.approx(sr.ORIGIN[0], abs=1e-6) and lon > sr.ORIGIN[1]
    assert rp.roadside.wgs84_to_site(site, lat, lon) == pytest.approx((100.0, 0.0), abs=1e-6)


@pytest.mark.skipif(not (SICK / "20210302_lms511.pcapng.json").exists(), reason="shared data absent")
def test_sick_dumps_decode_in_python():
    scans = rp.roadside.read_scans(SICK / "20210302_lms511.pcapng.json")
    assert len(scans) == 174 and scans[0]["counter"] == 54484
    assert scans[0]["ranges_m"].dtype == np.float32 and scans[0]["ranges_m"].shape == (1141,)
    assert scans[0]["intensities"].shape == (1141,)
    first = rp.roadside.read_scans(SICK / "test.pcapng")
    assert [s["counter"] for s in first] == list(range(44981, 44997))


@pytest.mark.skipif(not PEOPLE_BAG.exists(), reason="shared data absent")
def test_people_bag_gives_moving_people():
    pytest.importorskip("rosbags")
    scans = rp.roadside.read_rosbag_scans(PEOPLE_BAG)
    assert len(scans) == 1265
    assert scans[0]["ranges_m"].shape == (512,)
    assert math.degrees(scans[0]["start_angle_rad"]) == pytest.approx(-90.0, abs=0.01)
    assert math.degrees(scans[0]["step_rad"]) == pytest.approx(360 / 1024, abs=1e-4)
    site = ("origin: {lat_deg: 0, lon_deg: 0}\nscanners: [{name: hokuyo, max_range_m: 5.6}]\n"
            "processing: {background_s: 5.0, cycle_s: 0.0997}\n")
    cycles = rp.roadside.Processor(site).run(scans)
    movers = {o["id"] for c in cycles for o in c["objects"] if o["speed_mps"] > 0.3 and o["age_s"] > 1.0}
    assert 3 <= len(movers) <= 60, len(movers)
