"""Locations shared by the Python tests."""

import shutil
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "tests" / "data"
KITTI_FRAMES = sorted((DATA / "semantickitti").glob("*.bin"))
PCD_FILE = DATA / "pcd" / "patchwork_128ring_000000.pcd"
KITTI_SENSOR_HEIGHT = 1.73  # m, Velodyne HDL-64E on the KITTI car


def cli() -> str:
    """The installed `roadpreview` binary: beside this interpreter (a venv), else on PATH."""
    beside = Path(sys.executable).parent / "roadpreview"
    found = str(beside) if beside.exists() else shutil.which("roadpreview")
    assert found, "the roadpreview CLI is not installed (pip install .)"
    return found


def run_cli(*args, check=True) -> subprocess.CompletedProcess:
    """Runs the CLI with the given arguments; with `check`, asserts it succeeded."""
    proc = subprocess.run([cli(), *map(str, args)], capture_output=True, text=True, timeout=120)
    if check:
        assert proc.returncode == 0, proc.stderr
    return proc


def run_quick_bench(script: str) -> str:
    """stdout of ``bench/<script> --quick``, run by this interpreter; asserts it succeeded."""
    proc = subprocess.run([sys.executable, str(REPO / "bench" / script), "--quick"], cwd=REPO, capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout
