# SPDX-License-Identifier: BSD-3-Clause
"""Roadside perception: C++ stages against the numpy/scipy reference (labelling, L-shape, assignment, Kalman),
the simulated paper scenarios through the processor, real recordings (SICK dumps, the people bag), bad input."""

import json
import math
import subprocess
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import roadpreview as rp
from roadpreview.reference import roadside as ref
from roadpreview.sim import roadside as sr
from paths import DATA, SHARED_DATA, cli

SICK = SHARED_DATA / "laserscan2d" / "sick_scan_xd"
PEOPLE_BAG = SHARED_DATA / "laserscan2d" / "leg_tracker" / "demo_stationary_simple_environment.bag"
CARMEN_LOG = SHARED_DATA / "laserscan2d" / "carmen_freiburg_campus" / "freiburg-campus-corrected.log.gz"
CARMEN_SITE = DATA / "roadside" / "carmen_freiburg_campus_site.yaml"


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


def reference_track(scans, pose, confirm_hits, background_s, cycle_s=1 / sr.SCAN_HZ):
    """One object's track through the reference stages (§13.3–13.8): background, foreground points per cycle, one
    component, its centre (L-shape, or once moving the extent along the velocity grown to the learned extent and the
    class's smallest, away from the scanner), Kalman predict/update. Returns (t_end, x, y, speed) per cycle."""
    extent = {"car": (4.5, 1.8), "cyclist": (1.75, 0.5), "pedestrian": (0.0, 0.0)}  # class_extent_m
    half_turn = lambda a: (a - math.pi / 2) % -math.pi + math.pi / 2  # noqa: E731 — to (−π/2, π/2]: box axes
    t0 = scans[0]["time_s"]
    learn = [s for s in scans if s["time_s"] - t0 < background_s]
    bg = ref.background(np.array([s["ranges_m"] for s in learn], np.float64))
    cycles = {}
    for s in scans[len(learn):]:
        cycles.setdefault(math.floor((s["time_s"] - t0) / cycle_s), []).append(s)
    track, out = None, []

    def box(pts):  # §13.8's visible box: along the velocity once moving, else the L-shape's (axes as the track's)
        if track is None or track["hits"] < confirm_hits or math.hypot(*track["x"][2:]) <= 1.0:
            x, y, length, width, heading = ref.fit_l_shape(pts)
            if track is not None and track["hits"] > 0 and abs(half_turn(heading - track["heading"])) > math.pi / 4:
                length, width, heading = width, length, heading + math.pi / 2
            return np.array([x, y]), length, width, heading, False
        heading = math.atan2(track["x"][3], track["x"][2])
        u = np.array([math.cos(heading), math.sin(heading)])
        v = np.array([-u[1], u[0]])
        c1, c2 = pts @ u, pts @ v
        return (c1.min() + c1.max()) / 2 * u + (c2.min() + c2.max()) / 2 * v, np.ptp(c1), np.ptp(c2), heading, True

    for k in sorted(cycles):
        t_meas = np.mean([s["time_s"] for s in cycles[k]])
        pts = np.vstack([ref.scan_points(s["ranges_m"], s["start_angle_rad"], s["step_rad"], pose,
                                         ref.foreground(s["ranges_m"], bg)) for s in cycles[k]])
        labels, n = ref.label_points(pts) if len(pts) else (None, 0)
        comps = [pts[labels == i] for i in range(1, n + 1) if np.sum(labels == i) >= 2]
        assert len(comps) <= 1  # the pedestrian alone: no assignment to replay
        if track is not None and t_meas > track["t"]:
            track["x"], track["P"] = ref.kalman_predict(track["x"], track["P"], t_meas - track["t"])
            track["t"] = t_meas
        if comps:
            m = comps[0]
            l_shape = np.array(ref.fit_l_shape(m)[:2])
            sigma = 0.08 + 0.005 * math.hypot(*(l_shape - pose[:2]))  # position_sigma_m + sigma_per_range · range
            new = track is None
            if new:
                track = dict(t=t_meas, x=np.array([*l_shape, 0.0, 0.0]), P=np.diag([sigma ** 2] * 2 + [100.0] * 2),
                             hits=0, length=0.0, width=0.0, heading=0.0, corrected=False, offset=np.zeros(2))
            visible, length, width, heading, moving = box(m)
            z = visible
            if moving:  # grown to the learned extent (at least its class's), away from the scanner
                speed = math.hypot(*track["x"][2:])
                cls = ("car" if track["length"] >= 2.6 or track["width"] >= 1.4 else
                       "cyclist" if track["length"] >= 1.2 or speed > 2.5 else "pedestrian")
                u = np.array([math.cos(heading), math.sin(heading)])
                v, away = np.array([-u[1], u[0]]), visible - pose[:2]
                z = (visible + np.sign(away @ u or 1) * max(0.0, max(track["length"], extent[cls][0]) - length) / 2 * u
                     + np.sign(away @ v or 1) * max(0.0, max(track["width"], extent[cls][1]) - width) / 2 * v)
                if not track["corrected"]:  # the correction switches on: the state moves with it, once
                    track["x"][:2] += z - visible - track["offset"]
                    track["corrected"] = True
            track["offset"] = z - visible
            track["x"], track["P"] = ref.kalman_update(track["x"], track["P"], z, sigma)
            _, length, width, heading, _ = box(m)  # the learned extent, along the updated velocity
            track["length"], track["width"] = max(track["length"], length), max(track["width"], width)
            track["heading"] = half_turn(heading)
            track["hits"] += 1
            if new:
                track["x"][:2] = l_shape
        if track is not None:
            t_end = t0 + (k + 1) * cycle_s
            x = ref.kalman_predict(track["x"], track["P"], t_end - track["t"])[0] if t_end > track["t"] else track["x"]
            out.append((t_end, x[0], x[1], math.hypot(x[2], x[3])))
    return out


