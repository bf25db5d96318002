# SPDX-License-Identifier: BSD-3-Clause
"""roadpreview batch on Dask: per-frame Parquet equal to a serial run, split recordings, a corrupt recording and a
worker killed mid-task, --resume, and the bad inputs the batch refuses."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")
pytest.importorskip("pyarrow")

import roadpreview as rp  # noqa: E402
from roadpreview import batch, drive  # noqa: E402
from paths import KITTI_FRAMES, KITTI_SENSOR_HEIGHT  # noqa: E402

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
    monkeypatch.setattr(batch, "ROW_GROUP_FRAMES", 4)
    batch.process_chunk("d", [str(folder)], batch.Chunk(0, 0, 9, 0), dict(RUN, config=config), str(tmp_path / "b"))
    assert groups(tmp_path / "b") == [4, 4, 1]
    monkeypatch.setattr(batch, "ROW_GROUP_FRAMES", 3)  # no empty group after the last full one
    batch.process_chunk("d", [str(folder)], batch.Chunk(0, 0, 9, 0), dict(RUN, config=config), str(tmp_path / "e"))
    assert groups(tmp_path / "e") == [3, 3, 3]
    monkeypatch.setattr(batch, "ROW_GROUP_FRAMES", 128)
    line_bytes = len(batch.read_frames(tmp_path / "a", "d", ["line"]).column("line")[0].as_py())
    monkeypatch.setattr(batch, "ROW_GROUP_BYTES", 2 * line_bytes)  # lines differ a little: 2 or 3 frames a group
    batch.process_chunk("d", [str(folder)], batch.Chunk(0, 0, 9, 0), dict(RUN, config=config), str(tmp_path / "c"))
    sizes = groups(tmp_path / "c")
    assert sum(sizes) == 9 and len(sizes) >= 3 and max(sizes) <= 3
