# SPDX-License-Identifier: BSD-3-Clause
"""Smoke test of ``bench/batch.py --quick``: its tables, with numbers, and the target lines."""

import re

import pytest

from paths import run_bench

pytest.importorskip("distributed")


def test_batch_bench_quick_prints_speedup_and_memory_tables():
    out = run_bench("batch.py", "--quick", timeout=300)
    speed = out.split("## Speedup")[1].split("## Segments step")[0]
    for workers in (1, 2):
        assert re.search(rf"\| {workers} \| 4 × 3 \| \d+\.\d \(\d+\.\d–\d+\.\d\) \| \d+\.\d \| \d+\.\d \|", speed)
    assert re.search(r"Speedup 2 workers vs 1: \*\*\d+\.\d\d×\*\* \(target ≥ 1\.8×: (met|not met)\): the median of \d+ "
                     r"pairs' ratios \(\d+\.\d\d–\d+\.\d\d\), the ratio of the medians \d+\.\d\d×", speed)
    segments = out.split("## Segments step")[1].split("## Worker memory")[0]
    for name in ("numpy reference Route", "C\\+\\+ RouteBuilder"):
        assert re.search(rf"\| {name} \| 4 × 3 \| \d+\.\d{{3}} \(\d+\.\d{{3}}–\d+\.\d{{3}}\) \|", segments)
    assert re.search(r"Time per recording, reference / C\+\+ RouteBuilder: \*\*\d+\.\d×\*\*", segments)
    memory = out.split("## Worker memory")[1]
    assert re.search(r"\| 60 \| \d+ \| [\d.]+ \| \d+ \| [\d.]+ \| \d+ \| \d+ \| \d+ \| \d+ \| [\d.]+ % \| (yes|no) \|",
                     memory)
    assert re.search(r"Lowest sample after 10 %: \d+ MB at \d+ s; highest \d+ MB at \d+ s; \d+ of \d+ samples", memory)
