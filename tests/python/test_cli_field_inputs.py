"""The CLI on what a new user feeds it first: motion tables with file inputs, runs that write nothing,
usage errors, odd input formats and mixed directories."""

import json
import math
import re

import numpy as np
import pytest

import roadpreview as rp

from paths import KITTI_FRAMES, KITTI_SENSOR_HEIGHT, NUSCENES_BIN, OS1_128_PCAP, VELODYNE
from paths import run_cli as run


def lines(text):
    return [json.loads(line) for line in text.splitlines()]


def test_motion_table_with_file_inputs_is_read_at_the_frame_rate_timestamps(tmp_path):
    motion = tmp_path / "motion.csv"
    motion.write_text("t,speed,yaw_rate\n0.0,4.0,0.0\n1.0,6.0,0.2\n")
    out = lines(run("run", *KITTI_FRAMES[:3], "--motion", motion, "--frame-rate", 10,
                    "--sensor-height", KITTI_SENSOR_HEIGHT, "-q").stdout)
    assert [o["timestamp"] for o in out] == pytest.approx([0.0, 0.1, 0.2])
    assert [o["motion"]["speed"] for o in out] == pytest.approx([4.0, 4.2, 4.4])
    assert [o["motion"]["yaw_rate"] for o in out] == pytest.approx([0.0, 0.02, 0.04])
    assert all(o["path"]["yaw_rate_source"] == "motion" for o in out)


def test_motion_table_without_timestamps_says_to_give_a_frame_rate(tmp_path):
    motion = tmp_path / "motion.csv"
    motion.write_text("t,speed,yaw_rate\n0.0,4.0,0.0\n1.0,6.0,0.2\n")
    proc = run("run", KITTI_FRAMES[0], "--motion", motion, "--sensor-height", KITTI_SENSOR_HEIGHT, check=False)
    assert proc.returncode == 1 and "--frame-rate" in proc.stderr


def test_frames_beyond_the_input_write_nothing_say_so_and_fail(tmp_path):
    out = tmp_path / "out.jsonl"
    proc = run("run", KITTI_FRAMES[0], "--frames", 5, "--speed", 5, "--sensor-height", KITTI_SENSOR_HEIGHT,
               "-o", out, check=False)
    assert proc.returncode == 1
    assert "no frames from index 5 on (the input has 1)" in proc.stderr and "nothing was written" in proc.stderr
    assert not out.exists()


def test_a_run_that_fails_before_its_first_frame_leaves_no_empty_output(tmp_path):
    """A capture truncated before its first frame completes: the run failed, as it should, but left its output
    file empty (the documented rule is no empty file behind)."""
    truncated, out = tmp_path / "truncated.pcap", tmp_path / "out.jsonl"
    truncated.write_bytes((VELODYNE / "velodyne_example.pcap").read_bytes()[:3000])
    proc = run("run", truncated, "--speed", 5, "-o", out, check=False)
    assert proc.returncode == 1 and "truncated or corrupt" in proc.stderr
    assert not out.exists()


def test_a_single_frame_index_selects_that_frame():
    out = lines(run("run", *KITTI_FRAMES[:3], "--frames", 1, "--speed", 5, "--sensor-height", KITTI_SENSOR_HEIGHT,
                    "-q").stdout)
    assert [o["source"] for o in out] == [str(KITTI_FRAMES[1])]


@pytest.mark.parametrize("args, message", [
    (("--speed", 5, "--no-such-flag"), "The following argument was not expected: --no-such-flag"),
    (("--speed", "fast"), "Could not convert: --speed = fast"),
    (("--speed", 5, "--ground", "magic"), "--ground: magic not in {zones,pca,ransac}"),
    (("--speed", 5, "--speed", 6), "--speed: At Most 1 required but received 2"),
    (("--speed", 5, "--frame-rate", 0.001), "--frame-rate: expected a number in [0.01, 10000], got 0.001"),
], ids=["unknown flag", "speed not a number", "unknown ground method", "speed twice", "frame rate out of range"])
def test_usage_errors_exit_with_status_2(args, message):
    proc = run("run", KITTI_FRAMES[0], *args, check=False)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr == f"{message}\nRun with --help for more information.\n"  # each its own error, by name


def test_help_and_version_still_exit_0():
    assert run("--help").returncode == 0 and run("run", "--help").returncode == 0


def test_frame_rate_zero_names_the_problem_without_the_double_range():
    proc = run("run", KITTI_FRAMES[0], "--speed", 5, "--frame-rate", 0, check=False)
    assert proc.returncode == 2
    assert "--frame-rate: expected a number in [0.01, 10000], got 0" in proc.stderr and "e+308" not in proc.stderr


