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
    for heading in ("## Accuracy against the simulator's truth", "## Bump height error", "## Per sequence",
                    "## What one frame resolves"):
        assert heading in out
    for fusion in ("none", "kalman"):
        os1 = re.search(rf"\| classes C, straight \+ curved \| OS1-128 \| {fusion} \| 1/1 \(100 %\) \| 1/1 \(100 %\) \| "
                        r"(\d+)/3 .*\| (\d+) \| (\d\.\d\d) / (\d\.\d\d) \| – \| (1\.000|0\.\d{3}) / (1\.000|0\.\d{3}) \| "
                        r"\d+\.\d\d \|", out)
        assert os1, out  # a class C road seen by an OS1-128 is class C, frame by frame and fused
        assert 0 < float(os1.group(3)) < 1.0  # profile RMSE in cm
        bump = re.search(rf"\| bumps 6 cm \| OS1-128 \| {fusion} \|( – \|){{6}} (\d+) \| \d\.\d\d / \d\.\d\d \| "
                         r"(\d\.\d\d) / (\d\.\d\d) \(n = (\d+)\)", out)
        assert bump and float(bump.group(3)) < 2.0 and int(bump.group(5)) > 0, out
    coverage = [int(m) for m in re.findall(r"\| bumps 6 cm \| OS1-128 \| \w+ \|(?: – \|){6} (\d+) \|", out)]
    assert len(coverage) == 2 and coverage[1] > coverage[0]  # the map backs more bins than one frame
    # too sparse: no class, frame by frame or fused
    assert re.search(r"\| class C, straight \| VLP-16 \| declined \| – \| ··· \| declined \| – \| ··· \|", out)
    # repeatability of the simulated class C road (a correlation in [-1, 1]) and the real OS1-128 recording
    rep = re.search(r"\| OS1-128 \| classes C–D \| none \| (-?\d\.\d{3}) \((-?\d\.\d{3})\), 2/2 \| \d+\.\d\d \| "
                    r"(\d\.\d{3}) \(\d\.\d{3}\), 2/2 \| \d\.\d{3} \(\d\.\d{3}\), 2/2 \|", out)
    assert rep and -1.0 <= float(rep.group(2)) <= float(rep.group(1)) <= 1.0, out
    assert 0.8 < float(rep.group(3)) <= 1.0  # a noise-free OS1-128 whose frames are 2 m apart
    # two drives over the class C road: their fused maps repeat (issue 10's bar: 0.90)
    passes = re.search(r"\| OS1-128 \| class C, straight \| -?\d\.\d{3} / -?\d\.\d{3} \| (\d\.\d{3}) / (\d\.\d{3}) \| "
                       r"\d+\.\d\d \|", out)
    assert passes and min(float(passes.group(1)), float(passes.group(2))) >= 0.9, out
    assert re.search(r"\| OS1-128 pcap \(3 frames\) \| 2 \| [A-H] / ", out), out  # classes frame by frame
    assert re.search(r"\| OS1-128 pcap \(3 frames\) \| left \| 0\.50 \| -?\d\.\d{3} \|", out), out
