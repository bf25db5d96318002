"""Randomized robustness: recordings with bytes flipped inside their packets, records cut short or dropped
must decode to sane frames or raise RuntimeError naming the file — never crash, hang or return garbage.
(fuzz/ holds a libFuzzer target that drives the packet decoders directly, for longer runs.)"""

import math

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import roadpreview as rp
from paths import OUSTER, VELODYNE
from pcaps import records, write_pcap

CASES = [  # small recordings covering every Ouster profile family and both Velodyne firing patterns
    (OUSTER / "OS-1-128_767798045_1024x10_20230712_120049.pcap", {}),
    (OUSTER / "OS-0-32-U1_v2.2.0_1024x10.pcap", {}),
    (OUSTER / "OS-1-32-G_v2.1.1_1024x10.pcap", {}),
    (OUSTER / "OS-1-64_1024x10_fw20.pcap", {"meta": OUSTER / "OS-1-64_sensor_config_reduced.json"}),
    (VELODYNE / "velodyne_example.pcap", {}),
    (VELODYNE / "velodyne_vlp32.pcap", {}),
]
RECORDS = {path: records(path) for path, _ in CASES}
EXAMPLES = 150  # per case: 900 decoded mutants per run


def mutate(recs, data):
    recs = list(recs)
    for _ in range(data.draw(st.integers(1, 40), label="mutations")):
        i = data.draw(st.integers(0, len(recs) - 1))
        ts, buf = recs[i]
        kind = data.draw(st.sampled_from(["flip", "cut", "drop", "duplicate"]))
        if kind == "flip" and len(buf) > 14:  # anywhere past the Ethernet header: IP/UDP headers and payload
            pos = data.draw(st.integers(14, len(buf) - 1))
            buf = buf[:pos] + bytes([data.draw(st.integers(0, 255))]) + buf[pos + 1:]
            recs[i] = (ts, buf)
        elif kind == "cut":
            recs[i] = (ts, buf[: data.draw(st.integers(0, len(buf)))])
        elif kind == "drop" and len(recs) > 1:
            del recs[i]
        elif kind == "duplicate":
            recs.insert(i, (ts, buf))
    return recs


@settings(max_examples=EXAMPLES * len(CASES), deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow, HealthCheck.data_too_large])
@given(case=st.integers(0, len(CASES) - 1), skip=st.booleans(), data=st.data())
def test_mutated_recordings_decode_or_fail_cleanly(tmp_path_factory, case, skip, data):
    path, options = CASES[case]
    pcap = write_pcap(tmp_path_factory.mktemp("fuzz") / path.name, mutate(RECORDS[path], data))
    try:
        for frame in rp.io.open(pcap, skip_bad_packets=skip, **options):
            p = frame.points
            assert p.dtype == np.float32 and p.ndim == 2 and p.shape[1] == 4
            # Every point comes from a range of at most 20 bits of mm (1048 m) or 16 bits of 2-4 mm.
            assert np.all(np.isfinite(p)) and (len(p) == 0 or np.abs(p[:, :3]).max() < 1100)
            assert len(frame.point_times) == len(p)
            assert frame.timestamp is not None and math.isfinite(frame.timestamp)
    except RuntimeError as err:
        assert pcap.name in str(err), err