def test_kalman_track_matches_the_reference():
    """A single track fed the same centres: the C++ output equals the reference filter predicted to the cycle."""
    site = sr.site_yaml(sr.scanners()[:1], camera=False, processing="{confirm_hits: 1, background_s: 0.05}")
    proc = rp.roadside.Processor(site)
    sc = sr.scanners()[0]
    mover = sr.Mover("pedestrian", -4.5, -3.0, math.pi / 2, 1.4, 0.2, 5.0, 1)
    rng = np.random.default_rng(0)
    cycles, scans = [], []
    for k in range(60):
        t = k / sr.SCAN_HZ
        s = sr.scan(sc, k, t, [mover] if mover.present(t) else [], rng)
        s["scanner"] = 0
        scans.append(s)
        cycles += proc.push(s)
    cycles += proc.finish()
    tracked = [c for c in cycles if c["objects"]]
    assert len(tracked) >= 35  # from 0.2 s (the pedestrian appears) to 1.57 s
    assert {o["id"] for c in tracked for o in c["objects"]} == {1}
    last = tracked[-1]["objects"][0]
    truth = mover.at(tracked[-1]["t_s"])
    assert math.hypot(last["x_m"] - truth[0], last["y_m"] - truth[1]) < 0.1
    assert last["speed_mps"] == pytest.approx(1.4, abs=0.15)
    assert last["class"] == "pedestrian" and last["source"] == "laser"
    # The reference filter fed the same centres, cycle by cycle (the start-up transient too: 0 to 3.7 m/s).
    want = reference_track(scans, np.array([sc.x_m, sc.y_m, sc.yaw_rad]), confirm_hits=1, background_s=0.05)
    assert len(want) == len(tracked)
    for c, (t_end, x, y, speed) in zip(tracked, want):
        o = c["objects"][0]
        assert c["t_s"] == pytest.approx(t_end, abs=1e-6)
        # The output is rounded to mm (measured differences ≤ 5.0e-4 m, m/s): 1 mm, far below the 1.4 m/s and the
        # 0.1–0.7 m the track's start-up would be off by with the wrong centre (the class's extent left out).
        assert (o["x_m"], o["y_m"], o["speed_mps"]) == pytest.approx((x, y, speed), abs=1e-3), c["t_s"]


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


def test_each_cycles_scanner_status_counts_the_scans_up_to_its_end():
    """A cycle's `scanners` are as of its end: the scans it and the cycles before it used (once each counted the scan
    that closed it, of the next cycle: its `last_scan_s` lay up to a scan period after `t_s`)."""
    run = sr.simulate("two_cars_crossing", seed=3)
    cycles = rp.roadside.Processor(run.site_yaml).run(run.scans, run.detections)
    times = [np.array([s["time_s"] for s in run.scans if s["scanner"] == k]) for k in range(len(sr.scanners()))]
    assert len(cycles) > 100
    # Scanner 0 scans on the cycles' boundaries (a scan at a cycle's end opens the next one, up to rounding and t_s's
    # 1 µs), scanner 1 11 ms after them: the scan that closed a cycle came 11 ms after its end.
    for c in cycles:
        for k, status in enumerate(c["scanners"]):
            up_to_end = times[k][times[k] <= c["t_s"] + 1e-5]
            assert len(times[k][times[k] < c["t_s"] - 1e-5]) <= status["scans"] <= len(up_to_end), (c["t_s"], k)
            assert status["last_scan_s"] == pytest.approx(up_to_end[-1], abs=2e-5) or status["scans"] < len(up_to_end)
            assert status["last_scan_s"] <= c["t_s"] + 1e-5, (c["t_s"], k)


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
    # Every one of them is a person walking. Classed by the largest box a track had seen, 14 of 39 ended as cyclists
    # or cars; by what most of its updates' boxes say, none.
    last = {o["id"]: o["class"] for c in cycles for o in c["objects"] if o["id"] in movers}
    assert sum(cls == "pedestrian" for cls in last.values()) >= 0.95 * len(movers), last


