# SPDX-License-Identifier: BSD-3-Clause
"""roadpreview batch on Dask: per-frame Parquet equal to a serial run, split recordings (and their estimated
mounting), a corrupt recording and a worker killed mid-task, --resume (and the options it binds), the decoder
options, Ctrl-C, and the bad inputs the batch refuses."""

import functools
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")
pytest.importorskip("pyarrow")

import roadpreview as rp  # noqa: E402
from roadpreview import batch, drive  # noqa: E402
from paths import KITTI_FRAMES, KITTI_SENSOR_HEIGHT, SHARED_DATA, VELODYNE  # noqa: E402

CONFIG = {"sensor_height": KITTI_SENSOR_HEIGHT}
RUN = {"config": CONFIG, "motion": (5.0, None), "frame_rate": 10.0}
SEQ00 = [p for p in KITTI_FRAMES if p.name.startswith("0000")]  # frames 0-2 of KITTI seq 00


class KillOnce(distributed.WorkerPlugin):
    """Kills the worker process the first time it starts a chunk of recording ``victim`` (a marker file
    remembers), as a machine lost mid-task would."""

    def __init__(self, victim: str, marker: str):
        self.victim, self.marker = victim, marker

    def setup(self, worker):
        self.worker = worker

    def transition(self, key, start, finish, **kwargs):
        if finish == "executing" and str(key).startswith(f"chunk-{self.victim}-") and not os.path.exists(self.marker):
            Path(self.marker).touch()
            os._exit(1)


@pytest.fixture(scope="module")
def client():
    with batch.local_cluster(2) as c:  # the cluster `roadpreview batch` starts
        with distributed.Client(c) as cl:
            yield cl


def test_the_local_cluster_keeps_its_housekeeping_rare(client):
    """The settings reach the worker processes, where the profiler would otherwise sample every 10 ms."""
    import dask

    seen = client.run(lambda: {k: dask.config.get(k) for k in batch.LOCAL_CLUSTER_CONFIG})
    assert len(seen) == 2 and all(v == batch.LOCAL_CLUSTER_CONFIG for v in seen.values()), seen


@pytest.fixture()
def recordings(tmp_path):
    """Three copies of KITTI seq 00 frames 0-2 and one recording with a truncated frame file."""
    paths = []
    for name in ("a", "b", "c"):
        folder = tmp_path / "in" / name
        folder.mkdir(parents=True)
        for f in SEQ00:
            shutil.copy(f, folder / f.name)
        paths.append(str(folder))
    corrupt = tmp_path / "in" / "corrupt"
    corrupt.mkdir()
    (corrupt / "000000.bin").write_bytes(SEQ00[0].read_bytes()[:1001])  # not a whole number of points
    return paths, str(corrupt)


def frames_of(out, rid):
    return batch.read_frames(out, rid).drop(["timing_total_ms", "timing_fusion_ms"]).to_pylist()


def serial_rows(path, rid):
    """The per-frame rows of one recording run serially in this process, unsplit."""
    results = drive.run([path], rp.Config.from_dict(CONFIG), motion=RUN["motion"], frame_rate=RUN["frame_rate"])
    return [{"recording": rid, **{k: v for k, v in batch.frame_row(i, r).items() if not k.startswith("timing_")}}
            for i, r in enumerate(results)]


def test_split_recordings_killed_worker_and_corrupt_input_leave_the_others_equal_to_a_serial_run(
        client, recordings, tmp_path):
    good, corrupt = recordings
    client.register_plugin(KillOnce("b", str(tmp_path / "killed")), name="kill-once")
    try:
        report = batch.run_batch(good + [corrupt], tmp_path / "out", client=client, chunk_frames=2,
                                 overlap_frames=1, quiet=True, **RUN)
    finally:
        client.unregister_worker_plugin("kill-once")
    assert (tmp_path / "killed").exists(), "the worker was not killed: the test did not test a lost worker"
    assert sorted(report["done"]) == ["a", "b", "c"] and report["failed"] == ["corrupt"]
    for path in good:
        rid = Path(path).name
        assert frames_of(tmp_path / "out", rid) == serial_rows(path, rid)  # 2 chunks, overlap dropped
    errors = [json.loads(line) for line in (tmp_path / "out" / "errors.jsonl").read_text().splitlines()]
    assert [e["recording"] for e in errors] == ["corrupt"]
    assert "000000.bin" in errors[0]["error"]
    summary = (tmp_path / "out" / "summary.csv").read_text().splitlines()
    assert [line.split(",")[0] for line in summary[1:]] == ["a", "b", "c"]
    assert_hive_readers_agree(tmp_path / "out")


