"""bench/stereo.py runs and prints its tables (--quick)."""

from paths import STEREO_PAIR, run_bench


def test_bench_stereo_quick():
    out = run_bench("stereo.py", "--quick", timeout=900)
    assert "## The paper's experiment" in out
    assert "| kalman |" in out
    assert "### Read as the paper reads its profile" in out and "| ema | 6 |" in out
    if (STEREO_PAIR / "left.png").exists():
        assert "## Real KITTI pair" in out and "## Time per KITTI pair" in out
        assert "## Disparity noise of the real pair" in out and "| 10–15 |" in out
        assert "## The bins' noise, simulated" in out and "| as measured (sim.SGBM_ON_KITTI) | 5–10 |" in out
