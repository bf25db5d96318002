"""roadpreview — road height profiles and ISO 8608 roughness ahead of the wheels, from LiDAR.

    import roadpreview as rp
    est = rp.Estimator(rp.Config(sensor_height=1.73))
    res = est.process(points, speed=5.0, yaw_rate=0.0)   # points: N×3 or N×4 float32/float64, sensor frame
    res.left.z, res.left.roughness.iso_class, res.vehicle.gd_n0, res.to_dict()

Frames: base frame x forward, y left, z up, origin on the ground; metres, seconds, radians.
``rp.reference`` is the pure-numpy implementation of the same method, used to cross-check the C++ core.
"""

from pathlib import Path

from . import reference, sim
from ._native import native_available
from .config import (Config, Extrinsics, FusionConfig, GroundConfig, IriConfig, ObstaclesConfig, PathConfig,
                     ProfileConfig, RoughnessConfig)
from .estimator import Estimator
from .metrics import Repeatability, repeatability, world_profile

if native_available():
    from . import io, range_sensor, roadside
    from . import batch, drive, geo, io_bags, odometry  # drives: bags, odometry, batches, maps (their deps lazily)
    from ._core import BeamCalibration, CalibrationError
    from .calibration import calibrate_beams, read_beam_calibration
    from .drive_runner import Drive, run
    from .readout import ProfileReadout
    from ._core import Iri, Obstacles, PathObstacles, Profile, Result, Roughness, __version__
else:  # a source checkout without the compiled extension: only the reference works
    __version__ = "0+source"


def cmake_dir() -> str:
    """Directory of the installed CMake package: ``cmake -Droadpreview_DIR=$(python -c ...)``."""
    return str(Path(__file__).resolve().parent / "lib" / "cmake" / "roadpreview")


__all__ = [
    "Config", "Extrinsics", "GroundConfig", "IriConfig", "PathConfig", "ProfileConfig", "RoughnessConfig",
    "ObstaclesConfig", "FusionConfig", "Estimator", "Result", "Profile", "Roughness", "Iri", "Obstacles",
    "PathObstacles", "io", "reference", "sim", "cmake_dir", "__version__", "calibrate_beams", "read_beam_calibration",
    "BeamCalibration", "CalibrationError", "Repeatability", "repeatability", "world_profile", "range_sensor", "run",
    "Drive", "roadside", "drive", "io_bags", "odometry", "batch", "geo", "ProfileReadout",
]
