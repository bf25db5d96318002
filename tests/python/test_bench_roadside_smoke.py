# SPDX-License-Identifier: BSD-3-Clause
"""bench/roadside.py --quick runs and prints the paper's table for all five scenarios and the cycle time."""

import pytest

from paths import run_bench


def test_roadside_bench_quick():
    pytest.importorskip("motmetrics")
    out = run_bench("roadside.py", "--quick")
    scenarios = ("one_car", "two_cars_crossing", "two_cars_in_a_row", "pedestrian_crossing", "cyclist_crossing")
    rows = [line for line in out.splitlines() if line.split("|")[1:2] and line.split("|")[1].strip() in scenarios]
    assert len(rows) == 5, out
    for row in rows:
        mean_error = float(row.split("|")[4])
        assert mean_error < 0.3, row  # a tracked road user, not a wall
    assert "Cycle processing (C++, 2 × 361 beams" in out
