"""Smoke test of ``bench/obstacles.py --quick``: it runs and prints the paper's metrics and the timing tables."""

import re

from paths import run_bench

NUMBER_CELL = r"\d+\.\d+ \(\d+\.\d+–\d+\.\d+\)"  # "median (min–max)"


def test_obstacle_bench_quick_prints_the_papers_metrics_and_timing():
    out = run_bench("obstacles.py", "--quick")
    for heading in ("## The paper's metrics", "## Time per frame", "## Clustering variants"):
        assert heading in out
    metrics = out.split("## The paper's metrics")[1].split("## Time per frame")[0]
    for method in ("pca", "ransac"):
        row = re.search(rf"\| \*\*mean of 4 frames\*\* \| {method} \| (\d+) → (\d+) \| (\d+) → (\d+) \| "
                        rf"(\d+\.\d+) → (\d+\.\d+) \|", metrics)
        assert row, metrics
        front_before, front_after = int(row.group(1)), int(row.group(2))
        assert 0 < front_after < front_before  # ground removal removes points
        assert float(row.group(6)) < float(row.group(5))  # and fewer clusters sit on the ground
    assert "| **paper**" in metrics and "4.73 → 1.71" in metrics
    timing = out.split("## Time per frame")[1].split("## Clustering variants")[0]
    assert re.search(rf"\| 000000 \| pca \| \d+ \| {NUMBER_CELL} \| {NUMBER_CELL} \| {NUMBER_CELL} \|", timing)
    assert "Target: clustering ≤ 2 ms" in timing
