# SPDX-License-Identifier: BSD-3-Clause
"""bench/route.py on short drives runs and prints its table."""

from paths import run_bench


def test_route_bench_short_drives():
    out = run_bench("route.py", "--frames", "25", "--classes", "C", timeout=600)
    header, rule, row = out.strip().splitlines()
    assert header.startswith("| road | segments to 60 m | classed | same class |") and row.startswith("| C | ")
    segments, classed, same, near = (int(v) for v in row.split("|")[2:6])
    assert segments >= 4 and 0 < classed <= segments and same <= near <= classed
    to_line, to_strip = (float(v.split()[0]) for v in row.split("|")[6:8])  # medians of the two truths' ratios
    assert 0.3 < to_line < to_strip < 3  # the strip keeps less of the road than the line: its ratio is the larger
