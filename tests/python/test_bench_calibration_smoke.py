# SPDX-License-Identifier: BSD-3-Clause
"""bench/calibration.py --quick runs and prints its table."""

import pytest

import roadpreview as rp

from paths import run_bench


@pytest.mark.skipif(not rp.native_available(), reason="needs the compiled extension")
def test_calibration_bench_quick():
    out = run_bench("calibration.py", "--quick", timeout=600)
    assert "beams off by 0.03°" in out and "uniform offsets up to 0.1°" in out
    assert out.count("| after |") == 2