def assert_hive_readers_agree(out):
    """The folder of per-frame parts as a Hive dataset, read as users read one: pandas and pyarrow take the
    recording from the folder name (a file column of that name, of another type, made pandas refuse it)."""
    import pandas as pd
    import pyarrow.dataset as ds

    expected = sorted((r["recording"], r["frame"]) for r in batch.read_frames(out, columns=["recording", "frame"])
                      .to_pylist())
    assert len({rid for rid, _ in expected}) > 1
    frame = pd.read_parquet(out / "frames", columns=["recording", "frame"])
    assert sorted(zip(frame["recording"].astype(str), frame["frame"])) == expected
    table = ds.dataset(out / "frames", partitioning="hive").to_table(columns=["recording", "frame"])
    assert sorted(zip(table.column("recording").to_pylist(), table.column("frame").to_pylist())) == expected


def test_resume_redoes_only_what_is_missing(client, recordings, tmp_path):
    good, _ = recordings
    out = tmp_path / "out"
    first = batch.run_batch(good, out, client=client, chunk_frames=2, overlap_frames=1, quiet=True, **RUN)
    assert first["tasks_run"] == 9  # 3 recordings × (2 chunks + 1 summary)
    expected = {Path(p).name: frames_of(out, Path(p).name) for p in good}
    kept = out / "frames" / "recording=a" / "part-00000.parquet"
    before = kept.stat().st_mtime_ns
    (out / "frames" / "recording=b" / "part-00001.parquet").unlink()  # a task lost before it wrote
    (out / "recordings" / "c" / "summary.json").unlink()
    with pytest.raises(ValueError, match="earlier batch"):
        batch.run_batch(good, out, client=client, quiet=True, **RUN)
    again = batch.run_batch(good, out, client=client, resume=True, chunk_frames=2, overlap_frames=1, quiet=True,
                            **RUN)
    assert again["skipped"] == ["a"] and sorted(again["done"]) == ["b", "c"]
    assert again["tasks_run"] == 3  # b: the lost chunk and its summary; c: its summary only
    assert kept.stat().st_mtime_ns == before
    assert {rid: frames_of(out, rid) for rid in expected} == expected


def test_resume_with_the_inputs_in_another_order_is_refused(client, recordings, tmp_path):
    """Ids come from folder names and argument order: two folders named `seq` are `seq` and `seq-2`. Resumed with
    them swapped, `seq` named the other folder, and its finished parts were taken as that folder's (exit 0)."""
    good, _ = recordings
    for name in ("x", "y"):
        (tmp_path / name / "seq").mkdir(parents=True)
        shutil.copy(next(Path(good[0]).glob("*.bin")), tmp_path / name / "seq")
    x, y, out = str(tmp_path / "x" / "seq"), str(tmp_path / "y" / "seq"), tmp_path / "out"
    batch.run_batch([x], out, client=client, quiet=True, **RUN)
    with pytest.raises(ValueError, match=r"recording seq there was made from .*x/seq, not .*y/seq: give the inputs"):
        batch.run_batch([y, x], out, client=client, resume=True, quiet=True, **RUN)
    again = batch.run_batch([x, y], out, client=client, resume=True, quiet=True, **RUN)
    assert again["skipped"] == ["seq"] and again["done"] == ["seq-2"]


