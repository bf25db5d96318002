"""Locations shared by the Python tests."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "tests" / "data"
KITTI_FRAMES = sorted((DATA / "semantickitti").glob("*.bin"))
PCD_FILE = DATA / "pcd" / "patchwork_128ring_000000.pcd"
NUSCENES_BIN = DATA / "nuscenes" / "n015-2018-07-24-11-22-45+0800__LIDAR_TOP__1532402927647951.pcd.bin"
KITTI_SENSOR_HEIGHT = 1.73  # m, Velodyne HDL-64E on the KITTI car


def shared_data() -> Path:
    """The project's shared data set: $ROADPREVIEW_SHARED_DATA, else ../shared/data beside the repository (or beside
    the directory holding it, for a worktree); tests that need it skip when it is absent."""
    candidates = [os.environ.get("ROADPREVIEW_SHARED_DATA", "")] + [str(p / "shared" / "data") for p in REPO.parents[:2]]
    return Path(next((c for c in candidates if c and Path(c).is_dir()), candidates[1]))


STEREO_PAIR = shared_data() / "stereo" / "stereo_rcnn_kitti_object"  # KITTI colour pair, calib and Velodyne scan


def cli() -> str:
    """The installed `roadpreview` binary: beside this interpreter (a venv), else on PATH."""
    beside = Path(sys.executable).parent / "roadpreview"
    found = str(beside) if beside.exists() else shutil.which("roadpreview")
    assert found, "the roadpreview CLI is not installed (pip install .)"
    return found


OUSTER = DATA / "ouster"
VELODYNE = DATA / "velodyne"
OS1_128_PCAP = OUSTER / "OS-1-128_v2.3.0_1024x10_lb_n3.pcap"  # 3 frames; its metadata is found by name
OS1_128_META = OUSTER / "OS-1-128_v2.3.0_1024x10.json"
OS1_128_HEIGHT = 1.97  # m, estimated from the ground in the first frame (shared data field notes)


def run_bench(script: str, *args: str, timeout: int = 300) -> str:
    """stdout of ``python bench/<script> args`` run from the repository, which must succeed."""
    run = subprocess.run([sys.executable, str(REPO / "bench" / script), *args], cwd=REPO, capture_output=True,
                         text=True, timeout=timeout)
    assert run.returncode == 0, run.stderr
    return run.stdout


def run_cli(*args, check=True) -> subprocess.CompletedProcess:
    """Runs the CLI with the given arguments; with `check`, asserts it succeeded."""
    proc = subprocess.run([cli(), *map(str, args)], capture_output=True, text=True, timeout=120)
    if check:
        assert proc.returncode == 0, proc.stderr
    return proc


# The project's shared data (real recordings too large or not licensed for tests/data), found as shared_data()
# finds it (a worktree's too). Tests that need it skip when it is absent.
SHARED_DATA = shared_data()
