"""What the points behind a height profile support (docs/noise-aware-roughness.md): the variance of each bin
height and the PSD those errors add to a stretch's periodogram (§1–2), and the share of the road's PSD that
the sampling resolves, given that the profile is linear between the bins that hold points (§3)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

# Variance of the median of n Gaussian values ≈ (π/2)·σ²/n (asymptotic; slightly high for small n, so the
# noise floor errs on the safe side). For n = 2 the median is the mean: σ²/2 exactly.
MEDIAN_VARIANCE_FACTOR = math.pi / 2
NYQUIST_TOLERANCE = 1e-9  # relative: a frequency on an interval's Nyquist frequency is resolved


def check_ds(ds) -> float:
    """The bin length ``ds`` (m) as a float; ValueError unless finite and > 0 (0 divides by zero, a negative ds
    gives negative PSDs)."""
    ds = float(ds)
    if not (math.isfinite(ds) and ds > 0):
        raise ValueError(f"ds must be finite and > 0 m, got {ds}")
    return ds


def pooled_variances(count, spread, band, max_spread_factor: float = np.inf, min_bins: int = 1) -> Optional[np.ndarray]:
    """Per bin, the pooled within-bin variance Σ(n − 1)s² / Σ(n − 1) of its band (``band``: small integers by
    range), over the band's bins of 2+ points spread at most max_spread_factor × its typical spread: its median, or
    the least median of the bands below it with min_bins such bins if smaller. A band with fewer than min_bins
    such bins borrows the pool of the nearest band below it, else of the nearest above; with too few in every
    band, one pool over them all. None when there is no such bin at all."""
    count, band = np.asarray(count, dtype=np.int64), np.asarray(band, dtype=np.int64)
    spread = np.asarray(spread, dtype=np.float64)
    measured = (count >= 2) & np.isfinite(spread)
    use = np.zeros(len(count), dtype=bool)
    nearer = np.inf  # honest noise does not grow with range: no band's typical spread exceeds a nearer band's
    for b in np.unique(band[measured]):
        mine = measured & (band == b)
        if mine.sum() >= min_bins:
            nearer = min(nearer, np.median(spread[mine]))
        typical = min(np.median(spread[mine]), nearer)
        limit = max_spread_factor * typical if np.isfinite(max_spread_factor) else np.inf
        use |= mine & (spread <= limit)
    if not use.any():
        return None

    def pool(bins):
        return np.sum((count[bins] - 1) * spread[bins] ** 2) / np.sum(count[bins] - 1)

    pools = {b: pool(use & (band == b)) for b in np.unique(band[use]) if np.sum(use & (band == b)) >= min_bins}
    if not pools:
        return np.full(len(count), pool(use))
    have = np.array(sorted(pools))

    def pool_of(b):
        below = have[have <= b]
        return pools[below.max()] if len(below) else pools[have.min()]

    return np.array([pool_of(b) for b in band], dtype=np.float64)


def backed_variances(count, spread) -> Optional[np.ndarray]:
    """Variance (m²) of the height of each bin of a stretch that holds points (NaN elsewhere), or None when no bin
    holds points or a single point's variance is unknown.

    Bins with 2+ points use their own sample variance s²: s²/2 for 2 points, (π/2)·s²/n from 3 on. A single-point
    bin uses s² when it carries a spread (a fused map's cell), else the pooled within-bin variance of the stretch's
    bins of 2+ points.
    """
    count = np.asarray(count, dtype=np.int64)
    spread = np.asarray(spread, dtype=np.float64)
    pooled = pooled_variances(count, spread, np.zeros(len(count)))
    variance = np.full(len(count), np.nan)
    single = count == 1
    variance[single] = spread[single] ** 2
    unknown = single & np.isnan(spread)
    if not (count > 0).any() or (unknown.any() and pooled is None):
        return None
    if unknown.any():
        variance[unknown] = pooled[unknown]
    variance[count == 2] = spread[count == 2] ** 2 / 2
    many = count >= 3
    variance[many] = MEDIAN_VARIANCE_FACTOR * spread[many] ** 2 / count[many]
    return variance


def interpolation_matrix(count) -> np.ndarray:
    """A (bins × backed bins): bin j's height error as a combination of the backed bins' errors. A backed bin is
    itself; an interpolated one (count 0) at fraction f between backed bins a and b is (1 − f)·a + f·b."""
    backed = np.flatnonzero(np.asarray(count) > 0)
    a = np.zeros((len(count), len(backed)))
    a[backed, np.arange(len(backed))] = 1.0
    for i in range(len(backed) - 1):
        lo, hi = backed[i], backed[i + 1]
        f = (np.arange(lo + 1, hi) - lo) / (hi - lo)
        a[lo + 1:hi, i] = 1 - f
        a[lo + 1:hi, i + 1] = f
    return a


def noise_psd(count, spread, ds: float, windowed: bool = True) -> Optional[np.ndarray]:
    """Expected one-sided PSD (m³, on the grid of displacement_psd) of the bin errors of a stretch: independent
    errors of the backed bins, carried into the gaps by the linear interpolation, windowed like the profile
    (periodic Hann; the detrend is neglected), or not at all (``windowed`` false: the errors' power averaged over
    the stretch, which the IRI's noise reads). None when the bin variances are unknown."""
    ds = check_ds(ds)
    variance = backed_variances(count, spread)
    if variance is None:
        return None
    count = np.asarray(count)
    n = len(count)
    a = interpolation_matrix(count)
    window = 0.5 * (1 - np.cos(2 * np.pi * np.arange(n) / n)) if windowed else np.ones(n)
    weighted = window[:, None] * a  # windowed error = weighted @ ε, ε independent with these variances
    spectra = np.fft.rfft(weighted, axis=0)  # (frequencies, backed bins)
    expected = np.abs(spectra) ** 2 @ variance[count > 0]  # E|X_k|²
    one_sided = np.full(len(expected), 2.0)
    one_sided[0] = 1.0
    if n % 2 == 0:
        one_sided[-1] = 1.0
    return one_sided * expected * ds / np.sum(window**2)


def backed_fraction(count) -> float:
    """Fraction of a stretch's bins that hold points (the rest are interpolated)."""
    count = np.asarray(count)
    return float(np.count_nonzero(count > 0) / len(count))


def interval_spacing(count, ds: float) -> np.ndarray:
    """Per bin of a stretch, the length (m) of the interval between consecutive backed bins it lies in (the
    left end included): ds where every bin holds points, (b − a)·ds across a gap from backed bin a to b."""
    backed = np.flatnonzero(np.asarray(count) > 0)
    spacing = np.full(len(count), ds)
    for a, b in zip(backed[:-1], backed[1:]):
        spacing[a:b] = (b - a) * ds
    return spacing


def resolved_fraction(count, ds: float, n: np.ndarray) -> np.ndarray:
    """Φ(n): the share of the road's PSD at each frequency n that survives in the profile, window-weighted over
    the stretch. Where points lie g apart and the profile is linear between them, a wave of frequency n keeps
    the amplitude sinc²(n·g) of linear interpolation (sinc x = sin πx / πx) up to the Nyquist frequency 1/(2g),
    and nothing is resolved above it."""
    spacing = interval_spacing(count, check_ds(ds))
    window_sq = (0.5 * (1 - np.cos(2 * np.pi * np.arange(len(spacing)) / len(spacing)))) ** 2
    x = np.asarray(n, dtype=float)[:, None] * spacing[None, :]
    kept = np.where(x <= 0.5 * (1 + NYQUIST_TOLERANCE), np.sinc(x) ** 4, 0.0)
    return kept @ window_sq / np.sum(window_sq)


@dataclass
class Support:
    """What the points behind a stretch's bins support."""

    noise: Optional[np.ndarray]  #: N_k, m³, expected PSD of the bin errors; None when unmeasurable
    resolved: np.ndarray  #: Φ_k, share of the road's PSD the sampling keeps
    backed: float  #: fraction of bins that hold points

    @classmethod
    def of(cls, count, spread, start: int, stop: int, ds: float, n: np.ndarray) -> Optional["Support"]:
        """The support of bins start…stop−1, or None without per-bin point counts."""
        if count is None or spread is None:
            return None
        count = np.asarray(count)[start:stop]
        spread = np.asarray(spread, dtype=np.float64)[start:stop]
        return cls(noise_psd(count, spread, ds), resolved_fraction(count, ds, n), backed_fraction(count))

    @classmethod
    def mean(cls, a: "Support", b: "Support") -> "Support":
        noise = None if a.noise is None or b.noise is None else (a.noise + b.noise) / 2
        return cls(noise, (a.resolved + b.resolved) / 2, (a.backed + b.backed) / 2)