def test_segments_of_a_recording_match_the_cli(client, recordings, tmp_path):
    good, _ = recordings
    batch.run_batch(good[:1], tmp_path / "out", client=client, quiet=True, **RUN)
    import pyarrow.parquet as pq

    seg = pq.read_table(tmp_path / "out" / "recordings" / "a" / "segments.parquet").to_pylist()
    from paths import run_cli

    run_cli("run", good[0], "--sensor-height", KITTI_SENSOR_HEIGHT, "--speed", 5, "--frame-rate", 10, "-q",
            "--segments", "10,100", "-o", tmp_path / "cli.jsonl")
    rows = (tmp_path / "cli.segments.csv").read_text().splitlines()
    header = rows[0].split(",")
    cli = [dict(zip(header, r.split(","))) for r in rows[1:]]
    assert len(seg) == len(cli) > 0
    for mine, theirs in zip(seg, cli):  # the RouteBuilder fed the batch's lines against the CLI's own run
        assert mine["segment_length_m"] == pytest.approx(float(theirs["segment_length_m"]))
        assert mine["start_m"] == pytest.approx(float(theirs["start_m"])), theirs
        for side in ("left", "right", "vehicle"):
            assert (mine[f"class_{side}"] or "") == theirs[f"class_{side}"], (side, theirs)
            for key in (f"gd_n0_m3_{side}", f"iri_m_per_km_{side}", f"iri_noise_m_per_km_{side}"):
                expected = float(theirs[key]) if theirs[key] else None
                assert mine[key] == (pytest.approx(expected, rel=1e-3) if expected is not None else None), key


def test_a_recording_that_cannot_be_opened_is_an_error_line_not_the_end_of_the_batch(client, recordings, tmp_path):
    good, _ = recordings
    garbage = tmp_path / "in" / "garbage.pcap"
    garbage.write_bytes(b"not a capture file at all")
    report = batch.run_batch([good[0], str(garbage)], tmp_path / "out", client=client, quiet=True, **RUN)
    assert report["done"] == ["a"] and report["failed"] == ["garbage"]
    (error,) = [json.loads(x) for x in (tmp_path / "out" / "errors.jsonl").read_text().splitlines()]
    assert "garbage.pcap" in error["error"]
    assert frames_of(tmp_path / "out", "a") == serial_rows(good[0], "a")


def test_bad_batches_are_refused_naming_the_input(recordings, tmp_path):
    good, _ = recordings
    pcap = str(Path(__file__).resolve().parents[1] / "data" / "ouster" / "OS-1-128_v2.3.0_1024x10_lb_n3.pcap")
    with pytest.raises(ValueError, match="mixed sensors in one batch.*OS-1-128"):
        batch.run_batch([good[0], pcap], tmp_path / "o1", workers=1, quiet=True, **RUN)
    with pytest.raises(ValueError, match="nowhere: no such recording"):
        batch.run_batch([str(tmp_path / "nowhere")], tmp_path / "o2", workers=1, quiet=True, **RUN)
    with pytest.raises(ValueError, match=r"segment length .* one profile bin \(profile.ds_m 0.1 m\), got 0.01"):
        batch.run_batch(good[:1], tmp_path / "o3", segment_lengths_m=[10.0, 0.01], workers=1, quiet=True, **RUN)
    assert not (tmp_path / "o3").exists()  # refused before anything ran
    with pytest.raises(RuntimeError, match="tcp://127.0.0.1:9: cannot reach the Dask scheduler"):
        batch.connect(None, "tcp://127.0.0.1:9", timeout_s=2)


