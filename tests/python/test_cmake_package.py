"""C++ consumers: find_package(roadpreview) against the tree `pip install .` installed."""

import shutil
import subprocess

import pytest

import roadpreview as rp
from paths import REPO


@pytest.mark.skipif(shutil.which("cmake") is None, reason="cmake is not installed")
def test_consumer_builds_and_runs_against_the_pip_installed_package(tmp_path):
    build = tmp_path / "build"
    subprocess.run(["cmake", "-S", REPO / "tests" / "consumer", "-B", build, f"-Droadpreview_DIR={rp.cmake_dir()}"],
                   check=True, capture_output=True)
    subprocess.run(["cmake", "--build", build], check=True, capture_output=True)
    for program in ("consumer", "consumer_core", "consumer_io"):  # the umbrella target; the core alone; the I/O alone
        proc = subprocess.run([build / program], capture_output=True, text=True)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        assert f"roadpreview {rp.__version__}" in proc.stdout or program == "consumer_io"
    needed = subprocess.run(["readelf", "-d", build / "consumer_core"], capture_output=True, text=True).stdout
    assert "libroadpreview_core" in needed and "libroadpreview_io" not in needed and "libpcap" not in needed
