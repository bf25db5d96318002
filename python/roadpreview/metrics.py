# SPDX-License-Identifier: BSD-3-Clause
"""Repeatability of a height profile, a measure that needs no ground truth (docs/method.md §9).

Profiler certification compares repeated runs over the same road: AASHTO R 56 (Standard Practice for Certification
of Inertial Profiling Systems) rates their agreement by the cross-correlation of the IRI-filtered profiles
(Karamihas & Gillespie, *Development of Cross Correlation for Objective Comparison of Profiles*, UMTRI, 2002),
and ASTM E950 states a profiler's precision as the spread of repeated elevation measurements. Here the "runs"
are two views of the same stretch of road in the world frame, e.g. one frame's profile where the stretch lies
15–25 m ahead and a later frame's where it lies 5–15 m ahead.

    rep = rp.repeatability(z_far, z_near, ds=0.1)     # both sampled on the same world-frame grid, NaN = missing
    rep.correlation, rep.rms_m, rep.length_m
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from .reference.iri import moving_average_samples, suspension_slope
from .reference.runs import longest_run

MIN_LENGTH_M = 5.0  # shorter common stretches say too little (the IRI filter's longest response is ~ 5 m)


@dataclass
class Repeatability:
    correlation: Optional[float] = None  #: cross-correlation of the IRI-filtered profiles, −1…1 (1 = identical)
    rms_m: Optional[float] = None  #: RMS of the height difference about its best line (offset and grade), m
    filtered_rms: Optional[float] = None  #: RMS difference of the IRI-filtered profiles, m/km (= mm/m)
    length_m: float = 0.0  #: length of the common stretch compared, m
    reason: Optional[str] = None  #: why there is no value


def _check(z, name: str) -> np.ndarray:
    z = np.asarray(z, dtype=np.float64)
    if z.ndim != 1:
        raise ValueError(f"repeatability: profile {name} must be 1-D, got shape {z.shape}")
    if np.isinf(z).any():
        raise ValueError(f"repeatability: profile {name} holds infinite heights (NaN marks missing bins)")
    return z


def repeatability(z_a, z_b, ds: float, min_length_m: float = MIN_LENGTH_M) -> Repeatability:
    """Agreement of two height profiles (m) of the same stretch, sampled every ds metres on the same grid of
    world-frame positions (NaN = missing), over the longest run of bins where both hold a height.

    correlation = Σ f_a·f_b / √(Σ f_a² · Σ f_b²), f the IRI quarter-car filter's output (docs/method.md §6:
    250 mm moving average, golden car at 80 km/h, sprung − unsprung slope) over that run; rms_m the RMS of
    z_a − z_b after removing its least-squares line (a per-frame offset and grade are not roughness)."""
    a, b = _check(z_a, "a"), _check(z_b, "b")
    if a.shape != b.shape:
        raise ValueError(f"repeatability: the profiles must share one grid, got {a.shape[0]} and {b.shape[0]} bins")
    if not (math.isfinite(ds) and ds > 0):
        raise ValueError(f"repeatability: ds must be a positive number of metres, got {ds}")
    start, stop = longest_run(~np.isnan(a) & ~np.isnan(b))
    length = (stop - start - 1) * ds if stop > start else 0.0
    if stop - start <= moving_average_samples(ds) or length < min_length_m - 1e-9:
        return Repeatability(length_m=length, reason="common stretch too short")
    a, b = a[start:stop], b[start:stop]
    s = np.arange(len(a)) * ds
    difference = a - b
    difference -= np.polyval(np.polyfit(s, difference, 1), s)
    f_a, f_b = suspension_slope(a, ds), suspension_slope(b, ds)
    power = math.sqrt(float(np.sum(f_a**2) * np.sum(f_b**2)))
    correlation = float(np.sum(f_a * f_b) / power) if power > 0 else (1.0 if not f_a.any() and not f_b.any() else 0.0)
    return Repeatability(correlation=correlation, rms_m=float(np.sqrt(np.mean(difference**2))),
                         filtered_rms=float(np.sqrt(np.mean((f_a - f_b) ** 2)) * 1000.0), length_m=length)


def world_profile(profile_s, profile_z, travelled_m: float, grid_m) -> np.ndarray:
    """A straight-ahead profile (arc length s ahead of the wheel, m) of a vehicle that has travelled
    `travelled_m` along its path, resampled at world-frame positions `grid_m` along the same path (NaN where
    the profile has no bin). Bins are matched to the nearest grid position within half a bin."""
    s = np.asarray(profile_s, dtype=np.float64) + travelled_m
    z = np.asarray(profile_z, dtype=np.float64)
    grid = np.asarray(grid_m, dtype=np.float64)
    if s.shape != z.shape or s.ndim != 1:
        raise ValueError(f"world_profile: s and z must be 1-D and of one length, got shapes {s.shape} and {z.shape}")
    if len(s) < 2:
        return np.full(len(grid), np.nan)
    ds = s[1] - s[0]
    index = np.rint((grid - s[0]) / ds).astype(np.int64)
    inside = (index >= 0) & (index < len(s)) & (np.abs(s[np.clip(index, 0, len(s) - 1)] - grid) <= ds / 2 + 1e-9)
    out = np.full(len(grid), np.nan)
    out[inside] = z[index[inside]]
    return out
