"""Roughness of a height profile (docs/method.md §4 Roughness): stretch, PSD, band, bias-corrected
log fit, ISO 8608 class, octave bands, and the two-wheel vehicle result."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..config import Config

ISO_CLASSES = "ABCDEFGH"
ISO_GEOMETRIC_MEANS = 1e-6 * 4.0 ** np.arange(2, 10)  # 16, 64, ..., 262144 (×10⁻⁶ m³)
ISO_CLASS_LIMITS = 2.0 * ISO_GEOMETRIC_MEANS[:-1]  # geometric midpoints 32, 128, ..., 131072 (×10⁻⁶ m³)
N0_CPM = 0.1  # ISO 8608 reference spatial frequency
OCTAVE_CENTERS = 2.0 ** np.arange(-6, 3)  # ISO 8608 octave band centres, cycles/m

NO_VALID_BIN = "no valid profile"
TOO_SHORT = "valid stretch too short"
TOO_FEW_ORDINATES = "too few PSD ordinates in band"
BAND_EDGE_TOLERANCE = 1e-9  # relative: an ordinate sitting on a band edge is inside


def _empty() -> np.ndarray:
    return np.zeros(0)


@dataclass
class Roughness:
    iso_class: Optional[str] = None
    gd_n0: Optional[float] = None  #: G_d(n0) of the w = 2 fit, m³
    gd_n0_free: Optional[float] = None  #: G_d(n0) of the free-w fit, m³
    waviness: Optional[float] = None  #: w of the free-w fit
    band: Optional[tuple] = None  #: (lo, hi) cycles/m actually used
    n: np.ndarray = field(default_factory=_empty)  #: spatial frequencies incl. n = 0, cycles/m
    psd: np.ndarray = field(default_factory=_empty)  #: G_d(n), m³
    octave_centers: np.ndarray = field(default_factory=_empty)
    octave_gd: np.ndarray = field(default_factory=_empty)
    reason: Optional[str] = None  #: why there is no class (None when classified)


def iso_class(gd_n0: float) -> str:
    """ISO 8608 class of G_d(n0) in m³; a value exactly on a limit belongs to the rougher class."""
    if np.isnan(gd_n0):
        raise ValueError("gd_n0 is NaN")
    return ISO_CLASSES[int(np.count_nonzero(gd_n0 >= ISO_CLASS_LIMITS))]


def true_runs(mask) -> list[tuple[int, int]]:
    """Half-open (start, stop) of every run of consecutive True values, in order."""
    padded = np.concatenate(([False], np.asarray(mask, dtype=bool), [False]))
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    return list(zip(edges[0::2].tolist(), edges[1::2].tolist()))


def _longest_run(mask) -> tuple[int, int]:
    runs = true_runs(mask)
    if not runs:
        return 0, 0
    lengths = [stop - start for start, stop in runs]
    return runs[int(np.argmax(lengths))]  # argmax picks the first on ties


def longest_valid_stretch(z) -> tuple[int, int]:
    """(start, stop) of the longest run of non-NaN bins, the first one on ties; (0, 0) when there is none."""
    return _longest_run(~np.isnan(np.asarray(z, dtype=np.float64)))


def detrend(x: np.ndarray) -> np.ndarray:
    """x minus its least-squares line a + b·j (same residuals as a line in s = j·Δ)."""
    j = np.arange(len(x)) - (len(x) - 1) / 2
    slope = (j @ x) / (j @ j)
    return x - x.mean() - slope * j


def periodic_hann(n: int) -> np.ndarray:
    return 0.5 * (1 - np.cos(2 * np.pi * np.arange(n) / n))


def displacement_psd(x, ds: float) -> tuple[np.ndarray, np.ndarray]:
    """One-sided displacement PSD (n, G_d) of an all-finite stretch: detrend, periodic Hann, FFT (§4 steps 2–5)."""
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 1 or len(x) < 2 or not np.all(np.isfinite(x)):
        raise ValueError("displacement_psd needs a 1-D, all-finite stretch of at least 2 samples")
    count = len(x)
    window = periodic_hann(count)
    power_loss = np.mean(window**2)  # U
    spectrum = np.fft.rfft(detrend(x) * window)
    one_sided = np.full(len(spectrum), 2.0)
    one_sided[0] = 1.0
    if count % 2 == 0:
        one_sided[-1] = 1.0  # the Nyquist ordinate has no mirror image
    psd = one_sided * np.abs(spectrum) ** 2 * ds / (count * power_loss)
    freq_step = 1.0 / (count * ds)
    return np.arange(len(spectrum)) * freq_step, psd


def analysis_band(length: float, ds: float, cfg: Config) -> tuple[float, float]:
    r = cfg.roughness
    return max(r.band_min_cpm, r.min_cycles / length), min(r.band_max_cpm, 1.0 / (2 * ds))


def octave_bands(n: np.ndarray, psd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean G_d (k >= 1) per ISO octave band n_c/√2 <= n < n_c·√2; bands without an ordinate are omitted."""
    centers, means = [], []
    for centre in OCTAVE_CENTERS:
        inside = (n > 0) & (n >= centre / np.sqrt(2)) & (n < centre * np.sqrt(2))
        if inside.any():
            centers.append(centre)
            means.append(psd[inside].mean())
    return np.array(centers), np.array(means)