def test_cli_exit_status_and_errors(recordings, tmp_path):
    _, corrupt = recordings
    exe = Path(sys.executable).parent / "roadpreview"
    run = subprocess.run([str(exe), "batch", corrupt, "-o", str(tmp_path / "out"), "--workers", "1", "--speed", "5",
                          "--sensor-height", "1.73", "-q"], capture_output=True, text=True, timeout=120)
    assert run.returncode == 1, run.stderr
    assert "1 failed" in run.stderr and (tmp_path / "out" / "errors.jsonl").exists()
    run = subprocess.run([str(exe), "batch", corrupt, "-o", str(tmp_path / "o2"), "--scheduler", "tcp://127.0.0.1:9",
                          "--speed", "5", "-q"], capture_output=True, text=True, timeout=120)
    assert run.returncode == 1 and "tcp://127.0.0.1:9: cannot reach the Dask scheduler" in run.stderr
    run = subprocess.run([str(exe), "batch", corrupt, "-o", str(tmp_path / "o3")], capture_output=True, text=True,
                         timeout=60)
    assert run.returncode == 2 and "give the vehicle's motion" in run.stderr
    (tmp_path / "empty").mkdir()  # a usage error, said before anything runs
    run = subprocess.run([str(exe), "batch", str(tmp_path / "empty"), "-o", str(tmp_path / "o4"), "--speed", "5", "-q"],
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 2 and f"{tmp_path / 'empty'}: directory holds no .bin, .pcd or .ply files" in run.stderr
    assert not (tmp_path / "o4").exists()


def test_the_default_overlap_lets_ema_fusion_settle_to_the_serial_profiles(tmp_path):
    """30 frames in ranges of 10 read 20 frames early (the default): the kept frames' fused profiles equal an
    unsplit run's within 1 µm (EMA α = 0.5 forgets a frame by 2⁻²⁰); with 5 frames of overlap they do not."""
    folder = tmp_path / "drive"
    folder.mkdir()
    for k in range(30):
        (folder / f"{k:06d}.bin").symlink_to(SEQ00[k % len(SEQ00)])
    config = dict(CONFIG, fusion={"method": "ema"}, obstacles={"enabled": False})  # clusters off: faster
    serial = [r.to_dict() for r in drive.run([str(folder)], rp.Config.from_dict(config), motion=(8.6, None),
                                             frame_rate=10.0)]

    def worst_difference_m(overlap):
        out = tmp_path / f"out{overlap}"
        for chunk in batch.split(30, 10, overlap):
            batch.process_chunk("d", [str(folder)], chunk, dict(RUN, config=config, motion=(8.6, None)), str(out))
        lines = [json.loads(x) for x in batch.read_frames(out, "d").column("line").to_pylist()]
        assert [x["frame"] for x in lines] == list(range(30))
        z = [np.array([np.nan if v is None else v for v in x["profiles"]["left"]["z"]], float)
             for x in lines + serial]
        return max(np.nanmax(np.abs(a - b)) for a, b in zip(z[:30], z[30:]))

    assert worst_difference_m(batch.DEFAULT_OVERLAP_FRAMES) < 1e-6
    assert worst_difference_m(5) > 1e-3


def test_row_groups_are_bounded_by_frames_and_by_bytes(tmp_path, monkeypatch):
    """A part's row groups close at ROW_GROUP_FRAMES frames or once their output lines reach ROW_GROUP_BYTES,
    whichever comes first, and reading it back gives every frame in order."""
    import pyarrow.parquet as pq

    folder = tmp_path / "drive"
    folder.mkdir()
    for k in range(9):
        (folder / f"{k:06d}.bin").symlink_to(SEQ00[k % len(SEQ00)])
    config = dict(CONFIG, obstacles={"enabled": False})

    def groups(out):
        (part,) = (out / "frames").glob("recording=d/part-*.parquet")
        meta = pq.ParquetFile(part).metadata
        assert [x["frame"] for x in batch.read_frames(out, "d", ["frame"]).to_pylist()] == list(range(9))
        return [meta.row_group(g).num_rows for g in range(meta.num_row_groups)]

    batch.process_chunk("d", [str(folder)], batch.Chunk(0, 0, 9, 0), dict(RUN, config=config), str(tmp_path / "a"))
    assert groups(tmp_path / "a") == [9]  # 9 KITTI lines are far below both bounds
    monkeypatch.setattr(batch.chunks, "ROW_GROUP_FRAMES", 4)
    batch.process_chunk("d", [str(folder)], batch.Chunk(0, 0, 9, 0), dict(RUN, config=config), str(tmp_path / "b"))
    assert groups(tmp_path / "b") == [4, 4, 1]
    monkeypatch.setattr(batch.chunks, "ROW_GROUP_FRAMES", 3)  # no empty group after the last full one
    batch.process_chunk("d", [str(folder)], batch.Chunk(0, 0, 9, 0), dict(RUN, config=config), str(tmp_path / "e"))
    assert groups(tmp_path / "e") == [3, 3, 3]
    monkeypatch.setattr(batch.chunks, "ROW_GROUP_FRAMES", 128)
    line_bytes = len(batch.read_frames(tmp_path / "a", "d", ["line"]).column("line")[0].as_py())
    monkeypatch.setattr(batch.chunks, "ROW_GROUP_BYTES", 2 * line_bytes)  # lines differ a little: 2 or 3 frames a group
    batch.process_chunk("d", [str(folder)], batch.Chunk(0, 0, 9, 0), dict(RUN, config=config), str(tmp_path / "c"))
    sizes = groups(tmp_path / "c")
    assert sum(sizes) == 9 and len(sizes) >= 3 and max(sizes) <= 3


def test_resume_with_other_options_is_refused_naming_them(client, recordings, tmp_path, monkeypatch):
    """A resume given another sensor height, speed, fusion or segment lengths mixed results made with both in one
    folder (exit 0); the workers, the scheduler and -q change no result and do not count."""
    good, _ = recordings
    out = tmp_path / "out"
    batch.run_batch(good[:1], out, client=client, quiet=True, **RUN)
    other = dict(RUN, config=dict(CONFIG, sensor_height=1.8, fusion={"method": "ema"}), motion=(4.0, None))
    with pytest.raises(ValueError) as refused:
        batch.run_batch(good[:1], out, client=client, resume=True, quiet=True, segment_lengths_m=[10.0], **other)
    said = str(refused.value)
    for name in ("config.sensor_height 1.73 there, 1.8 now", 'config.fusion.method "none" there, "ema" now',
                 "motion [5.0, null] there, [4.0, null] now", "segment_lengths_m [10.0, 100.0] there, [10.0] now"):
        assert name in said, said
    assert said.count(" there, ") == 4 and "give the options it ran with to --resume it" in said
    motion = tmp_path / "motion.csv"
    motion.write_text("t,speed,yaw_rate\n0,5,0\n10,5,0\n")
    batch.run_batch(good[1:2], tmp_path / "csv", client=client, quiet=True, **dict(RUN, motion=str(motion)))
    motion.write_text("t,speed,yaw_rate\n0,6,0\n10,6,0\n")  # the same file, another motion
    with pytest.raises(ValueError, match=r"\(motion \"file with sha256 [0-9a-f]{64}\" there, \"file with sha256"):
        batch.run_batch(good[1:2], tmp_path / "csv", client=client, resume=True, quiet=True,
                        **dict(RUN, motion=str(motion)))
    monkeypatch.setattr(batch.cli, "run_batch", functools.partial(batch.run_batch, client=client))
    cli = [good[0], "-o", str(out), "--resume", "--sensor-height", "1.73", "--frame-rate", "10", "-q"]
    assert batch.main(cli + ["--speed", "4"]) == 2  # a usage error, before anything runs
    assert batch.main(cli + ["--speed", "5", "--workers", "1"]) == 0  # the same options: nothing left to do


def kitti_drive(folder: Path, frames: int) -> str:
    """A recording of ``frames`` KITTI frames: seq 00 frames 0-2 repeated (symlinks)."""
    folder.mkdir(parents=True)
    for k in range(frames):
        (folder / f"{k:06d}.bin").symlink_to(SEQ00[k % len(SEQ00)])
    return str(folder)


def test_chunks_take_the_mounting_the_whole_recording_estimated(client, tmp_path):
    """Without a sensor height each chunk estimated the mounting from its own first frame, so the answers depended
    on --chunk-frames (700 of 1,200 KITTI lines differed). Now the chunks take the one the whole run estimates."""
    drive_dir = kitti_drive(tmp_path / "drive", 8)
    run = dict(RUN, config={"obstacles": {"enabled": False}})

    def lines(chunk_frames):
        out = tmp_path / f"out{chunk_frames}"
        batch.run_batch([drive_dir], out, client=client, chunk_frames=chunk_frames, overlap_frames=1, quiet=True,
                        **run)
        return frames_of(out, "drive")

    whole, chunked = lines(0), lines(3)  # chunks start at frames 0, 2 (seq 00's frame 2) and 5 (frame 2)
    assert [r["frame"] for r in chunked] == list(range(8))
    assert chunked == whole
    frame0 = next(iter(drive.run([str(SEQ00[0])], rp.Config(), motion=(5.0, None)))).mounting["extrinsics"]
    for row in chunked:
        mounting = json.loads(row["line"])["mounting"]
        assert mounting["source"] == "estimated" and mounting["extrinsics"] == pytest.approx(frame0, abs=1e-15)


def test_chunks_keep_the_base_frame_the_whole_recording_settled_on(client, tmp_path):
    """A first frame whose ground lies at the cloud's origin settles it: base-frame points, no later frame asked.
    A chunk starting at a frame from a mounted sensor estimated a mounting of its own."""
    drive_dir = Path(kitti_drive(tmp_path / "drive", 6))
    points = rp.io.read(SEQ00[0])
    points[:, 2] += 1.85  # the ground about at z = 0: a cloud in a base frame
    (drive_dir / "000000.bin").unlink()
    points.astype(np.float32).tofile(drive_dir / "000000.bin")
    run = dict(RUN, config={"obstacles": {"enabled": False}})
    outs = {k: tmp_path / f"out{k}" for k in (0, 2)}
    for chunk_frames, out in outs.items():
        batch.run_batch([str(drive_dir)], out, client=client, chunk_frames=chunk_frames, overlap_frames=1,
                        quiet=True, **run)
    chunked, whole = frames_of(outs[2], "drive"), frames_of(outs[0], "drive")
    assert chunked == whole and len(whole) == 6
    assert {json.loads(r["line"])["mounting"]["source"] for r in whole} == {"none"}


def test_a_recording_that_fails_part_way_leaves_no_frames(client, recordings, tmp_path):
    """Its first chunks' parts stayed in frames/, so `pd.read_parquet(OUT/frames)` mixed in a failed drive."""
    import pandas as pd

    good, _ = recordings
    bad = Path(kitti_drive(tmp_path / "in" / "bad", 4))
    (bad / "000004.bin").write_bytes(SEQ00[0].read_bytes()[:1001])  # the last chunk's frame: truncated
    out = tmp_path / "out"
    report = batch.run_batch([good[0], str(bad)], out, client=client, chunk_frames=2, overlap_frames=1, quiet=True,
                             **RUN)
    assert report["done"] == ["a"] and report["failed"] == ["bad"]
    assert "000004.bin" in json.loads((out / "errors.jsonl").read_text())["error"]
    assert not (out / "frames" / "recording=bad").exists()
    frames = pd.read_parquet(out / "frames", columns=["recording", "frame"])
    assert sorted(zip(frames["recording"].astype(str), frames["frame"])) == [("a", 0), ("a", 1), ("a", 2)]


@pytest.mark.skipif(not (SHARED_DATA / "laserscan2d").is_dir(), reason="needs the shared data")
def test_a_bag_without_point_clouds_is_an_error_line_not_the_end_of_the_batch(client, recordings, tmp_path):
    good, _ = recordings
    scans = SHARED_DATA / "laserscan2d" / "leg_tracker" / "demo_stationary_simple_environment.bag"
    report = batch.run_batch([good[0], str(scans)], tmp_path / "out", client=client, quiet=True, **RUN)
    assert report["done"] == ["a"] and report["failed"] == ["demo_stationary_simple_environment"]
    (error,) = [json.loads(x) for x in (tmp_path / "out" / "errors.jsonl").read_text().splitlines()]
    assert error["error"].startswith(f"ValueError: {scans}: no point clouds in this bag"), error


@pytest.mark.parametrize("option, value, said", [
    ("topic", "/points", "--topic applies to ROS bags and MCAP files only"),
    ("sensor_model", "VLP-16", "--sensor-model applies to pcap recordings only"),
    ("calibration", "vlp.yaml", "--calibration applies to pcap recordings only")])
def test_an_option_for_other_inputs_is_a_usage_error(recordings, tmp_path, option, value, said):
    """Refused before anything runs, naming the input (frame files had one error line each, exit 1)."""
    good, _ = recordings
    with pytest.raises(ValueError, match=f"^{good[0]}: {said}$"):
        batch.run_batch(good[:1], tmp_path / "out", workers=1, quiet=True, **{option: value}, **RUN)
    assert not (tmp_path / "out").exists()


def test_origin_without_poses_is_a_usage_error(recordings, tmp_path):
    """It failed every recording, each after it had been processed."""
    good, _ = recordings
    for motion_from in (None, "bag"):  # a bag's motion topics give no poses
        with pytest.raises(ValueError, match=r"--origin 50.1,14.4 places poses on the map, and no option gives the "
                                             r"frames poses: give --poses or --motion-from lidar"):
            batch.run_batch(good[:1], tmp_path / "out", workers=1, quiet=True, geo_options={"origin": [50.1, 14.4]},
                            **dict(RUN, motion_from=motion_from))
    assert batch.main([good[0], "-o", str(tmp_path / "out"), "--speed", "5", "--origin", "50.1,14.4", "-q"]) == 2
    assert not (tmp_path / "out").exists()


@pytest.fixture()
def batch_cli(client, monkeypatch):
    """`roadpreview batch ARGS` in this process, on the module's cluster; returns (status, summary.csv rows)."""
    monkeypatch.setattr(batch.cli, "run_batch", functools.partial(batch.run_batch, client=client))

    def run(*args):
        out = Path(args[args.index("-o") + 1])
        status = batch.main([str(a) for a in args] + ["-q"])
        table = out / "summary.csv"
        return status, (table.read_text().splitlines()[1:] if table.exists() else [])
    return run


def test_the_beam_calibration_reaches_the_decoder(batch_cli, recordings, tmp_path):
    """A surface calibration of the bundled KITTI frames: C C D without (median IRI 10.8 m/km), C C B with (6.2)."""
    good, _ = recordings
    beams = tmp_path / "beams.yaml"
    rp.calibrate_beams([rp.io.read(f) for f in KITTI_FRAMES], method="surface",
                       config=rp.Config(sensor_height=KITTI_SENSOR_HEIGHT)).save(str(beams))
    common = (good[0], "--speed", 5, "--sensor-height", KITTI_SENSOR_HEIGHT, "--frame-rate", 10)
    assert batch_cli(*common, "-o", tmp_path / "plain") == (0, ["a,3,Cx2 Dx1,10.766,5"])
    assert batch_cli(*common, "--beam-calibration", beams, "-o", tmp_path / "beams") == (0, ["a,3,Bx1 Cx2,6.238,5"])


def test_the_columns_reach_the_decoder(batch_cli, recordings, tmp_path):
    """KITTI frames written with a fifth value per point (a ring number) read as the originals with --columns 5."""
    good, _ = recordings
    five = tmp_path / "five" / "a"
    five.mkdir(parents=True)
    for f in SEQ00:
        points = rp.io.read(f)
        np.column_stack([points, np.arange(len(points)) % 64]).astype(np.float32).tofile(five / f.name)
    common = ("--speed", 5, "--sensor-height", KITTI_SENSOR_HEIGHT, "--frame-rate", 10)
    four = batch_cli(good[0], *common, "-o", tmp_path / "four")
    assert batch_cli(five, *common, "--columns", 5, "-o", tmp_path / "out5") == four
    columns = [c for c in batch.FRAME_SCHEMA().names if c not in ("source", "line") and not c.startswith("timing")]
    assert batch.read_frames(tmp_path / "out5", "a", columns) == batch.read_frames(tmp_path / "four", "a", columns)
    assert batch_cli(five, *common, "-o", tmp_path / "out4")[1] != four[1]  # 20-byte points read as 16-byte ones


def test_the_sensor_model_reaches_the_decoder(batch_cli, tmp_path):
    """An HDL-32E capture decoded as a VLP-16 gives other points: the lines `roadpreview run` writes with it."""
    pcap = VELODYNE / "hdl32_example.pcap"
    assert batch_cli(pcap, "--speed", 5, "--sensor-model", "VLP-16", "-o", tmp_path / "out")[0] == 0
    from paths import run_cli

    expected = [json.loads(x) for x in run_cli("run", pcap, "--speed", 5, "--sensor-model", "VLP-16", "-q")
                .stdout.splitlines()]
    got = [json.loads(x) for x in batch.read_frames(tmp_path / "out", "hdl32_example").column("line").to_pylist()]
    assert [x["points"] for x in got] == [x["points"] for x in expected] and len(got) == 7
    assert [x["mounting"] for x in got] == [x["mounting"] for x in expected]
    assert expected[0]["mounting"]["extrinsics"][2] == pytest.approx(0.96, abs=0.01)  # 2.17 m as an HDL-32E


def test_the_velodyne_calibration_reaches_the_decoder(batch_cli, tmp_path):
    cal = tmp_path / "vlp.yaml"
    cal.write_text("lasers:\n" + "".join(f"  - {{laser_id: {min(k, 14)}, vert_correction: 0.0}}\n" for k in range(16)))
    out = tmp_path / "out"
    status, _ = batch_cli(VELODYNE / "velodyne_vlp16.pcap", "--speed", 5, "--sensor-model", "VLP-16",
                          "--calibration", cal, "-o", out)
    (error,) = [json.loads(x) for x in (out / "errors.jsonl").read_text().splitlines()]
    assert status == 1 and "vlp.yaml" in error["error"] and "laser_id 14 listed twice" in error["error"], error


def test_resume_removes_what_killed_writers_left(client, recordings, tmp_path):
    good, _ = recordings
    out = tmp_path / "out"
    batch.run_batch(good[:1], out, client=client, quiet=True, **RUN)
    stale = [out / "frames" / "recording=a" / ".part-00001.parquet.4242.tmp", out / "recordings" / "a" /
             ".summary.json.4242.tmp", out / ".summary.csv.4242.tmp"]
    for path in stale:
        path.write_bytes(b"half")
    kept = out / "recordings" / "a" / ".notes.tmp"  # not one of ours
    kept.write_bytes(b"x")
    batch.run_batch(good[:1], out, client=client, resume=True, quiet=True, **RUN)
    assert [p.exists() for p in stale] == [False] * 3 and kept.exists()


def test_ctrl_c_says_how_to_continue(recordings, tmp_path):
    """Ctrl-C printed a KeyboardInterrupt traceback; now one line and status 130."""
    good, _ = recordings
    many = kitti_drive(tmp_path / "long", 300)
    exe = Path(sys.executable).parent / "roadpreview"
    proc = subprocess.Popen([str(exe), "batch", many, *good, "-o", str(tmp_path / "out"), "--workers", "1",
                             "--speed", "5", "--sensor-height", "1.73", "--chunk-frames", "50"],
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.monotonic() + 60
    while not list((tmp_path / "out").glob("frames/*/part-*.parquet")) and time.monotonic() < deadline:
        time.sleep(0.2)  # interrupted while tasks run
    os.killpg(proc.pid, signal.SIGINT)  # as a terminal's Ctrl-C: to the whole process group
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr and "KeyboardInterrupt" not in stderr, stderr
    assert f"roadpreview batch: interrupted; the same command with --resume continues it in {tmp_path / 'out'}" \
        in stderr
