# SPDX-License-Identifier: BSD-3-Clause
"""Smoke test of ``bench/live.py --quick``: the 1× rows on one thread, whole rotations and the region's columns, the
reader sleeping and busy, with every frame written and latency figures."""

import re

from paths import run_bench


def test_live_bench_prints_the_rows_at_recorded_speed():
    out = run_bench("live.py", "--quick")
    rows = {}
    for row in re.finditer(r"\| 1× \| 1 \| (sleeping|busy) \| (whole rotation|region's columns) \| (\d+) \((\d+)\) "
                           r"\| ([\d.]+) \| ([\d.]+) \| ([\d.]+) \| (-?[\d.]+) \| ([\d.]+) \| ([\d.]+) \| ([\d.]+) "
                           r"\| ([\d.]+) \| (\d+) \| (\d+) \| (\d+) "
                           r"\| [\d.]+ / [\d.]+ "
                           r"\| (yes|no) \|", out):
        rows[row[1], row[2]] = [None, *row.groups()[1:]]  # the groups from the frame on, numbered from 1
    frames = ("whole rotation", "region's columns")
    assert set(rows) == {(wait, frame) for wait in ("sleeping", "busy") for frame in frames}, out
    for row in rows.values():
        written, sent = int(row[2]), int(row[3])
        p50, p99, worst = float(row[4]), float(row[5]), float(row[6])
        assert written == sent == 15  # 5 loops of the 3-frame capture: none lost at 1×
        assert 0 < p50 <= p99 <= worst
        assert 0 < float(row[8]) <= float(row[9])  # the pipeline's median and p99 from the output lines
        assert 0 <= float(row[10]) < p50 and 0 <= float(row[11]) < p50  # frame complete after, output line
        assert int(row[13]) == 0  # nothing dropped by the receive queue
    for wait in ("sleeping", "busy"):
        whole, region = rows[wait, "whole rotation"], rows[wait, "region's columns"]
        assert float(whole[7]) == float(whole[4])
        # Columns 764–1023 come 25.4 ms after the region's last: the result is that much earlier against the rotation.
        assert abs(float(region[7]) - (float(region[4]) - 25.39)) < 0.011
