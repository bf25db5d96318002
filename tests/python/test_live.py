# SPDX-License-Identifier: BSD-3-Clause
"""Live UDP input from Python and the CLI, fed by the replay over loopback only; every run is bounded in time."""

from __future__ import annotations

import re
import socket
import subprocess
import sys
import tempfile
import threading

import dpkt
import numpy as np
import pytest

import roadpreview as rp
from paths import OS1_128_HEIGHT, OS1_128_META, OS1_128_PCAP, REPO, VELODYNE, cli, run_cli

sys.path.insert(0, str(REPO / "bench"))
from live import free_port_pair  # noqa: E402  (the benchmark's loopback port pair, one definition)


def live_frames(pcap, meta=None, roi_columns=None, busy_wait=False, **replay):
    """Frames of the live source while the capture is replayed to it from a thread."""
    port = free_port_pair()
    source = rp.io.open_live(f"udp://127.0.0.1:{port}", meta, timeout_s=0.5, duration_s=30.0, roi_columns=roi_columns,
                             busy_wait=busy_wait)
    sent, failed = {}, []

    def send():
        try:
            sent.update(rp.io.replay(pcap, f"127.0.0.1:{port}", **replay))
        except Exception as e:  # noqa: BLE001 - re-raised in the test's thread
            failed.append(e)

    sender = threading.Thread(target=send)
    sender.start()
    frames = list(source)
    sender.join(timeout=30)
    if failed:
        raise failed[0]
    return frames, source.info, sent


@pytest.mark.parametrize("busy_wait", [False, True])
def test_open_live_yields_the_offline_frames_of_a_velodyne_capture(busy_wait):
    pcap = VELODYNE / "velodyne_vlp16.pcap"
    frames, info, sent = live_frames(pcap, rate="max", busy_wait=busy_wait)
    offline = list(rp.io.open(pcap))
    assert info["format"] == "velodyne udp" and info["datagrams_dropped"] == 0
    assert 0 < info["datagrams_received"] <= sent["sent"]  # the position packets go to a port not listened on
    assert [f.frame_id for f in frames] == [f.frame_id for f in offline]
    for got, want in zip(frames, offline):
        np.testing.assert_array_equal(got.points, want.points)
    assert frames[0].arrival_s > 0 and frames[0].arrival_s <= rp.io.steady_now_s()
    assert frames[0].arrival_s <= frames[0].completed_s <= rp.io.steady_now_s()


def test_open_live_flags_the_frames_that_lost_packets():
    frames, _, sent = live_frames(OS1_128_PCAP, OS1_128_META, rate="max", drop=0.05, reorder=0.05, loops=2, seed=3)
    assert sent["dropped"] > 0 and sent["reordered"] > 0
    assert len(frames) >= 5  # 2 loops of 3 frames; a frame may lose its first packets, never its place
    flagged = [f for f in frames if f.diagnostics["lost_packets"] or f.diagnostics["late_packets"]]
    assert flagged and all(not f.diagnostics["complete"] for f in flagged if f.diagnostics["lost_packets"])


def test_open_live_with_roi_columns_yields_the_offline_frames_of_the_regions_columns():
    cfg = rp.Config(sensor_height=OS1_128_HEIGHT)
    frames, info, _ = live_frames(OS1_128_PCAP, OS1_128_META, roi_columns=cfg, rate="max")
    offline = list(rp.io.open(OS1_128_PCAP, OS1_128_META, roi_columns=cfg))
    assert any("columns 261–763 decoded" in n for n in info["notes"])
    assert [f.frame_id for f in frames] == [f.frame_id for f in offline] == [1795, 1796, 1797]
    for got, want in zip(frames, offline):
        np.testing.assert_array_equal(got.points, want.points)
        assert got.diagnostics["complete"]


def test_replay_refuses_a_bad_rate():
    with pytest.raises(ValueError, match="rate"):
        rp.io.replay(OS1_128_PCAP, "127.0.0.1:9", rate=0)


