# SPDX-License-Identifier: BSD-3-Clause
"""bench/beam_errors.py runs and prints its tables (the OS1-128 rows; KITTI's need the shared data)."""

from paths import run_bench


def test_beam_errors_bench_prints_the_os1_128_rows(tmp_path):
    out = run_bench("beam_errors.py", "--shared", str(tmp_path), timeout=600)
    single, fused = out.split("## Fused")
    assert "| OS1-128 recording, uncalibrated | 0 | DDD DCD DDD |" in single  # README "Beam self-calibration"
    assert "| OS1-128 recording, uncalibrated | 0.02 | ··· ··· ··· |" in single
    assert "| OS1-128 recording, uncalibrated | 0.01 | CCC ·CC CCC |" in fused
    assert "KITTI" not in out
