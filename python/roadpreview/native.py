"""The C++ core's stage functions with the call shapes of ``roadpreview.reference``.

Tests run the same known-answer cases on both modules and compare them on shared inputs.
"""

from __future__ import annotations

import numpy as np

from ._native import core
from .config import Config

POINT_DTYPE = np.float32  #: the C++ core reads points as float32 (x, y, z rounded to ~1e-7 relative)
ISO_CLASSES = "ABCDEFGH"
ISO_GEOMETRIC_MEANS = tuple(16e-6 * 4.0**k for k in range(8))  # m³, ISO 8608 class centres at n0


def _cfg(cfg: Config | None) -> str:
    return (cfg if cfg is not None else Config()).to_json()


def process(points, speed, yaw_rate, cfg: Config | None = None):
    from .estimator import Estimator

    return Estimator(cfg).process(points, speed, yaw_rate)


def to_base_frame(points, cfg: Config | None = None):
    return core().to_base_frame(points, _cfg(cfg))


def fit_plane(points_xyz):
    plane = core().fit_plane(np.asarray(points_xyz))
    if plane is None:
        raise ValueError("no plane: fewer than 3 points, or all of them on one line")
    return plane


def fit_ground(base_xyz, cfg: Config | None = None):
    return core().fit_ground(np.asarray(base_xyz), _cfg(cfg))


def plan_path(speed, yaw_rate, cfg: Config | None = None):
    return core().plan_path(float(speed), float(yaw_rate), _cfg(cfg))


def wheel_profile(ground_xyz, plane, path, wheel, speed, yaw_rate, cfg: Config | None = None):
    """``path`` is accepted for call-shape parity; the C++ side plans it again from speed and yaw rate."""
    if wheel not in ("left", "right"):
        raise ValueError(f"wheel must be 'left' or 'right', got {wheel!r}")
    left, right = core().wheel_profiles(np.asarray(ground_xyz), plane, float(speed), float(yaw_rate), _cfg(cfg))
    return left if wheel == "left" else right


def level_points(xyz, plane):
    return core().level_points(np.asarray(xyz), [float(v) for v in plane])


def fill_gaps(z, ds, max_gap_m, blocked=None):
    flags = None if blocked is None else np.asarray(blocked, dtype=bool).tolist()
    return core().fill_gaps(np.asarray(z, dtype=float), float(ds), float(max_gap_m), flags)


def longest_valid_stretch(z):
    return tuple(core().longest_valid_stretch(np.asarray(z, dtype=float)))


def displacement_psd(x, ds):
    return core().displacement_psd(np.asarray(x, dtype=float), float(ds))


def analyze_roughness(z, ds, cfg: Config | None = None, *, count=None, spread=None):
    return core().analyze_roughness(np.asarray(z, dtype=float), float(ds), _cfg(cfg), count, spread)


def vehicle_roughness(z_left, z_right, ds, cfg: Config | None = None, *, count_left=None, spread_left=None,
                      count_right=None, spread_right=None):
    return core().vehicle_roughness(np.asarray(z_left, dtype=float), np.asarray(z_right, dtype=float), float(ds),
                                    _cfg(cfg), count_left, spread_left, count_right, spread_right)


def noise_psd(count, spread, ds):
    return core().noise_psd(np.asarray(count), np.asarray(spread, dtype=float), float(ds))


def resolved_fraction(count, ds, n):
    return core().resolved_fraction(np.asarray(count), float(ds), np.asarray(n, dtype=float))


def rectified_slope(z, ds):
    return core().iri_rectified_slope(np.asarray(z, dtype=float), float(ds))


def noise_iri(count, spread, ds):
    return core().iri_noise(np.asarray(count), np.asarray(spread, dtype=float), float(ds))


def profile_iri(z, ds, cfg: Config | None = None):
    return core().profile_iri(np.asarray(z, dtype=float), float(ds), _cfg(cfg))


def iso_class(gd_n0):
    return core().iso_class(float(gd_n0))


def cluster_labels(xyz, cfg: Config | None = None):
    return core().cluster_labels(np.asarray(xyz), _cfg(cfg))


def find_obstacles(base_xyz, ground_mask, plane, cfg: Config | None = None):
    return core().find_obstacles(np.asarray(base_xyz), np.asarray(ground_mask), [float(v) for v in plane],
                                 _cfg(cfg))


def wheel_obstacles(base_xyz, labels, obstacles, plane, path, wheel, speed, yaw_rate, cfg: Config | None = None):
    """``path`` is accepted for call-shape parity; the C++ side plans it again from speed and yaw rate."""
    return core().wheel_obstacles(np.asarray(base_xyz), np.asarray(labels), obstacles,
                                  [float(v) for v in plane], float(speed), float(yaw_rate), wheel, _cfg(cfg))


def blocked_bins(s_start, s_end, cfg: Config | None = None):
    return core().blocked_bins(np.atleast_1d(np.asarray(s_start, dtype=float)).tolist(),
                               np.atleast_1d(np.asarray(s_end, dtype=float)).tolist(), _cfg(cfg))


def estimate_mounting(points, cfg: Config | None = None):
    return core().estimate_mounting(points, _cfg(cfg))