def tracks_of(cycles: list[dict]) -> dict[int, list[tuple[float, dict]]]:
    out: dict[int, list[tuple[float, dict]]] = {}
    for c in cycles:
        for o in c["objects"]:
            out.setdefault(o["id"], []).append((c["t_s"], o))
    return out


def test_a_moving_scanner_tracks_the_pedestrian_it_passes():
    run = sr.simulate_moving_scanner(seed=1)
    tracks = tracks_of(rp.roadside.Processor(run.site_yaml).run(run.scans))
    assert len(tracks) == 1, sorted(tracks)  # the pedestrian, nothing of the buildings and poles driven past
    (track,) = tracks.values()
    seen = [(t, o, run.truth_at(t)) for t, o in track if run.truth_at(t)]  # then it coasts a little
    assert len(seen) >= 50
    for t, o, (truth,) in seen:
        assert math.hypot(o["x_m"] - truth["x_m"], o["y_m"] - truth["y_m"]) < 0.3, (t, o["x_m"], o["y_m"], truth)
    assert seen[-1][1]["speed_mps"] == pytest.approx(1.4, abs=0.15)


def test_world_background_matches_the_reference():
    run = sr.simulate_moving_scanner(seed=2, rate_hz=5.0)
    proc = rp.roadside.Processor(run.site_yaml)
    proc.learn_world(run.scans)
    grid = ref.world_background(run.scans, [s["pose"] for s in run.scans])
    returns = agree = walker = walker_flagged = 0
    for s in run.scans:
        ours = proc.world_foreground(s)
        theirs = ref.world_foreground(s, s["pose"], grid, max_hit_scans=20)  # 4 s at 5 Hz
        finite = np.isfinite(s["ranges_m"])
        returns += finite.sum()
        agree += (ours == theirs)[finite].sum()
        for truth in run.truth_at(s["time_s"]):
            xy = ref.scan_points(s["ranges_m"], s["start_angle_rad"], s["step_rad"], s["pose"])
            on = np.hypot(xy[:, 0] - truth["x_m"], xy[:, 1] - truth["y_m"]) < 0.3
            in_range = np.hypot(xy[:, 0] - s["pose"][0], xy[:, 1] - s["pose"][1]) <= 30.0
            walker += (on & in_range).sum()
            walker_flagged += ours[finite][on & in_range].sum()
    assert agree >= 0.999 * returns, (agree, returns)
    assert walker > 50 and walker_flagged >= 0.9 * walker, (walker, walker_flagged)


@settings(max_examples=8, deadline=None)
@given(st.floats(-20, 20), st.floats(-6, 6), st.floats(-math.pi, math.pi), st.floats(0.5, 3.0), st.integers(0, 99))
def test_a_static_world_has_no_foreground_whatever_the_drive(x0, y0, heading, speed, seed):
    """Buildings and poles seen from any straight drive through the intersection: nothing passed, nothing is
    foreground; and the counts do not depend on the order the scans are learned in."""
    rng = np.random.default_rng(seed)
    scans = []
    for k in range(60):
        x, y = x0 + speed * 0.2 * k * math.cos(heading), y0 + speed * 0.2 * k * math.sin(heading)
        if min(abs(x), abs(y)) > 7.5:
            break  # inside a building
        s = sr.scan(sr.Scanner(x, y, heading), k, 0.2 * k, [], rng)
        scans.append(dict(s, scanner=0, pose=(x, y, heading), source=f"drive#{k}"))
    assert len(scans) >= 2
    site = ("origin: {lat_deg: 0, lon_deg: 0}\nscanners: [{name: v, max_range_m: 80}]\n"
            "processing: {world: {min_free_scans: 3}}\n")
    ordered, shuffled = rp.roadside.Processor(site), rp.roadside.Processor(site)
    ordered.learn_world(scans)
    shuffled.learn_world([scans[i] for i in rng.permutation(len(scans))])
    for s in scans:
        flags = ordered.world_foreground(s)
        assert not flags.any(), (s["source"], np.flatnonzero(flags)[:10])
        assert (shuffled.world_foreground(s) == flags).all()


def test_scans_with_poses_need_a_world_background():
    run = sr.simulate_moving_scanner(seed=3, rate_hz=2.0)
    proc = rp.roadside.Processor(run.site_yaml)
    with pytest.raises(RuntimeError, match="vehicle#0.*carries a pose"):
        proc.push(run.scans[0])
    with pytest.raises(ValueError, match="none has one"):
        proc.learn_world([dict(s, pose=None) for s in run.scans])  # the Python side drops unposed scans
    with pytest.raises(RuntimeError, match="max_speed_mps must be"):
        rp.roadside.Processor(run.site_yaml.replace("confirm_hits: 3", "confirm_hits: 3, max_speed_mps: -1"))
    with pytest.raises(RuntimeError, match="processing.world: unknown key 'cell'"):
        rp.roadside.Processor(run.site_yaml.replace("confirm_hits: 3", "confirm_hits: 3, world: {cell: 0.2}"))


@pytest.mark.parametrize("field, value", [("step_rad", math.nan), ("step_rad", 0.0), ("step_rad", 1e300),
                                          ("start_angle_rad", math.inf), ("start_angle_rad", 100.0)])
def test_a_scan_with_angles_no_scanner_has_is_refused(field, value):
    """A NaN step once ended in "foreground spans nan × nan m", a step of 0 or 1e300 made objects."""
    run = sr.simulate("pedestrian_crossing", seed=4)
    with pytest.raises(RuntimeError, match="the scan's angles are no scanner's: 361 beams from"):
        rp.roadside.Processor(run.site_yaml).push(dict(run.scans[0], **{field: value}))


def test_a_track_the_scanners_no_longer_see_says_since_when():
    """A track coasts on its predicted motion for max_coast_s once the scanners lose it; it was reported like a
    measured one (the leg_tracker bag: 428 reports 5.6–15 m from a 5.6 m scanner)."""
    run = sr.simulate("pedestrian_crossing", seed=4)
    empty = {}  # per scanner: its first scan, before the pedestrian comes
    for scan in run.scans:
        empty.setdefault(scan["scanner"], scan["ranges_m"])
    lost_at = 8.0
    scans = [dict(s, ranges_m=empty[s["scanner"]]) if s["time_s"] >= lost_at else s for s in run.scans]
    cycles = rp.roadside.Processor(run.site_yaml).run(scans)
    seen = [(c["t_s"], o["since_measured_s"]) for c in cycles for o in c["objects"] if o["id"] > 0]
    measured = [since for t, since in seen if t < lost_at - 0.5]
    coasting = [(t, since) for t, since in seen if t > lost_at + 0.1]
    assert measured and np.median(measured) < 0.03 and max(measured) < 0.3  # measured in most cycles of 1/37.5 s
    assert coasting and all(since == pytest.approx(t - lost_at, abs=0.1) for t, since in coasting)
    assert max(since for _, since in coasting) > 0.5


def test_unreadable_bags_and_missing_site_files_are_named(tmp_path):
    """A PNG renamed .bag raised a bare UnicodeDecodeError, a truncated bag "Bag index looks damaged" without its
    path, and a site path with a colon in its name "expected a mapping" (it was taken for YAML text)."""
    pytest.importorskip("rosbags")
    png = tmp_path / "picture.bag"
    png.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(200))
    with pytest.raises(RuntimeError, match=r"picture\.bag: not a readable ROS bag or MCAP file"):
        rp.roadside.read_scans(png)
    cut = tmp_path / "cut.bag"
    cut.write_bytes(b"#ROSBAG V2.0\n" + bytes(100))
    with pytest.raises(RuntimeError, match=r"cut\.bag: not a readable ROS bag"):
        rp.roadside.read_scans(cut)
    with pytest.raises(FileNotFoundError, match=r"my:site\.yaml: no such site file"):
        rp.roadside.Processor(str(tmp_path / "my:site.yaml"))


def test_a_scanner_that_changes_its_layout_is_refused():
    """The per-beam background is learned beam by beam: a later scan with another step or first beam looked
    elsewhere and was classified against it, silently (unless the site file pinned the layout)."""
    run = sr.simulate("pedestrian_crossing", seed=4)
    site = "\n".join(line.split(", max_range_m")[0] + "}" if "name: s" in line else line
                     for line in run.site_yaml.splitlines())  # no layout pinned in the site file
    proc = rp.roadside.Processor(site)
    first = next(s for s in run.scans if s["scanner"] == 0)
    proc.push(first)
    with pytest.raises(RuntimeError, match=r"the scanner 's1' changed its layout to 361 beams from -90° every 0\.25° "
                                           r"from 361 beams from -90° every 0\.5° of its first scan"):
        proc.push(dict(first, time_s=first["time_s"] + 0.1, step_rad=math.radians(0.25)))