def test_config_of_the_wrong_type_names_the_field_not_the_json_library(tmp_path):
    cfg = tmp_path / "cfg.json"
    cfg.write_text('{"ground": {"pca_threshold_m": "0.2"}}')
    proc = run("run", KITTI_FRAMES[0], "--speed", 5, "--config", cfg, check=False)
    assert proc.returncode == 1
    assert "ground.pca_threshold_m must be a number" in proc.stderr and "json.exception" not in proc.stderr
    cfg.write_text('{"sensor_height": NaN}')
    proc = run("run", KITTI_FRAMES[0], "--speed", 5, "--config", cfg, check=False)
    assert proc.returncode == 1 and "cfg.json" in proc.stderr and "json.exception" not in proc.stderr


def test_nuscenes_pcd_bin_is_read_with_five_columns(tmp_path):
    points = rp.io.read(NUSCENES_BIN)
    raw = np.fromfile(NUSCENES_BIN, dtype="<f4").reshape(-1, 5)
    assert points.shape == (34688, 4)
    np.testing.assert_array_equal(points, raw[:, :4])
    out = lines(run("run", NUSCENES_BIN, "--speed", 5, "--sensor-height", 1.75, "-q").stdout)[0]
    assert out["points"]["input"] == 34688
    plane = out["ground"]["plane"]
    assert plane is not None and plane[2] > 0.99  # a level road, not the vertical "ground" of 4-column reading
    assert abs(plane[3]) < 0.3


def test_nuscenes_lidar_top_looks_ahead_along_its_y_axis_with_the_documented_yaw():
    """nuScenes' LIDAR_TOP frame has x right and y forward (the car body hides the ground to 5.1 m behind, 3.6 m
    ahead and 3.1 m to the sides): yaw −90° turns it into the base frame, and the wheel paths then lie on the flat
    road ahead (to the right of the car, without the yaw, they cross the verge: −0.21 … +0.26 m)."""
    out = lines(run("run", NUSCENES_BIN, "--speed", 5, "--extrinsics", 0, 0, 1.75, 0, 0, -math.pi / 2, "-q").stdout)[0]
    for wheel in ("left", "right"):
        z = np.array([v for v in out["profiles"][wheel]["z"] if v is not None])
        assert len(z) >= 60 and np.all(np.abs(z) < 0.02), (wheel, len(z), z.min(), z.max())


def test_columns_flag_reads_any_raw_float32_layout(tmp_path):
    points = rp.io.read(KITTI_FRAMES[0])
    six = tmp_path / "frame.bin"
    np.hstack([points, np.zeros((len(points), 2), np.float32)]).astype("<f4").tofile(six)
    a = lines(run("run", six, "--columns", 6, "--speed", 5, "--sensor-height", KITTI_SENSOR_HEIGHT, "-q").stdout)[0]
    b = lines(run("run", KITTI_FRAMES[0], "--speed", 5, "--sensor-height", KITTI_SENSOR_HEIGHT, "-q").stdout)[0]
    assert a["points"] == b["points"] and a["roughness"]["vehicle"]["class"] == b["roughness"]["vehicle"]["class"]
    three = tmp_path / "xyz.bin"
    points[:, :3].astype("<f4").tofile(three)
    c = lines(run("run", three, "--columns", 3, "--speed", 5, "--sensor-height", KITTI_SENSOR_HEIGHT, "-q").stdout)[0]
    assert c["points"] == b["points"]
    proc = run("run", three, "--columns", 7, "--speed", 5, check=False)
    assert proc.returncode == 1 and "xyz.bin" in proc.stderr and "multiple of 28" in proc.stderr
    assert run("run", three, "--columns", 2, "--speed", 5, check=False).returncode == 2


def write_ply(path, points, fmt):
    header = (f"ply\nformat {fmt} 1.0\ncomment written by a test\nelement vertex {len(points)}\n"
              "property float x\nproperty float y\nproperty float z\nproperty float intensity\nend_header\n")
    with open(path, "wb") as f:
        f.write(header.encode())
        if fmt == "ascii":
            f.write("".join(" ".join(repr(float(v)) for v in row) + "\n" for row in points).encode())
        else:
            f.write(points.astype("<f4" if fmt == "binary_little_endian" else ">f4").tobytes())


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_clouds_read_like_the_same_points_in_a_bin(tmp_path, fmt):
    points = rp.io.read(KITTI_FRAMES[0])[::7]
    ply = tmp_path / f"cloud_{fmt}.ply"
    write_ply(ply, points, fmt)
    read = rp.io.read(ply)
    np.testing.assert_allclose(read, points, rtol=1e-6, atol=1e-6)
    out = lines(run("run", ply, "--speed", 5, "--sensor-height", KITTI_SENSOR_HEIGHT, "-q").stdout)[0]
    assert out["points"]["input"] == len(points) and out["ground"]["plane"] is not None


