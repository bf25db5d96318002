"""Reading real recordings through rp.io.open: the vendor SDK's XYZ, capture variants (IP fragments, pcapng,
Linux cooked link layer), bad input, and constant memory."""

import json
import subprocess
import sys

import dpkt
import numpy as np
import pytest

import roadpreview as rp
from paths import OS1_128_META, OS1_128_PCAP, OUSTER, PCD_FILE, VELODYNE
from pcaps import fragment, linux_cooked, records, udp_of, write_pcap, write_pcapng

REFERENCE = OUSTER / "reference"


def frames_of(path, **kw):
    return list(rp.io.open(path, **kw))


@pytest.fixture(scope="module")
def os1_frames():
    return frames_of(OS1_128_PCAP)


@pytest.mark.parametrize("pcap, reference", [
    ("OS-1-128_v2.3.0_1024x10_lb_n3.pcap", "OS-1-128_v2.3.0_1024x10_lb_n3_frame0_xyz_valid_f32.npy"),
    ("OS-1-128_767798045_1024x10_20230712_120049.pcap",
     "OS-1-128_767798045_1024x10_20230712_120049_frame0_incomplete_xyz_valid_f32.npy"),
])
def test_xyz_matches_the_vendor_sdk_within_1mm_for_every_valid_pixel(pcap, reference):
    """The reference holds every pixel with range > 0 in the SDK's destaggered row-major order, sensor frame."""
    ref = np.load(REFERENCE / reference)
    frame = next(iter(rp.io.open(OUSTER / pcap)))
    assert frame.points.shape == (len(ref), 4)
    err = np.linalg.norm(frame.points[:, :3].astype(np.float64) - ref, axis=1)
    assert err.max() < 1e-3, err.max()


def test_frames_carry_points_time_id_and_diagnostics(os1_frames):
    assert [f.frame_id for f in os1_frames] == [1795, 1796, 1797]
    assert [len(f.points) for f in os1_frames] == [107647, 107357, 107532]
    f = os1_frames[0]
    assert f.points.dtype == np.float32 and f.points.shape[1] == 4 and not f.points.flags.writeable
    assert np.diff([g.timestamp for g in os1_frames]) == pytest.approx([0.1, 0.1], abs=0.01)
    assert 0 <= f.point_times.min() and f.point_times.max() < 0.1  # one 10 Hz sweep
    assert f.diagnostics == {"missing_columns": 0, "cut_columns": 0, "invalid_columns": 0, "skipped_packets": 0,
                             "lost_packets": 0, "late_packets": 0, "duplicate_packets": 0, "complete": True}
    assert f.imu_angular_velocity.shape == (len(f.imu_timestamps), 3) and len(f.imu_timestamps) == 10
    assert abs(rp.io.imu_yaw_rate(f)) < 0.05  # driving nearly straight
    r = np.linalg.norm(f.points[:, :3], axis=1)
    assert r.min() > 0.2 and r.max() < 32767 * 0.008 + 0.1  # RNG15: 15 bits of 8 mm


def test_an_imu_datagram_the_network_copied_is_one_reading(os1_frames, tmp_path):
    recs = records(OS1_128_PCAP)
    imu = [i for i, (_, buf) in enumerate(recs) if (u := udp_of(buf)) and len(u[2].data) == 48]
    copied = list(recs)
    for i in reversed(imu[::2]):  # every other IMU datagram twice, the copy right behind it or after a lidar packet
        copied.insert(i + 1 + (i % 4 == 0), recs[i])
    frames = frames_of(write_pcap(tmp_path / "imu_copies.pcap", copied), meta=OS1_128_META)
    assert len(copied) == len(recs) + len(imu[::2]) and len(frames) == len(os1_frames)
    for got, want in zip(frames, os1_frames):
        np.testing.assert_array_equal(got.imu_timestamps, want.imu_timestamps)
        np.testing.assert_array_equal(got.imu_angular_velocity, want.imu_angular_velocity)


