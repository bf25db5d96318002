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


def test_the_wheel_holds_each_library_once_and_the_licence():
    """A wheel cannot hold symlinks: versioned, libX.so, libX.so.0 and libX.so.0.1.0 were three full copies (3 MB
    of an 8 MB wheel). And BSD-3-Clause asks that the licence travel with every redistribution."""
    from importlib import metadata
    from pathlib import Path

    libraries = sorted(p.name for p in (Path(rp.cmake_dir()).parents[1]).glob("libroadpreview*"))
    assert libraries == ["libroadpreview_core.so", "libroadpreview_io.so", "libroadpreview_roadside.so",
                         "libroadpreview_roadside_video.so"]
    licence = [f for f in metadata.files("roadpreview") if f.name == "LICENSE"]
    assert licence and "BSD 3-Clause License" in licence[0].read_text()