def test_ply_header_claiming_more_vertices_than_the_file_holds(tmp_path):
    ply = tmp_path / "liar.ply"
    ply.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 200000000\nproperty float x\n"
                    b"property float y\nproperty float z\nend_header\n" + b"\0" * 24)
    proc = run("run", ply, "--speed", 5, check=False)
    assert proc.returncode == 1 and "liar.ply" in proc.stderr and "200000000 vertices" in proc.stderr


def test_directory_mixing_sequences_resets_the_fusion_and_names_what_it_skipped(tmp_path):
    folder = KITTI_FRAMES[0].parent  # seq 00 frames 000000-000002, then spvnas_000000, and .label files
    proc = run("run", folder, "--speed", 5, "--sensor-height", KITTI_SENSOR_HEIGHT, "--fusion", "ema",
               "--frame-rate", 10)
    out = lines(proc.stdout)
    assert [o["fusion"]["frames"] for o in out] == [1, 2, 3, 1]
    assert [o["fusion"]["reset"] for o in out][:3] == [None, None, None]
    assert out[3]["fusion"]["reset"] == "new sequence: another file name pattern"
    labels = sorted(folder.glob("*.label"))
    note = [line for line in proc.stderr.splitlines() if "skipped" in line]
    assert len(note) == 1 and f"skipped {len(labels)} directory entries" in note[0]
    assert all(str(p) in note[0] for p in labels)
    assert "new sequence (another file name pattern)" in proc.stderr


def test_a_jump_in_frame_numbers_is_a_sequence_break(tmp_path):
    for number, src in zip((10, 11, 20), KITTI_FRAMES):  # 10 → 11 sets a step of 1; 20 is a jump
        (tmp_path / f"{number:06d}.bin").symlink_to(src)
    (tmp_path / "dangling.bin").symlink_to(tmp_path / "missing.bin")
    (tmp_path / "capture.pcap").write_bytes(b"")
    proc = run("run", tmp_path, "--speed", 5, "--sensor-height", KITTI_SENSOR_HEIGHT, "--fusion", "kalman",
               "--frame-rate", 10)
    out = lines(proc.stdout)
    assert [o["fusion"]["frames"] for o in out] == [1, 2, 1]
    assert out[2]["fusion"]["reset"] == "new sequence: frame number 11 → 20"
    assert "skipped 2 directory entries" in proc.stderr and "dangling.bin (broken link)" in proc.stderr
    assert "capture.pcap" in proc.stderr


def lidar_frame_id(buf: bytes):
    from pcaps import udp_of

    parts = udp_of(buf)
    if parts is None or len(parts[2].data) != 8448:  # this recording's lidar packets
        return None
    return int.from_bytes(parts[2].data[2:4], "little")


def test_split_recordings_run_as_one_drive_in_order(tmp_path):
    from pcaps import records, write_pcap

    recs = records(OS1_128_PCAP)
    ids = [lidar_frame_id(buf) for _, buf in recs]
    first_of_last = ids.index(max(i for i in ids if i is not None))
    part1 = write_pcap(tmp_path / "drive_part1.pcap", recs[:first_of_last])
    part2 = write_pcap(tmp_path / "drive_part2.pcap", recs[first_of_last:])
    meta = OS1_128_PCAP.parent / "OS-1-128_v2.3.0_1024x10.json"
    whole = lines(run("run", OS1_128_PCAP, "--speed", 2.5, "--sensor-height", 1.97, "-q").stdout)
    proc = run("run", part1, part2, "--meta", meta, "--speed", 2.5, "--sensor-height", 1.97)
    split = lines(proc.stdout)
    assert "2 recordings read as one drive" in proc.stderr
    assert [o["source"] for o in split] == [str(part1), str(part1), str(part2)]
    for a, b in zip(whole, split):
        assert a["timestamp"] == b["timestamp"] and a["points"] == b["points"]
        assert a["roughness"]["vehicle"]["class"] == b["roughness"]["vehicle"]["class"]
    proc = run("run", part2, part1, "--meta", meta, "--speed", 2.5, check=False)
    assert proc.returncode == 1 and "drive_part1.pcap" in proc.stderr and "time order" in proc.stderr
    proc = run("run", part1, KITTI_FRAMES[0], "--meta", meta, "--speed", 2.5, check=False)
    assert proc.returncode == 1 and "not both" in proc.stderr


def summary_of(*args):
    """(output lines, the summary line) of a CLI run on the first three KITTI frames."""
    proc = run("run", *KITTI_FRAMES[:3], "--sensor-height", KITTI_SENSOR_HEIGHT, *args)
    summary = [line for line in proc.stderr.splitlines() if " frame(s), pipeline median " in line]
    assert len(summary) == 1, proc.stderr
    return lines(proc.stdout), summary[0]