def _fit_w2(n: np.ndarray, psd: np.ndarray) -> float:
    """G_d(n0) of ln G = ln G(n0) − 2 ln(n/n0), with the log-periodogram bias correction +γ."""
    with np.errstate(divide="ignore"):  # a zero ordinate (perfectly flat profile) gives G_d(n0) = 0
        return float(np.exp(np.mean(np.log(psd) + 2 * np.log(n / N0_CPM)) + np.euler_gamma))


def _fit_free(n: np.ndarray, psd: np.ndarray) -> tuple[Optional[float], Optional[float]]:
    """(waviness w, G_d(n0)) of the OLS fit ln G = A − w ln(n/n0); (None, None) if not finite."""
    t = np.log(n / N0_CPM)
    with np.errstate(divide="ignore", invalid="ignore"):
        y = np.log(psd)
        slope = ((t - t.mean()) @ (y - y.mean())) / ((t - t.mean()) @ (t - t.mean()))
        intercept = y.mean() - slope * t.mean()
    if not (np.isfinite(slope) and np.isfinite(intercept)):
        return None, None
    return float(-slope), float(np.exp(intercept + np.euler_gamma))


def classify_psd(n: np.ndarray, psd: np.ndarray, length: float, ds: float, cfg: Config) -> Roughness:
    """§4 steps 6–9 on a PSD of a stretch of the given length."""
    lo, hi = analysis_band(length, ds, cfg)
    centers, octave_gd = octave_bands(n, psd)
    result = Roughness(n=n, psd=psd, octave_centers=centers, octave_gd=octave_gd)
    in_band = (n > 0) & (n >= lo * (1 - BAND_EDGE_TOLERANCE)) & (n <= hi * (1 + BAND_EDGE_TOLERANCE))
    if lo >= hi or np.count_nonzero(in_band) < cfg.roughness.min_band_points:
        result.reason = TOO_FEW_ORDINATES
        return result
    result.band = (lo, hi)
    result.gd_n0 = _fit_w2(n[in_band], psd[in_band])
    result.waviness, result.gd_n0_free = _fit_free(n[in_band], psd[in_band])
    result.iso_class = iso_class(result.gd_n0)
    return result


def _stretch_problem(count: int, ds: float, cfg: Config) -> Optional[str]:
    if count == 0:
        return NO_VALID_BIN
    if count < 2 or count * ds < cfg.roughness.min_length_m - 1e-9:
        return TOO_SHORT
    return None


def analyze_roughness(z, ds: float, cfg: Config | None = None) -> Roughness:
    """The whole of §4 for one profile (NaN = missing bin)."""
    cfg = cfg or Config()
    z = np.asarray(z, dtype=np.float64)
    start, stop = longest_valid_stretch(z)
    problem = _stretch_problem(stop - start, ds, cfg)
    if problem:
        return Roughness(reason=problem)
    n, psd = displacement_psd(z[start:stop], ds)
    return classify_psd(n, psd, (stop - start) * ds, ds, cfg)


def vehicle_roughness(z_left, z_right, ds: float, cfg: Config | None = None) -> Roughness:
    """§4 on the mean of both wheels' PSDs over the longest run of bins valid in both profiles."""
    cfg = cfg or Config()
    z_left = np.asarray(z_left, dtype=np.float64)
    z_right = np.asarray(z_right, dtype=np.float64)
    if len(z_left) == 0 or len(z_right) == 0:
        return Roughness(reason=NO_VALID_BIN)
    if z_left.shape != z_right.shape:
        raise ValueError(f"left and right profiles differ in shape: {z_left.shape} vs {z_right.shape}")
    start, stop = _longest_run(~np.isnan(z_left) & ~np.isnan(z_right))
    problem = _stretch_problem(stop - start, ds, cfg)
    if problem:
        return Roughness(reason=problem)
    n, psd_left = displacement_psd(z_left[start:stop], ds)
    _, psd_right = displacement_psd(z_right[start:stop], ds)
    return classify_psd(n, (psd_left + psd_right) / 2, (stop - start) * ds, ds, cfg)
