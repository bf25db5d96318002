"""Road surfaces: an ISO 8608 random height field plus speed bumps, potholes, grade and cross-slope.

World frame: x, y horizontal, z up, metres. The surface is z = grade·x + cross_slope·y + relief(x, y), where the
*relief* (rough field + bumps + potholes) is the height above the road's mean plane: what a wheel profile measures.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

ISO_CLASSES = "ABCDEFGH"
N0_CPM = 0.1  #: ISO 8608 reference spatial frequency, cycles/m


def class_gd_n0(iso_class: str) -> float:
    """Geometric mean G_d(n0) of an ISO 8608 class, m³ (A: 16e-6, each class 4× the previous)."""
    if not isinstance(iso_class, str) or len(iso_class) != 1 or iso_class.upper() not in ISO_CLASSES:
        raise ValueError(f"ISO 8608 class must be one of {ISO_CLASSES!r}, got {iso_class!r}")
    return 16e-6 * 4.0 ** ISO_CLASSES.index(iso_class.upper())


def iso_psd(n, gd_n0: float, waviness: float = 2.0) -> np.ndarray:
    """One-sided displacement PSD G_d(n) = G_d(n0)·(n/n0)^−w, m³; n in cycles/m (> 0)."""
    return gd_n0 * (np.asarray(n, dtype=float) / N0_CPM) ** -waviness


@dataclass(frozen=True)
class RoughField:
    """Stationary Gaussian height field on a periodic grid (bilinear in between, repeating outside).

    Along every line y = const its one-sided displacement PSD is G_d(n) = G_d(n0)(n/n0)^−w in expectation, for
    n from 1/length_m to the grid's Nyquist frequency 1/(2·step_m). The lateral structure is that of an isotropic
    field (2-D spectrum ∝ |k|^−(w+1)), normalised column by column so the longitudinal PSD is exact.
    """

    heights: np.ndarray  #: (ny, nx) m; heights[j, i] at y = j·step, x = i·step
    step_m: float
    gd_n0: float
    waviness: float

    @classmethod
    def generate(cls, gd_n0: float, waviness: float = 2.0, *, length_m: float = 102.4, width_m: float = 12.8,
                 step_m: float = 0.025, seed: int = 0) -> "RoughField":
        if not (gd_n0 >= 0 and np.isfinite(gd_n0)):
            raise ValueError(f"gd_n0 must be a finite value >= 0 m³, got {gd_n0}")
        if not (step_m > 0 and length_m >= 4 * step_m and width_m >= 4 * step_m):
            raise ValueError(f"need step_m > 0 and length_m, width_m >= 4 steps, got {step_m}, {length_m}, {width_m}")
        nx, ny = int(round(length_m / step_m)), int(round(width_m / step_m))
        nx += nx % 2
        kx = np.fft.rfftfreq(nx, step_m)  # cycles/m, 0 … Nyquist
        ky = np.fft.fftfreq(ny, step_m)
        target = np.zeros_like(kx)
        target[1:-1] = iso_psd(kx[1:-1], gd_n0, waviness)  # no mean, no Nyquist column (both would be real)
        # Lateral shape per column: the isotropic spectrum's cross-section, normalised to sum 1 over ky.
        with np.errstate(divide="ignore"):
            shape = np.hypot(kx[None, :], ky[:, None]) ** -(waviness + 1.0)
        shape[:, 0] = 0.0
        shape /= np.maximum(shape.sum(axis=0, keepdims=True), np.finfo(float).tiny)
        # irfft2 makes each row's DFT coefficient at kx equal (1/ny)·Σ_ky C; the one-sided periodogram of a row,
        # 2|Z|²·step/nx, must have expectation G(kx), so E|C|² = ny²·nx·G/(2·step)·shape.
        variance = ny**2 * nx * target[None, :] / (2 * step_m) * shape
        rng = np.random.default_rng(seed)
        coeffs = (rng.standard_normal(variance.shape) + 1j * rng.standard_normal(variance.shape)) * np.sqrt(variance / 2)
        heights = np.fft.irfft2(coeffs, s=(ny, nx))
        return cls(heights=heights, step_m=float(step_m), gd_n0=float(gd_n0), waviness=float(waviness))

    @property
    def length_m(self) -> float:
        return self.heights.shape[1] * self.step_m

    @property
    def width_m(self) -> float:
        return self.heights.shape[0] * self.step_m

    def height(self, x, y) -> np.ndarray:
        """Bilinear interpolation of the periodic grid at world (x, y), m."""
        ny, nx = self.heights.shape
        gx, gy = np.asarray(x, float) / self.step_m, np.asarray(y, float) / self.step_m
        ix, iy = np.floor(gx), np.floor(gy)
        fx, fy = gx - ix, gy - iy
        i0, j0 = ix.astype(np.int64) % nx, iy.astype(np.int64) % ny
        i1, j1 = (i0 + 1) % nx, (j0 + 1) % ny
        h = self.heights
        return ((h[j0, i0] * (1 - fx) + h[j0, i1] * fx) * (1 - fy)
                + (h[j1, i0] * (1 - fx) + h[j1, i1] * fx) * fy)


BUMP_SHAPES = ("sine", "circular", "trapezoid")


@dataclass(frozen=True)
class SpeedBump:
    """A bump across the road at world x = x_m (its centre), height_m high and length_m long along x.

    Shapes: "sine" (raised cosine), "circular" (a circular segment through the ends and the top), "trapezoid"
    (linear ramps of ramp_m each and a flat top). It spans y_min_m ≤ y ≤ y_max_m (default: the whole road).
    """

    x_m: float
    height_m: float
    length_m: float
    shape: str = "sine"
    ramp_m: float = 0.3
    y_min_m: float = -np.inf
    y_max_m: float = np.inf

    def __post_init__(self):
        if self.shape not in BUMP_SHAPES:
            raise ValueError(f"bump shape must be one of {BUMP_SHAPES}, got {self.shape!r}")
        if not (self.length_m > 0 and self.height_m >= 0):
            raise ValueError(f"bump needs length_m > 0 and height_m >= 0, got {self.length_m}, {self.height_m}")
        if self.shape == "trapezoid" and not 0 < 2 * self.ramp_m <= self.length_m:
            raise ValueError(f"trapezoid ramps (2 × {self.ramp_m} m) must fit in the length {self.length_m} m")

    def height(self, x, y) -> np.ndarray:
        u = np.asarray(x, float) - self.x_m  # along the bump, 0 at its centre
        half = self.length_m / 2
        inside = (np.abs(u) < half) & (np.asarray(y) >= self.y_min_m) & (np.asarray(y) <= self.y_max_m)
        if self.shape == "sine":
            z = self.height_m * 0.5 * (1 + np.cos(np.pi * u / half))
        elif self.shape == "circular":
            radius = (half**2 + self.height_m**2) / (2 * self.height_m) if self.height_m > 0 else np.inf
            z = np.sqrt(np.maximum(radius**2 - u**2, 0.0)) - (radius - self.height_m) if self.height_m > 0 else 0 * u
        else:
            z = self.height_m * np.clip((half - np.abs(u)) / self.ramp_m, 0.0, 1.0)
        return np.where(inside, z, 0.0)


@dataclass(frozen=True)
class GradeChange:
    """The grade changes by `change` (m/m) at world x = x_m: height change·(x − x_m) beyond it, up to x = until_m
    (level again after it, so the relief stays bounded). A rise then a fall — a positive grade and a negative
    change — is a crest; the opposite a sag."""

    x_m: float
    change: float
    until_m: float = 80.0

    def __post_init__(self):
        if not self.until_m > self.x_m:
            raise ValueError(f"grade change needs until_m > x_m, got {self.until_m} <= {self.x_m}")

    def height(self, x, y) -> np.ndarray:
        run = np.clip(np.asarray(x, float) - self.x_m, 0.0, self.until_m - self.x_m)
        return self.change * run + 0.0 * np.asarray(y, float)

    def bounds(self) -> tuple[float, float]:
        reach = self.change * (self.until_m - self.x_m)
        return min(reach, 0.0), max(reach, 0.0)


@dataclass(frozen=True)
class Pothole:
    """A round depression depth_m deep with radius radius_m centred at world (x_m, y_m).

    Shapes: "bowl" (raised-cosine profile) or "cylinder" (vertical walls, flat bottom).
    """

    x_m: float
    y_m: float
    radius_m: float
    depth_m: float
    shape: str = "bowl"

    def __post_init__(self):
        if self.shape not in ("bowl", "cylinder"):
            raise ValueError(f"pothole shape must be 'bowl' or 'cylinder', got {self.shape!r}")
        if not (self.radius_m > 0 and self.depth_m >= 0):
            raise ValueError(f"pothole needs radius_m > 0 and depth_m >= 0, got {self.radius_m}, {self.depth_m}")

    def height(self, x, y) -> np.ndarray:
        r = np.hypot(np.asarray(x, float) - self.x_m, np.asarray(y, float) - self.y_m)
        if self.shape == "cylinder":
            return np.where(r < self.radius_m, -self.depth_m, 0.0)
        return np.where(r < self.radius_m, -self.depth_m * 0.5 * (1 + np.cos(np.pi * r / self.radius_m)), 0.0)


@dataclass(frozen=True)
class Road:
    """z = grade·x + cross_slope·y + relief(x, y) (grade and cross_slope in m/m, positive rising to +x, +y)."""

    rough: Optional[RoughField] = None  #: the random relief; None for a smooth road
    grade: float = 0.0
    cross_slope: float = 0.0
    bumps: tuple = ()
    potholes: tuple = ()
    grade_changes: tuple = ()  #: GradeChange features: crests and sags the plane alone has not
    iso_class: Optional[str] = None  #: the class the rough field was drawn from, if any

    @classmethod
    def iso8608(cls, iso_class: str, *, seed: int = 0, waviness: float = 2.0, **kwargs) -> "Road":
        """A road whose relief is an ISO 8608 field at the class's geometric mean G_d(n0)."""
        field_kwargs = {k: kwargs.pop(k) for k in ("length_m", "width_m", "step_m") if k in kwargs}
        rough = RoughField.generate(class_gd_n0(iso_class), waviness, seed=seed, **field_kwargs)
        return cls(rough=rough, iso_class=iso_class.upper(), **kwargs)

    @property
    def gd_n0(self) -> float:
        """G_d(n0) of the rough field, m³ (0 without one)."""
        return self.rough.gd_n0 if self.rough is not None else 0.0

    def relief(self, x, y) -> np.ndarray:
        """Height above the mean plane: rough field + bumps + potholes, m."""
        x, y = np.asarray(x, float), np.asarray(y, float)
        z = self.rough.height(x, y) if self.rough is not None else np.zeros(np.broadcast(x, y).shape)
        for feature in (*self.bumps, *self.potholes, *self.grade_changes):
            z = z + feature.height(x, y)
        return z

    def plane_height(self, x, y) -> np.ndarray:
        return self.grade * np.asarray(x, float) + self.cross_slope * np.asarray(y, float)

    def height(self, x, y) -> np.ndarray:
        return self.plane_height(x, y) + self.relief(x, y)

    def relief_bounds(self) -> tuple[float, float]:
        """(lowest, highest) relief anywhere, m: the slab a ray must cross to meet the surface."""
        lo = hi = 0.0
        if self.rough is not None:
            lo, hi = float(self.rough.heights.min()), float(self.rough.heights.max())
        hi += sum(max(b.height_m, 0.0) for b in self.bumps)
        lo -= sum(p.depth_m for p in self.potholes)
        lo += sum(g.bounds()[0] for g in self.grade_changes)
        hi += sum(g.bounds()[1] for g in self.grade_changes)
        return lo, hi
