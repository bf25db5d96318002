"""Smoke test of the accuracy benchmark: ``bench/accuracy.py --quick`` runs and prints its tables with numbers."""

import re
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def test_accuracy_quick_prints_the_accuracy_and_range_tables():
    run = subprocess.run([sys.executable, str(REPO / "bench" / "accuracy.py"), "--quick", "--jobs", "1"], cwd=REPO,
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    out = run.stdout
    for heading in ("## Accuracy against the simulator's truth", "## Per sequence", "## What one frame resolves"):
        assert heading in out
    os1 = re.search(r"\| classes C, straight \+ curved \| OS1-128 \| 1/1 \(100 %\) \| 1/1 \(100 %\) \| (\d+)/3 .*"
                    r"\| (\d\.\d\d) / (\d\.\d\d) \| – \| (1\.000|0\.\d{3}) / (1\.000|0\.\d{3}) \| \d+\.\d\d \|", out)
    assert os1, out  # a class C road seen by an OS1-128 is class C
    assert 0 < float(os1.group(2)) < 1.0  # profile RMSE in cm
    bump = re.search(r"\| bump 6 cm \| OS1-128 \|( – \|){6} \d\.\d\d / \d\.\d\d \| (\d\.\d\d) \(n = (\d+)\)", out)
    assert bump and float(bump.group(2)) < 2.0 and int(bump.group(3)) > 0, out
    assert re.search(r"\| class C, straight \| VLP-16 \| declined \| – \| ··· \|", out)  # too sparse: no class
