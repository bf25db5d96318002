"""Smoke test of the benchmark script: ``bench/bench.py --quick`` runs and prints its tables with numbers."""

import re

from paths import run_bench

NUMBER_CELL = r"\|\s*\d+\.\d+ \(\d+\.\d+–\d+\.\d+\)\s*\|"  # "median (min–max)"


def test_bench_quick_prints_timing_and_ground_quality_tables():
    out = run_bench("bench.py", "--quick", timeout=120)
    for heading in ("## Timing: C++ pipeline", "## Timing: numpy reference", "## Timing: ground stage per KITTI frame",
                    "## Ground quality", "## Point counts"):
        assert heading in out
    timing = out.split("## Timing: C++ pipeline")[1].split("## Timing: numpy reference")[0]
    assert re.search(r"\| synthetic OS1-128 \| 131072 \| pca " + NUMBER_CELL, timing)
    assert re.search(r"\| 000000 \| \d+ \| ransac " + NUMBER_CELL, timing)
    quality = out.split("## Ground quality")[1].split("## Point counts")[0]
    assert "Target (default method `zones`): mean F1 ≥ 0.97" in quality
    for method in ("zones", "pca", "ransac"):
        match = re.search(rf"\| \*\*mean of \d+ labelled frames\*\* \| {method} \| (0\.\d+) \| (0\.\d+) \| (0\.\d+) \|",
                          quality)
        assert match, quality
        assert 0.5 < float(match.group(3)) <= 1.0  # F1
