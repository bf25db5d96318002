"""Smoke test of ``bench/decode.py --quick``: a row with numbers for every recording, and the target line."""

import re

from paths import DATA, run_bench

CELL = r"\d+\.\d+ \(\d+\.\d+–\d+\.\d+\)"  # "median (min–max)"


def test_decode_bench_prints_a_row_per_recording_and_the_target():
    out = run_bench("decode.py", "--quick")
    recordings = list(DATA.rglob("*.pcap"))
    assert len(recordings) == 13
    for pcap in recordings:
        row = re.search(rf"\| {re.escape(pcap.name)} \| [^|]+ \| [^|]+ \| (\d+) \| (\d+) \| [\d.]+ \| {CELL} \| {CELL} "
                        rf"\| (\d+) \| (\d+) \| ([\d.]+) \| (\d+) \|", out)
        assert row, pcap.name
        frames, points, fps, mbps, hz, realtime = map(float, row.groups())
        assert frames >= 1 and points > 1000 and fps > 0 and mbps > 0 and 5 <= hz <= 25 and realtime >= 1
    assert re.search(r"Target: an OS1-128 frame decodes in well under 5 ms — (met|NOT met)", out)
