"""Locations shared by the Python tests."""

import shutil
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
