# SPDX-License-Identifier: BSD-3-Clause
"""Route outputs: `roadpreview run --segments L1,L2 --export-profile DIR` stitches the frames' profiles along the
drive (C++ RouteBuilder) — checked against the numpy reference fed the same run's output lines, against a
known road, and by reading the ERD file back with an independent reader."""

import csv
import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

import roadpreview as rp
from roadpreview.reference.runs import true_runs
from paths import KITTI_FRAMES, KITTI_SENSOR_HEIGHT, OS1_128_HEIGHT, OS1_128_PCAP, OUSTER
from paths import run_cli as run

POSES = OUSTER / "OS-1-128_v2.3.0_1024x10_lb_n3_poses_kitti.txt"
KITTI_SPEED = 8.6  # m/s: seq 00 moves 0.86 m per 0.1 s frame at its start (its poses)


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def number(text):
    return float(text) if text != "" else np.nan


def read_erd(path):
    """A small ERD text reader written from the format's description: ERDFILEV2.00, the format line (channels,
    samples, ..., sample interval at the 6th place), keyword lines up to END, then the numbers."""
    lines = path.read_text().splitlines()
    assert lines[0].strip() == "ERDFILEV2.00"
    fields = [f.strip() for f in lines[1].split(",") if f.strip()]
    channels, samples, interval = int(fields[0]), int(fields[1]), float(fields[5])
    end = next(i for i, line in enumerate(lines) if line.strip() == "END")
    keywords = {line[:8].strip(): line[8:].strip() for line in lines[2:end]}
    values = np.array([float(v) for line in lines[end + 1:] for v in line.split()])
    assert values.size == channels * samples
    return keywords, interval, values.reshape(samples, channels)


@pytest.fixture(scope="module")
def kitti_route(tmp_path_factory):
    out = tmp_path_factory.mktemp("route")
    proc = run("run", *KITTI_FRAMES[:3], "--speed", KITTI_SPEED, "--frame-rate", 10, "--sensor-height",
               KITTI_SENSOR_HEIGHT, "--segments", "10,100", "--export-profile", out / "profiles", "-o",
               out / "run.jsonl")
    return out, proc


def test_segments_csv_has_a_row_per_segment_with_the_documented_columns(kitti_route):
    out, proc = kitti_route
    rows = read_csv(out / "run.segments.csv")
    assert "segment rows" in proc.stderr
    tens = [r for r in rows if r["segment_length_m"] == "10"]
    hundreds = [r for r in rows if r["segment_length_m"] == "100"]
    assert len(hundreds) == 1 and number(hundreds[0]["end_m"]) > 35  # 2 × 0.86 m driven + up to 40 m ahead
    assert len(tens) == math.ceil(number(hundreds[0]["end_m"]) / 10)
    assert number(tens[-1]["end_m"]) == number(hundreds[0]["end_m"])  # the last segment ends short
    assert [number(r["start_m"]) for r in tens] == [10.0 * k for k in range(len(tens))]
    for side in ("left", "right", "vehicle"):
        for key in ("class", "gd_n0_m3", "iri_m_per_km", "backed_fraction", "class_reason", "iri_reason"):
            assert f"{key}_{side}" in rows[0]
    classified = [r for r in tens if r["class_vehicle"]]
    assert classified and all(r["class_vehicle"] in "ABCDEFGH" for r in classified)
    # The vehicle as a frame's (method §4): declined exactly when both wheels are, then for that reason.
    declined = [r for r in rows if not r["class_left"] and not r["class_right"]]
    assert declined and all(r["class_reason_vehicle"] == "both wheels declined" for r in declined)
    assert all(r["class_vehicle"] for r in rows if r["class_left"] and r["class_right"])
    assert all(r["x_start_m"] == "" for r in rows)  # no poses given
    assert any(number(r["iri_m_per_km_left"]) > 0 for r in tens)  # IRI of 10 m segments, from the whole stretch