@pytest.mark.skipif(not CARMEN_LOG.exists(), reason="shared data absent")
def test_carmen_log_gives_moving_objects_against_its_world_background():
    """The robot drives 1.75 km over the campus: what moved is what its log saw only briefly where it mostly saw
    open ground. Its scans carry no times; the site file's rate (0.8 Hz) is an upper bound from the log's PARAMs."""
    scans = rp.roadside.read_scans(CARMEN_LOG, scanner=0, rate_hz=0.8)
    proc = rp.roadside.Processor(CARMEN_SITE)
    proc.learn_world(scans)
    fg = sum(int(proc.world_foreground(s).sum()) for s in scans)
    near = sum(int((s["ranges_m"] <= 30.0).sum()) for s in scans)
    assert 0.002 * near < fg < 0.03 * near, (fg, near)  # walls, trees and hedges are background
    cycles = rp.roadside.Processor(CARMEN_SITE).run(scans)
    # Every reading that gave no point is counted, the log's maximum-range no-returns too (they counted 0 before).
    no_point = sum(int((~(s["ranges_m"] > 0) | (s["ranges_m"] >= 80.99)).sum()) for s in scans)
    assert cycles[-1]["scanners"][0]["invalid_ranges"] == no_point > 0.2 * sum(s["ranges_m"].size for s in scans)
    tracks = tracks_of(cycles)
    moving = [v for v in tracks.values()
              if len(v) >= 4 and math.hypot(v[-1][1]["x_m"] - v[0][1]["x_m"], v[-1][1]["y_m"] - v[0][1]["y_m"]) >= 2.0]
    assert 20 <= len(moving) <= 200, len(moving)
    pace = np.median([np.median([o["speed_mps"] for _, o in v]) for v in moving])
    assert 0.5 < pace < 3.0, pace  # people walking, at the assumed scan rate
    # The CLI learns the same world background by itself and writes the same cycles.
    done = subprocess.run([cli(), "roadside", "run", "--site", str(CARMEN_SITE), "--scan-rate", "0.8", str(CARMEN_LOG)],
                          capture_output=True, text=True, check=True)
    assert "world background from the scans with poses" in done.stderr
    untimed = lambda cs: [{k: v for k, v in c.items() if k != "process_ms"} for c in cs]  # noqa: E731
    assert untimed(json.loads(line) for line in done.stdout.splitlines()) == untimed(cycles)


@pytest.mark.parametrize("beams, step_deg", [(181, 1.0), (180, 1.0), (361, 0.5), (360, 0.5), (401, 0.25), (91, 2.0)])
def test_a_carmen_log_without_its_resolution_takes_carmen_s_step(tmp_path, beams, step_deg):
    """Without `laser_front_laser_resolution`, the step CARMEN assumes for so many beams (a 181-beam scan once read
    180°/181 = 0.9945°, its last beam 1° short of +90°)."""
    log = tmp_path / "scan.log"
    log.write_text("FLASER %d %s 0 0 0 0 0 0 10.0 host 10.0\n" % (beams, " ".join(["5.0"] * beams)))
    (scan,) = rp.roadside.read_scans(log)
    assert math.degrees(scan["start_angle_rad"]) == pytest.approx(-90.0)
    assert math.degrees(scan["step_rad"]) == pytest.approx(step_deg, rel=1e-12)


def test_a_carmen_log_without_times_says_at_what_rate_it_was_timed(tmp_path):
    log = tmp_path / "untimed.log"
    line = "FLASER 3 1.0 2.0 3.0 0 0 0 0 0 0 {t} host {t}\n"
    log.write_text(line.format(t=0) * 2)
    with pytest.warns(UserWarning, match=r"untimed\.log: the log's timestamps are all 0; .* 37\.5 Hz"):
        scans = rp.roadside.read_scans(log)
    assert [s["time_s"] for s in scans] == pytest.approx([0.0, 1 / 37.5])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a rate given, or times in the log: nothing to say
        assert [s["time_s"] for s in rp.roadside.read_scans(log, rate_hz=5.0)] == pytest.approx([0.0, 0.2])
        log.write_text(line.format(t=10.0) + line.format(t=10.5))
        assert [s["time_s"] for s in rp.roadside.read_scans(log)] == pytest.approx([10.0, 10.5])