def test_velodyne_recordings_decode_with_their_models():
    src = rp.io.open(VELODYNE / "hdl32_example.pcap")
    sweeps = list(src)
    assert src.info["sensor_model"] == "HDL-32E" and len(sweeps) == 7
    assert sum(len(s.points) for s in sweeps) == 252057
    src = rp.io.open(VELODYNE / "velodyne_vlp16.pcap")
    assert sum(len(s.points) for s in src) == 19579 and src.info["sensor_model"] == "VLP-16"
    assert "HDL-32E" in src.info["notes"][0]  # the factory byte's claim, overruled by the firing timing


def points_equal(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b):
        assert x.frame_id == y.frame_id
        np.testing.assert_array_equal(x.points, y.points)


def test_ip_fragments_are_reassembled(tmp_path, os1_frames):
    """Real captures on a 1500-byte MTU link fragment each 8448-byte lidar datagram into 6 IP fragments."""
    recs = []
    for i, (ts, buf) in enumerate(records(OS1_128_PCAP)):
        parts = udp_of(buf)
        if parts and len(parts[2].data) == 8448:
            recs += [(ts, f) for f in fragment(buf, reverse=i % 2 == 1)]  # every other one out of order
        else:
            recs.append((ts, buf))
    assert len(recs) > 1000
    points_equal(frames_of(write_pcap(tmp_path / "fragmented.pcap", recs), meta=OS1_128_META), os1_frames)


def test_pcapng_and_linux_cooked_captures(tmp_path, os1_frames):
    recs = records(OS1_128_PCAP)
    points_equal(frames_of(write_pcapng(tmp_path / "capture.pcapng", recs), meta=OS1_128_META), os1_frames)
    cooked = [(ts, linux_cooked(buf)) for ts, buf in recs]
    points_equal(frames_of(write_pcap(tmp_path / "cooked.pcap", cooked, linktype=dpkt.pcap.DLT_LINUX_SLL),
                           meta=OS1_128_META), os1_frames)


def test_truncated_pcap_keeps_the_frames_before_and_names_the_file(tmp_path, os1_frames):
    data = OS1_128_PCAP.read_bytes()
    cut = tmp_path / "cut.pcap"
    cut.write_bytes(data[: int(len(data) * 0.55)])  # inside the second frame
    src = rp.io.open(cut, meta=OS1_128_META)
    first = next(src)
    np.testing.assert_array_equal(first.points, os1_frames[0].points)
    with pytest.raises(RuntimeError, match=r"cut\.pcap: record \d+ cannot be read, the file is truncated"):
        list(src)


def test_garbage_and_missing_files_are_clear_errors(tmp_path):
    junk = tmp_path / "junk.pcap"
    junk.write_bytes(np.random.default_rng(1).integers(0, 256, 5000, dtype=np.uint8).tobytes())
    with pytest.raises(RuntimeError, match=r"junk\.pcap: cannot read as pcap or pcapng"):
        rp.io.open(junk, meta=OS1_128_META)
    with pytest.raises(RuntimeError, match=r"nope\.pcap: no such file"):
        rp.io.open(tmp_path / "nope.pcap")
    lonely = tmp_path / "lonely.pcap"
    lonely.write_bytes(OS1_128_PCAP.read_bytes())
    with pytest.raises(RuntimeError, match=r"lonely\.pcap: .*no Ouster metadata JSON was found.*--meta"):
        rp.io.open(lonely)
    with pytest.raises(RuntimeError, match=r"absent\.json: cannot read the Ouster metadata file: no such file"):
        rp.io.open(lonely, meta=tmp_path / "absent.json")
    # A capture of TCP traffic and small UDP datagrams (a SICK scanner's telegrams and mDNS) has no LiDAR packets:
    # it was sent looking for Ouster metadata it could never use.
    tcp = dpkt.tcp.TCP(sport=2112, dport=57104, flags=dpkt.tcp.TH_ACK | dpkt.tcp.TH_PUSH, data=b"\x02sSN LMDscandata\x03")
    mdns = dpkt.udp.UDP(sport=5353, dport=5353, data=bytes(40))
    recs = [(0.1 * k, bytes(dpkt.ethernet.Ethernet(data=dpkt.ip.IP(p=p, data=seg))))
            for k, (p, seg) in enumerate([(dpkt.ip.IP_PROTO_TCP, tcp), (dpkt.ip.IP_PROTO_UDP, mdns)] * 3)]
    sick = write_pcapng(tmp_path / "sick.pcapng", recs)
    # Another sensor's metadata: its packets' size is found nowhere, and the capture's LiDAR-sized ones say why.
    with pytest.raises(RuntimeError, match=r"fw20\.pcap: no lidar packets \(6464-byte UDP datagrams\) in 75 records; "
                                           r"the largest datagram is 12608 bytes on port 7502: if those are the "
                                           r"LiDAR's, the metadata or sensor model given is another sensor's"):
        list(rp.io.open(OUSTER / "OS-1-64_1024x10_fw20.pcap", meta=OUSTER / "OS-1-32-G_v2.1.1_1024x10.json"))
    with pytest.raises(RuntimeError, match=r"sick\.pcapng: holds no LiDAR packets: no UDP datagram of 512 bytes or "
                                           r"more \(a SICK scanner's telegrams travel over TCP: `roadpreview roadside`"):
        rp.io.open(sick)


