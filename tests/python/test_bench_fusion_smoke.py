"""Smoke test of ``bench/fusion.py --quick``: it runs and prints its four tables with numbers."""

import re

from paths import run_bench


def test_fusion_bench_quick_prints_accuracy_real_recording_and_timing():
    out = run_bench("fusion.py", "--quick", timeout=300)
    sims = out.split("## Simulated sequences")[1].split("## Coverage")[0]
    for method in ("none", "ema", "kalman"):
        assert re.search(rf"\| classes \(1\) \| 10 \| {method} \| \d+\.\d \| \d+\.\d \| \d+\.\d\d \|", sims)
        assert re.search(rf"\| bumps \(1\) \| 10 \| {method} \| .* \| \d+\.\d\d \(n = \d+\) \|", sims)
    drive = out.split("## Coverage")[1].split("## Real OS1-128")[0]
    covered = [int(m) for m in re.findall(r"\| 5 \| \d \| \d+ \| \d+ \| \d+ \| (\d+) \|", drive)]
    assert len(covered) == 2 and 0 < covered[0] <= covered[1] <= 100  # 0–30 m after 2 and 4 frames
    real = out.split("## Real OS1-128")[1].split("## Time per frame")[0]
    assert re.search(r"\| 2 \| \d+\.\d / \d+\.\d \| \d+\.\d / \d+\.\d \| \d+\.\d / \d+\.\d \|", real)
    timing = out.split("## Time per frame")[1]
    assert re.search(r"\| kalman \| 131072 \| \d+\.\d\d \|", timing)