def declined_reasons(out) -> dict:
    reasons = {}
    for o in out:
        for side in ("left", "right", "vehicle"):
            r = o["roughness"][side]
            if r["class"] is None:
                reasons[r["reason"]] = reasons.get(r["reason"], 0) + 1
    return reasons


@pytest.mark.parametrize("speed, iri_frames, rest", [
    (5, 3, "vehicle classes: C×2 D×1; vehicle IRI median 10.77 m/km (3 of 3 frames; the bins' errors alone 2.34)"),
    (0, 0, "vehicle classes: -×3; vehicle IRI: none; declined classes (L, R, vehicle): vehicle stopped ×9"),
], ids=["moving", "stopped"])
def test_summary_line_has_the_iri_and_counts_the_reasons_for_declined_classes(speed, iri_frames, rest):
    out, summary = summary_of("--speed", speed)
    # Measured on these frames; only the timings vary from run to run.
    assert re.fullmatch(r"roadpreview: 3 frame\(s\), pipeline median [0-9.]+ ms, max [0-9.]+ ms; " + re.escape(rest),
                        summary), summary
    iris = [o["roughness"]["vehicle"]["iri"] for o in out if o["roughness"]["vehicle"]["iri"]["value"]]
    assert len(iris) == iri_frames
    if iris:  # the summary's figures are the medians of the frames' own
        value, noise = (sorted(i[key] for i in iris)[len(iris) // 2] for key in ("value", "noise"))
        assert (f"vehicle IRI median {value:.2f} m/km ({len(iris)} of 3 frames; the bins' errors alone {noise:.2f})"
                in summary)
    reasons = declined_reasons(out)
    assert reasons == ({"vehicle stopped": 9} if speed == 0 else {})  # stopped: every class declined
    for reason, n in reasons.items():
        assert f"{reason} ×{n}" in summary


LYING_PCD_HEADER = ("# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 200000000\n"
                    "HEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 200000000\nDATA binary\n")


def peak_of_cli(*args):
    """(exit status, stderr, peak resident memory in MB) of one CLI run, measured in a fresh process."""
    import subprocess
    import sys

    from paths import cli

    code = ("import resource, subprocess, sys; p = subprocess.run(sys.argv[1:], capture_output=True, text=True); "
            "print(p.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss); print(p.stderr, end='')")
    out = subprocess.run([sys.executable, "-c", code, cli(), *map(str, args)], capture_output=True, text=True,
                         timeout=60).stdout
    status, kb = out.splitlines()[0].split()
    return int(status), "\n".join(out.splitlines()[1:]), int(kb) / 1024


def test_a_200_byte_pcd_claiming_2e8_points_fails_without_allocating(tmp_path):
    pcd = tmp_path / "liar.pcd"
    pcd.write_bytes(LYING_PCD_HEADER.encode().ljust(200, b"\0"))
    assert pcd.stat().st_size == 200
    status, err, peak_mb = peak_of_cli("run", pcd, "--speed", 5)
    assert status == 1 and "liar.pcd" in err and "declares 200000000 points" in err
    # The CLI's start-up (its shared libraries) is the same with --version; rejecting the header adds next to
    # nothing to it (PCL alone would allocate 2.4 GB). bench/bad_headers.py reports the absolute figures.
    _, _, baseline_mb = peak_of_cli("--version")
    assert peak_mb - baseline_mb < 5, f"{peak_mb:.0f} MB against {baseline_mb:.0f} MB for --version"


@pytest.mark.parametrize("width, problem", [("-5", "WIDTH"), ("4e9", "WIDTH")])
def test_pcd_widths_that_are_no_count_are_named(tmp_path, width, problem):
    pcd = tmp_path / "odd.pcd"
    pcd.write_text(LYING_PCD_HEADER.replace("WIDTH 200000000", f"WIDTH {width}") + "\0" * 24)
    proc = run("run", pcd, "--speed", 5, check=False)
    assert proc.returncode == 1 and "odd.pcd" in proc.stderr and problem in proc.stderr
    assert "vector" not in proc.stderr and "bad_alloc" not in proc.stderr


def test_a_text_line_in_an_ascii_pcd_is_an_error_not_a_point(tmp_path):
    pcd = tmp_path / "words.pcd"
    header = LYING_PCD_HEADER.replace("200000000", "3").replace("DATA binary", "DATA ascii")
    pcd.write_text(header + "1 2 -1.7\nfoo bar baz\n3 4 -1.7\n")
    proc = run("run", pcd, "--speed", 5, check=False)
    assert proc.returncode == 1 and "words.pcd" in proc.stderr and "foo bar baz" in proc.stderr
