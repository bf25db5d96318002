"""Pure-numpy reference implementation of docs/method.md: the independent test oracle for the C++ core. Its beam
calibration and roadside modules use scipy too (sparse least squares, image labelling, assignment):
``pip install 'roadpreview[reference]'``.

Written for clarity, not speed; every stage function below has a C++ twin with the same name.
"""

import numpy as _np

from .frames import to_base_frame
from .fusion import FusedMap, integrate_motion, process_fused
from .ground import fit_ground, fit_plane
from .obstacles import Obstacles, PathObstacles, blocked_bins, cluster_labels, find_obstacles, wheel_obstacles
from .iri import Iri, noise_iri, profile_iri, rectified_slope
from .mounting import check_mounting, estimate_mounting, mounting_from_plane
from .path import plan_path
from .pipeline import Result, process
from .profile import Profile, fill_gaps, level_points, wheel_profile
from .readout import Readout
from .route import Route, Stitched
from . import stereo
from .roughness import (
    ISO_CLASSES,
    ISO_GEOMETRIC_MEANS,
    Roughness,
    analyze_roughness,
    displacement_psd,
    iso_class,
    longest_valid_stretch,
    vehicle_roughness,
)
from .support import noise_psd, resolved_fraction

POINT_DTYPE = _np.float64  #: points are used in double precision

__all__ = [
    "POINT_DTYPE",
    "ISO_CLASSES",
    "ISO_GEOMETRIC_MEANS",
    "Obstacles",
    "PathObstacles",
    "FusedMap",
    "Profile",
    "Readout",
    "Result",
    "Route",
    "Roughness",
    "Stitched",
    "analyze_roughness",
    "blocked_bins",
    "cluster_labels",
    "displacement_psd",
    "fill_gaps",
    "find_obstacles",
    "Iri",
    "noise_iri",
    "noise_psd",
    "profile_iri",
    "rectified_slope",
    "resolved_fraction",
    "check_mounting",
    "estimate_mounting",
    "mounting_from_plane",
    "fit_ground",
    "fit_plane",
    "integrate_motion",
    "iso_class",
    "level_points",
    "longest_valid_stretch",
    "plan_path",
    "process",
    "process_fused",
    "stereo",
    "to_base_frame",
    "vehicle_roughness",
    "wheel_obstacles",
]