def test_route_matches_the_numpy_reference_on_the_same_run(kitti_route):
    out, _ = kitti_route
    cfg = rp.Config(sensor_height=KITTI_SENSOR_HEIGHT)
    route = rp.reference.Route(cfg)
    for line in (json.loads(t) for t in (out / "run.jsonl").read_text().splitlines()):
        route.add(line)
    for wheel in ("left", "right"):
        ref = route.stitched(wheel)
        rows = read_csv(out / "profiles" / f"{wheel}.csv")
        assert len(rows) == len(ref.z)
        np.testing.assert_allclose([number(r["z_m"]) for r in rows], ref.z, atol=1e-5, equal_nan=True)
        np.testing.assert_array_equal([int(r["count"]) for r in rows], ref.count)
        np.testing.assert_array_equal([int(r["frames"]) for r in rows], ref.frames)
        np.testing.assert_array_equal([r["blocked"] == "1" for r in rows], ref.blocked)
    rows = read_csv(out / "run.segments.csv")
    expected = route.segments(10.0) + route.segments(100.0)
    assert len(rows) == len(expected)
    for row, seg in zip(rows, expected):
        assert number(row["start_m"]) == pytest.approx(seg["start_m"])
        assert number(row["end_m"]) == pytest.approx(seg["end_m"])
        for side in ("left", "right", "vehicle"):
            rough, iri = seg[side]["roughness"], seg[side]["iri"]
            assert (row[f"class_{side}"] or None) == rough.iso_class
            if rough.iso_class:
                assert number(row[f"gd_n0_m3_{side}"]) == pytest.approx(rough.gd_n0, rel=1e-4)
            assert number(row[f"iri_m_per_km_{side}"]) == pytest.approx(iri.value if iri.value is not None else np.nan,
                                                                        abs=1e-3, nan_ok=True)
            assert number(row[f"backed_fraction_{side}"]) == pytest.approx(seg[side]["backed_fraction"], abs=1e-4)
            assert number(row[f"iri_noise_m_per_km_{side}"]) == pytest.approx(
                iri.noise if iri.noise is not None else np.nan, rel=1e-3, abs=1e-3, nan_ok=True)
            assert (iri.noise is None) == (iri.value is None)  # a segment with an IRI states its errors' share


def test_erd_export_reads_back_as_the_stitched_profile(kitti_route):
    out, _ = kitti_route
    for wheel in ("left", "right"):
        keywords, interval, values = read_erd(out / "profiles" / f"{wheel}.erd")
        assert interval == pytest.approx(0.1)
        assert keywords["UNITSNAM"] == "mm" and keywords["XUNITS"] == "m" and keywords["SHORTNAM"] == wheel
        z = np.array([number(r["z_m"]) for r in read_csv(out / "profiles" / f"{wheel}.csv")])
        first, last = rp.reference.longest_valid_stretch(z)
        np.testing.assert_allclose(values[:, 0], z[first:last] * 1000, atol=6e-3)  # mm, written to 1 µm
        assert f"{(first + 0.5) * 0.1:.2f} m along the drive" in keywords["TITLE"]


def test_the_erd_title_names_the_input_even_a_folder_given_with_a_slash(kitti_route, tmp_path):
    out, _ = kitti_route
    assert read_erd(out / "profiles" / "left.erd")[0]["TITLE"].startswith(f"roadpreview {Path(KITTI_FRAMES[0]).name}: ")
    drive = tmp_path / "drive"
    drive.mkdir()
    for frame in KITTI_FRAMES[:2]:
        shutil.copy(frame, drive)
    run("run", f"{drive}/", "--speed", KITTI_SPEED, "--frame-rate", 10, "--sensor-height", KITTI_SENSOR_HEIGHT,
        "--export-profile", tmp_path / "profiles", "-o", tmp_path / "run.jsonl")
    title = read_erd(tmp_path / "profiles" / "left.erd")[0]["TITLE"]
    assert title.startswith("roadpreview drive: ")  # was "roadpreview : "


def test_a_known_road_is_stitched_whole_whatever_each_frame_s_offset():
    """Frames 1 m apart each see 30 m of a sinusoidal road, each with its own height offset (its own ground
    plane): the stitched profile is the road plus the first frame's offset."""
    cfg = rp.Config()
    ds, road = 0.1, (lambda d: 0.01 * np.sin(2 * np.pi * d / 7.0))
    route = rp.reference.Route(cfg)
    offsets = [0.02, -0.03, 0.05, 0.0, 0.01]
    for f, offset in enumerate(offsets):
        s = (np.arange(300) + 0.5) * ds
        line = {"timestamp": f * 0.1, "motion": {"speed": 10.0}, "path": None, "reason": None,
                "profiles": {w: {"s": s.tolist(), "z": (road(f + s) + offset).tolist(), "count": [3] * 300,
                                 "spread": [0.0] * 300} for w in ("left", "right")}}
        route.add(line)
    stitched = route.stitched("left")
    centres = (np.arange(len(stitched.z)) + 0.5) * ds
    assert route.distance == pytest.approx(4.0)
    np.testing.assert_allclose(stitched.z, road(centres) + offsets[0], atol=1e-12)
    assert stitched.frames[0] == 1 and stitched.frames[45] == 5