def run_live_cli(port: int, *args, replay_args=(), first: bytes = b""):
    """`roadpreview run udp://127.0.0.1:PORT ...` while `roadpreview replay` sends the OS1-128 capture to it (after
    the datagram `first`, when given): its exit status, output lines, stderr and the replay's stderr. The run ends by
    itself (--frames, --timeout)."""
    with tempfile.TemporaryFile("w+") as out:
        run = subprocess.Popen([cli(), "run", f"udp://127.0.0.1:{port}", "--meta", str(OS1_128_META), "--speed",
                                "2.5", "--sensor-height", str(OS1_128_HEIGHT), *map(str, args)],
                               stdout=out, stderr=subprocess.PIPE, text=True)
        try:
            first_line = run.stderr.readline()  # "listening on ...": the sockets are bound
            assert "listening on" in first_line, first_line
            if first:
                with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
                    s.sendto(first, ("127.0.0.1", port))
            sender = run_cli("replay", OS1_128_PCAP, "--to", f"127.0.0.1:{port}", *replay_args)
            err = first_line + run.stderr.read()
            run.wait(timeout=60)
        finally:
            run.kill()
        out.seek(0)
        return run.returncode, out.read(), err, sender.stderr


@pytest.mark.parametrize("waiting", [(), ("--busy-wait",)])
def test_cli_live_run_writes_every_frame_and_the_latency_summary(waiting):
    status, out, err, sent = run_live_cli(free_port_pair(), "--frames", "3", "--timeout", "10", *waiting)
    assert status == 0, err
    lines = out.strip().splitlines()
    assert len(lines) == 3
    assert "sent 222 datagrams" in sent
    assert "ouster udp, OS-1-128" in err
    assert "222 datagrams received, 0 dropped by a full queue; 0 of 3 frames affected" in err
    assert "latency last packet → result p50" in err and "p99" in err
    # The parts outside the pipeline: medians of non-negative times, each below the latency's median.
    outside = re.search(r"p50 ([\d.]+) ms, p99 [\d.]+ ms, max [\d.]+ ms \(outside the pipeline, medians: frame "
                        r"complete ([\d.]+) ms after its last packet, output line ([\d.]+) ms\)", err)
    assert outside, err
    p50, completing, output = map(float, outside.groups())
    assert 0 <= completing < p50 and 0 <= output < p50


def test_cli_live_run_counts_the_bad_packets_it_skipped():
    status, _, err, _ = run_live_cli(free_port_pair(), "--frames", "3", "--timeout", "10", "--skip-bad-packets",
                                     first=b"not a lidar packet")
    assert status == 0, err
    assert "1 bad packets skipped" in err  # on the first frame's progress line
    assert "223 datagrams received, 0 dropped by a full queue; 1 of 3 frames affected (0 packets lost, 0 late, " \
           "0 duplicates, 1 bad packets skipped, 0 columns missing)" in err


def test_cli_live_run_reports_the_packets_lost():
    status, out, err, _ = run_live_cli(free_port_pair(), "--timeout", "5",
                                       replay_args=("--rate", "max", "--drop", "0.05", "--seed", "5"))
    assert status == 0, err
    assert "packets lost" in err  # on the affected frames' progress lines and in the summary
    assert re.search(r"; [1-9][0-9]* of [0-9]+ frames affected", err), err