def with_short_packet(tmp_path):
    """The recording with one lidar packet (the 20th) cut to 8000 bytes."""
    recs, n = [], 0
    for ts, buf in records(OS1_128_PCAP):
        parts = udp_of(buf)
        if parts and len(parts[2].data) == 8448:
            n += 1
            if n == 20:
                eth, ip, udp = parts
                udp.data = udp.data[:8000]
                udp.ulen = 8 + 8000
                ip.len = 20 + len(udp)
                buf = bytes(eth)
        recs.append((ts, buf))
    return write_pcap(tmp_path / "short.pcap", recs)


def test_a_packet_of_the_wrong_size_is_an_error_or_skipped_on_request(tmp_path):
    short = with_short_packet(tmp_path)
    with pytest.raises(RuntimeError, match=r"short\.pcap: record \d+ \(UDP port 7502\): lidar packet of 8000 bytes"):
        list(rp.io.open(short, meta=OS1_128_META))
    frames = frames_of(short, meta=OS1_128_META, skip_bad_packets=True)
    assert [f.diagnostics["skipped_packets"] for f in frames] == [1, 0, 0]
    assert [f.diagnostics["missing_columns"] for f in frames] == [16, 0, 0]  # 16 columns per packet


def test_memory_stays_constant_whatever_the_length(tmp_path):
    """60 frames (the 3 real ones with frame ids shifted) need no more memory than 3."""
    recs = records(OS1_128_PCAP)
    long_recs = []
    for k in range(20):
        for ts, buf in recs:
            parts = udp_of(buf)
            if parts and len(parts[2].data) == 8448:
                eth, ip, udp = parts
                data = bytearray(udp.data)
                data[2:4] = (int.from_bytes(data[2:4], "little") + 3 * k).to_bytes(2, "little")
                udp.data = bytes(data)
                buf = bytes(eth)
            long_recs.append((ts + 0.3 * k, buf))
    long_pcap = write_pcap(tmp_path / "long.pcap", long_recs)

    def peak_kib(path):
        code = ("import resource, sys, roadpreview as rp\n"
                f"n = sum(1 for _ in rp.io.open(sys.argv[1], meta={str(OS1_128_META)!r}))\n"
                "print(n, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)")
        out = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, check=True)
        return [int(v) for v in out.stdout.split()]

    n_short, short_kib = peak_kib(OS1_128_PCAP)
    n_long, long_kib = peak_kib(long_pcap)
    assert (n_short, n_long) == (3, 60)
    assert long_kib - short_kib < 8 * 1024, (short_kib, long_kib)  # the long file is 33 MB


def test_a_clouds_zero_placeholders_are_no_returns():
    # The organized 128 × 1875 Patchwork cloud writes (0, 0, 0) where no return came back (the data README: 205,898
    # of its 240,000 points are non-zero): those rows read as NaN, the others as they are.
    frame = next(iter(rp.io.open(PCD_FILE)))
    assert frame.points.shape == (240000, 4)
    missing = np.isnan(frame.points[:, :3]).all(axis=1)
    assert missing.sum() == 240000 - 205898
    assert not np.isnan(frame.points[~missing, :3]).any() and (frame.points[~missing, :3] != 0).any(axis=1).all()