def test_no_gap_is_filled_across_an_obstacle_a_frame_saw_unless_another_saw_road_there():
    """A frame's blocked bins (an obstacle in the wheel's path) stay missing in the stitched profile, as in the
    frame's own: a 0.9 m gap holding one is not interpolated (it was, up to 0.17 m over a kerb-high obstacle on
    KITTI seq 00), unless another frame saw road there (the obstacle moved on)."""
    cfg = rp.Config()
    ds = 0.1
    s = (np.arange(300) + 0.5) * ds

    def line(f, blocked_bins=range(0)):
        z = 0.01 * np.sin(2 * np.pi * (f + s) / 7.0)
        count = np.full(300, 3)
        blocked = np.zeros(300, dtype=bool)
        if blocked_bins:
            z[blocked_bins.start - 2:blocked_bins.stop + 2] = np.nan
            count[blocked_bins.start - 2:blocked_bins.stop + 2] = 0
            blocked[blocked_bins] = True
        profile = {"s": s.tolist(), "z": [None if np.isnan(v) else v for v in z], "count": count.tolist(),
                   "spread": [0.0] * 300, "blocked": blocked.tolist()}
        return {"timestamp": f * 0.1, "motion": {"speed": 10.0}, "path": None, "reason": None,
                "profiles": {"left": profile, "right": profile}}

    for blocked_bins in (range(0), range(100, 105)):  # without an obstacle the same 0.9 m gap is filled
        route = rp.reference.Route(cfg)
        route.add(line(0, blocked_bins))
        stitched = route.stitched("left")
        assert np.isnan(stitched.z[98:107]).all() == bool(blocked_bins)
        assert list(np.flatnonzero(stitched.blocked)) == list(blocked_bins)
    route.add(line(1))  # 1 m further on, road over the whole stretch
    assert np.isfinite(route.stitched("left").z[98:107]).all() and not route.stitched("left").blocked.any()


def test_a_kitti_route_leaves_the_obstacles_in_its_wheel_paths_unfilled(tmp_path):
    """Three KITTI frames on a curve whose wheel paths meet parked cars and kerbs: every bin the reference marks
    blocked is missing in the exported profile (27 of them were interpolated before), and none is filled in a
    run of empty bins that holds one."""
    proc = run("run", *KITTI_FRAMES[:3], "--speed", KITTI_SPEED, "--yaw-rate", -0.08, "--frame-rate", 10,
               "--sensor-height", KITTI_SENSOR_HEIGHT, "--export-profile", tmp_path / "profiles", "-q", "-o",
               tmp_path / "run.jsonl")
    assert proc.returncode == 0, proc.stderr
    route = rp.reference.Route(rp.Config(sensor_height=KITTI_SENSOR_HEIGHT))
    for text in (tmp_path / "run.jsonl").read_text().splitlines():
        route.add(json.loads(text))
    blocked_bins = 0
    for wheel in ("left", "right"):
        rows = read_csv(tmp_path / "profiles" / f"{wheel}.csv")
        blocked = np.array([r["blocked"] == "1" for r in rows])
        np.testing.assert_array_equal(blocked, route.stitched(wheel).blocked)
        assert all(r["z_m"] == "" for r, b in zip(rows, blocked) if b)
        empty = np.array([r["count"] == "0" for r in rows])
        for start, stop in true_runs(empty):
            if blocked[start:stop].any():
                assert not any(r["filled"] == "1" for r in rows[start:stop])
        blocked_bins += int(blocked.sum())
    assert blocked_bins >= 20


def test_poses_give_the_segments_their_place(tmp_path):
    run("run", OS1_128_PCAP, "--speed", 2.5, "--sensor-height", OS1_128_HEIGHT, "--fusion", "kalman", "--poses", POSES,
        "--segments", 0.2, "--segments-csv", tmp_path / "seg.csv", "-q", "-o", tmp_path / "out.jsonl")
    rows = read_csv(tmp_path / "seg.csv")
    # The drive's three frames span x 0 … 0.498 m (0.245 + 0.253): a segment's ends are placed where it passed them,
    # and left empty ahead of its last frame, where it never was (they once repeated the last pose).
    assert number(rows[0]["x_start_m"]) == pytest.approx(0.0, abs=1e-6)
    assert [number(r["x_end_m"]) for r in rows[:2]] == pytest.approx([0.2, 0.4], abs=0.01)
    assert rows[2]["x_start_m"] != "" and all(r["x_end_m"] == r["y_end_m"] == "" for r in rows[2:])
    assert all(r["x_start_m"] == "" for r in rows[3:])


