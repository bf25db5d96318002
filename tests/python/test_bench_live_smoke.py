# SPDX-License-Identifier: BSD-3-Clause
"""Smoke test of ``bench/live.py --quick``: the 1× row with every frame written and latency figures."""

import re

from paths import run_bench


def test_live_bench_prints_the_row_at_recorded_speed():
    out = run_bench("live.py", "--quick")
    row = re.search(r"\| 1× \| (\d+) \((\d+)\) \| ([\d.]+) \| ([\d.]+) \| ([\d.]+) \| ([\d.]+) \| (\d+) \| (\d+) \| (\d+) "
                    r"\| [\d.]+ / [\d.]+ \| (yes|no) \|", out)
    assert row, out
    frames, sent = int(row[1]), int(row[2])
    p50, p99, worst = float(row[3]), float(row[4]), float(row[5])
    assert frames == sent == 15  # 5 loops of the 3-frame capture: none lost at 1×
    assert 0 < p50 <= p99 <= worst
    assert int(row[8]) == 0  # nothing dropped by the receive queue
