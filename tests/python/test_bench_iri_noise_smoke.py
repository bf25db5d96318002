# SPDX-License-Identifier: BSD-3-Clause
"""bench/iri_noise.py --quick runs and prints its tables (KITTI frames 3–5 need the shared data)."""

from paths import run_bench


def test_iri_noise_bench_quick(tmp_path):
    out = run_bench("iri_noise.py", "--quick", "--shared", str(tmp_path), timeout=600)
    simulated, real = out.split("## Real")
    assert "| OS1-128 | C |" in simulated
    assert "| OS1-128 recording, frame 0 | D 8.3/3.0 \\| D 9.9/3.2 |" in real  # README "Noise-aware roughness"
    assert "| KITTI seq 00 000000 | C 10.6/2.9 \\| D 10.9/1.5 |" in real and "000003" not in real