def test_route_errors_name_the_problem(tmp_path):
    proc = run("run", KITTI_FRAMES[0], "--speed", 5, "--sensor-height", KITTI_SENSOR_HEIGHT, "--segments", "0,10",
               check=False)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr == "--segments: expected a number > 0, got 0\nRun with --help for more information.\n"
    # Shorter than a bin: once 61 MB of rows for 40 m of road, and on. A usage error, said before the input is read.
    proc = run("run", tmp_path / "absent.bin", "--speed", 5, "--segments", "10,1e-9", check=False)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr == ("roadpreview: error: --segments: route: segment length must be a number of metres of at "
                           "least one profile bin (profile.ds_m 0.1 m), got 1e-09\n")
    with pytest.raises(ValueError, match="at least one profile bin"):
        rp.reference.Route().segments(0.05)
    blocked = tmp_path / "file"
    blocked.write_text("")
    proc = run("run", KITTI_FRAMES[0], "--speed", 5, "--sensor-height", KITTI_SENSOR_HEIGHT, "--export-profile",
               blocked / "sub", "-q", "-o", tmp_path / "o.jsonl", check=False)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr == (f"roadpreview: error: --export-profile {blocked / 'sub'}: cannot be made a directory "
                           "(Not a directory)\n")
    assert not (tmp_path / "o.jsonl").exists()  # refused before anything was run


def test_the_cpp_route_builder_matches_the_numpy_reference_on_the_same_frames():
    """What batch runs stitch with (the bound C++ RouteBuilder, fed results or output lines) against the
    reference Route fed the same lines: on a curve (arc-length scaling) and with poses placing the segments."""
    cfg = rp.Config(sensor_height=KITTI_SENSOR_HEIGHT)
    results = list(rp.run(KITTI_FRAMES[:3], cfg, speed=KITTI_SPEED, yaw_rate=0.05, frame_rate=10))
    poses = [(0.86 * k, 0.02 * k, 0.005 * k) for k in range(3)]
    native = rp._native.core()
    for placed in (None, poses):
        from_results, from_lines = native.RouteBuilder(cfg.to_json()), native.RouteBuilder(cfg.to_json())
        reference = rp.reference.Route(cfg)
        for k, res in enumerate(results):
            pose = placed[k] if placed else None
            from_results.add(res, pose)
            from_lines.add_line(res.to_json(), pose, where=f"frame {k}")
            reference.add(res.to_dict(), pose)
        assert from_lines.distance_m == pytest.approx(reference.distance, abs=1e-12)
        for wheel in ("left", "right"):
            ref = reference.stitched(wheel)
            for built in (from_results.stitched(wheel), from_lines.stitched(wheel)):
                np.testing.assert_allclose(built.z, ref.z, atol=1e-9, equal_nan=True)
                np.testing.assert_allclose(built.spread, ref.spread, atol=1e-9, equal_nan=True)
                np.testing.assert_array_equal(built.count, ref.count)
                np.testing.assert_array_equal(built.frames, ref.frames)
                np.testing.assert_array_equal(built.blocked, ref.blocked)
        for length in (10.0, 100.0):
            mine, theirs = from_lines.segments(length), reference.segments(length)
            assert len(mine) == len(theirs) > 0
            for a, b in zip(mine, theirs):
                assert (a["start_m"], a["end_m"]) == pytest.approx((b["start_m"], b["end_m"]))
                assert (a["start"] is None) == (b["start"] is None)
                if a["start"] is not None:
                    assert a["start"] == pytest.approx(b["start"]) and a["end"] == pytest.approx(b["end"])
                for side in ("left", "right", "vehicle"):
                    ra, rb = a[side]["roughness"], b[side]["roughness"]
                    assert ra.iso_class == rb.iso_class
                    if ra.iso_class:
                        assert ra.gd_n0 == pytest.approx(rb.gd_n0, rel=1e-6)
                    iri_a, iri_b = a[side]["iri"].value, b[side]["iri"].value
                    assert (iri_a is None) == (iri_b is None)
                    if iri_b is not None:
                        assert iri_a == pytest.approx(iri_b, rel=1e-6)
                    assert a[side]["backed_fraction"] == pytest.approx(b[side]["backed_fraction"])
    assert any(s["vehicle"]["roughness"].iso_class for s in from_lines.segments(10.0))
    with pytest.raises(ValueError, match="frame 3: the output line has no 'motion'"):
        from_lines.add_line('{"source": "x.bin"}', where="frame 3")