def test_cli_live_run_stopped_by_ctrl_c_writes_its_summary_and_route(tmp_path):
    """SIGINT ended a live run at once: no summary, no segments, an empty profile folder. It ends the stream now."""
    import signal
    import time

    port = free_port_pair()
    run = subprocess.Popen([cli(), "run", f"udp://127.0.0.1:{port}", "--meta", str(OS1_128_META), "--speed", "2.5",
                            "--sensor-height", str(OS1_128_HEIGHT), "--timeout", "10", "--segments", "1",
                            "--segments-csv", str(tmp_path / "s.csv"), "-o", str(tmp_path / "out.jsonl")],
                           stderr=subprocess.PIPE, text=True)
    try:
        assert "listening on" in run.stderr.readline()
        sender = subprocess.Popen([cli(), "replay", str(OS1_128_PCAP), "--to", f"127.0.0.1:{port}", "--loop", "100"],
                                  stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + 30
        while (not (tmp_path / "out.jsonl").exists() or not (tmp_path / "out.jsonl").read_text()) \
                and time.monotonic() < deadline:
            time.sleep(0.05)  # a frame or more written
        run.send_signal(signal.SIGINT)
        err = run.stderr.read()
        run.wait(timeout=30)
    finally:
        run.kill()
        sender.kill()
    assert run.returncode == 130, err
    assert "interrupted: the live run ended there" in err and "frame(s), pipeline median" in err and "live:" in err
    assert (tmp_path / "s.csv").read_text().count("\n") >= 2  # the header and a segment


def test_cli_live_run_without_datagrams_is_an_error_naming_the_address():
    port = free_port_pair()
    proc = run_cli("run", f"udp://127.0.0.1:{port}", "--speed", "1", "--timeout", "0.3", check=False)
    assert proc.returncode == 1
    assert f"udp://127.0.0.1:{port}: no datagrams within 0.3 s" in proc.stderr


def test_cli_live_run_that_ends_before_any_datagram_says_so():
    # --duration shorter than --timeout: it said "no lidar packets ... the largest datagram is 0 bytes on port 0".
    port = free_port_pair()
    proc = run_cli("run", f"udp://127.0.0.1:{port}", "--speed", "1", "--duration", "0.3", check=False)
    assert proc.returncode == 1
    assert f"udp://127.0.0.1:{port}: no datagram arrived before the run ended" in proc.stderr
    proc = run_cli("run", f"udp://127.0.0.1:{port}", "--speed", "1", "--frames", "0", check=False)
    assert proc.returncode == 2 and "--frames 0: a live run's --frames N ends it after N ≥ 1 frames" in proc.stderr
    proc = run_cli("run", f"udp://127.0.0.1:{port}", "--speed", "1", "--frames", "2:1", check=False)
    assert proc.returncode == 2 and "--frames 2:1: A must be smaller than B" in proc.stderr
    assert "listening" not in proc.stderr  # said before the port is bound (it was an error after)


def test_cli_live_run_on_a_port_in_use_is_an_error_naming_the_address():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as taken:
        taken.bind(("127.0.0.1", 0))
        port = taken.getsockname()[1]
        proc = run_cli("run", f"udp://127.0.0.1:{port}", "--speed", "1", "--timeout", "1", check=False)
    assert proc.returncode == 1
    assert f"udp://127.0.0.1:{port}: cannot listen: the port is already in use" in proc.stderr


@pytest.mark.parametrize("option", [("--duration", "1"), ("--timeout", "1"), ("--busy-wait",)])
def test_cli_live_options_are_refused_with_files(option):
    proc = run_cli("run", OS1_128_PCAP, "--speed", "1", *option, check=False)
    assert proc.returncode == 2 and f"{option[0]} applies to a udp:// input only" in proc.stderr  # a usage error


@pytest.mark.parametrize("option", [("--lidar-port", "7502"), ("--columns", "4"), ("--frame-rate", "10")])
def test_cli_file_options_are_refused_with_a_live_input(option):
    """--lidar-port was ignored, silently: the udp:// address's port is the lidar's. Refused before any port is bound."""
    proc = run_cli("run", "udp://127.0.0.1:47560", "--speed", "1", *option, check=False)
    assert proc.returncode == 2 and f"{option[0]} does not apply to a udp:// input" in proc.stderr


def test_cli_replay_of_a_capture_without_udp_is_an_error_naming_it(tmp_path):
    path = tmp_path / "arp.pcap"
    with open(path, "wb") as f:
        writer = dpkt.pcap.Writer(f)
        arp = dpkt.ethernet.Ethernet(type=dpkt.ethernet.ETH_TYPE_ARP, data=dpkt.arp.ARP())
        writer.writepkt(bytes(arp), ts=1.0)
    proc = run_cli("replay", path, "--to", "127.0.0.1:9", check=False)
    assert proc.returncode == 1
    assert f"{path}: no UDP datagrams to replay (1 records, 1 of them not IPv4 UDP)" in proc.stderr


@pytest.mark.parametrize("args, message", [
    (("--to", "127.0.0.1"), "127.0.0.1: no port"),
    (("--to", "127.0.0.1:99999"), "port '99999' is not 1..65535"),
    (("--rate", "fast"), "--rate fast: expected a factor of at least 0.001"),
    (("--rate", "1e-300"), "--rate 1e-300: expected a factor of at least 0.001"),  # once: sent at once (overflow)
])
def test_cli_replay_refuses_bad_options(args, message):
    proc = run_cli("replay", OS1_128_PCAP, *args, check=False)
    assert proc.returncode == 2 and message in proc.stderr  # usage errors


def calling_on_a_thread(call):
    """Starts `call` on a thread (it waits for datagrams that never come, then fails) and returns the thread and
    the list its error lands in, once the call is under way."""
    errors, started = [], threading.Event()

    def run():
        started.set()
        try:
            call()
        except RuntimeError as e:
            errors.append(str(e))

    thread = threading.Thread(target=run)
    thread.start()
    started.wait(5)
    thread.join(0.5)  # the call has begun its wait (it holds the object until the timeout)
    return thread, errors


def test_a_source_or_a_drive_used_by_two_threads_at_once_refuses_the_second():
    """A FrameSource's next() and a drive's run without the GIL: another thread's call on the same object meanwhile
    corrupted it (a crash, a frame given twice, a false "file truncated"); now it raises RuntimeError naming it."""
    source = rp.io.open_live(f"udp://127.0.0.1:{free_port_pair()}", timeout_s=3.0)  # no sender: it waits 3 s
    thread, errors = calling_on_a_thread(lambda: next(source))
    with pytest.raises(RuntimeError, match="this FrameSource is in use by another thread"):
        next(source)
    thread.join()
    assert len(errors) == 1 and "in use" not in errors[0]  # the first call's own end: no datagram

    live = rp.io.open_live(f"udp://127.0.0.1:{free_port_pair()}", timeout_s=3.0)
    drive = rp.run(live, speed=5.0)
    thread, errors = calling_on_a_thread(lambda: next(drive))
    with pytest.raises(RuntimeError, match="this DriveRunner is in use by another thread"):
        next(drive)
    with pytest.raises(RuntimeError, match="this FrameSource is in use by another thread"):
        next(live)  # the source the drive reads, taken while it does
    thread.join()
    assert len(errors) == 1 and "in use" not in errors[0]


def port_is_free(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


@pytest.mark.parametrize("busy_wait", [False, True])
def test_closing_a_live_source_from_another_thread_ends_its_wait_and_frees_the_port(busy_wait):
    port = free_port_pair()
    # no sender: next() would wait 30 s, then fail
    live = rp.io.open_live(f"udp://127.0.0.1:{port}", timeout_s=30.0, busy_wait=busy_wait)
    assert not port_is_free(port)
    got = []
    reader = threading.Thread(target=lambda: got.append(list(live)))
    reader.start()
    reader.join(0.3)  # under way: waiting for a datagram
    live.close()
    reader.join(5.0)
    assert not reader.is_alive() and got == [[]]  # the iteration ended, without the timeout's error
    assert port_is_free(port)
    assert list(live) == [] and live.info["format"] == "velodyne udp"  # closed: no frames, its info kept
    live.close()  # closing twice is harmless


def test_a_live_source_in_a_with_block_frees_its_ports_on_leaving():
    port = free_port_pair()
    with rp.io.open_live(f"udp://127.0.0.1:{port}", OS1_128_META, timeout_s=30.0) as live:
        assert not port_is_free(port) and not port_is_free(port + 1)  # lidar and IMU
    assert port_is_free(port) and port_is_free(port + 1)
    assert next(live, None) is None
