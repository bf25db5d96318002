"""Roughness of a height profile (docs/method.md §4 Roughness): stretch, PSD, band, bias-corrected
log fit, ISO 8608 class, octave bands, and the two-wheel vehicle result; noise-aware when the points behind
each bin are known (docs/noise-aware-roughness.md)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..config import Config
from .iri import Iri
from .runs import NO_VALID_BIN, longest_run, longest_valid_stretch
from .support import Support, check_ds

ISO_CLASSES = "ABCDEFGH"
ISO_GEOMETRIC_MEANS = 1e-6 * 4.0 ** np.arange(2, 10)  # 16, 64, ..., 262144 (×10⁻⁶ m³)
ISO_CLASS_LIMITS = 2.0 * ISO_GEOMETRIC_MEANS[:-1]  # geometric midpoints 32, 128, ..., 131072 (×10⁻⁶ m³)
N0_CPM = 0.1  # ISO 8608 reference spatial frequency
OCTAVE_CENTERS = 2.0 ** np.arange(-6, 3)  # ISO 8608 octave band centres, cycles/m

TOO_SHORT = "valid stretch too short"
TOO_FEW_ORDINATES = "too few PSD ordinates in band"
NOISE_UNKNOWN = "noise floor unknown"
NOISE_DOMINATES = "noise dominates the band"
BAND_EDGE_TOLERANCE = 1e-9  # relative: an ordinate sitting on a band edge is inside
WHITTLE_ITERATIONS = 60  # Fisher-scoring steps of the noise-aware fit
MAX_WHITTLE_STEP = 1.0  # in ln G_d(n0): scoring overshoots when it starts far (a spectrum far from n^−2)
# Variance of ln G_d(n0) from M ordinates of a Hann-windowed stretch is factor/M. Neighbouring ordinates are
# correlated (DFT coefficients −2/3 at lag 1, 1/6 at lag 2, so periodogram ordinates 4/9 and 1/36):
# log regression: (π²/6)·(1 + 2·[Li₂(4/9) + Li₂(1/36)]/ζ(2)); likelihood fit: 1 + 2·(4/9 + 1/36).
LOG_FIT_VARIANCE_FACTOR = math.pi**2 / 6 * 1.6504918528873
WHITTLE_VARIANCE_FACTOR = 1 + 2 * (4 / 9 + 1 / 36)


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
    confidence: Optional[float] = None  #: probability that the class is right, given the fit's spread
    noise_psd: Optional[np.ndarray] = None  #: m³, expected PSD of the bin errors on the grid n (None: unknown)
    noise_floor: Optional[float] = None  #: m³, mean of noise_psd over the analysis band
    backed_fraction: Optional[float] = None  #: bins of the stretch that hold points (None: unknown)
    band_limit: Optional[str] = None  #: what set the band's upper edge: requested, nyquist, sampling or noise
    iri: Iri = field(default_factory=Iri)  #: International Roughness Index of the same profile (§6)


def iso_class(gd_n0: float) -> str:
    """ISO 8608 class of G_d(n0) in m³; a value exactly on a limit belongs to the rougher class."""
    if not np.isfinite(gd_n0) or gd_n0 < 0:
        raise ValueError(f"gd_n0 must be finite and >= 0 m³, got {gd_n0}")
    return ISO_CLASSES[int(np.count_nonzero(gd_n0 >= ISO_CLASS_LIMITS))]


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
    ds = check_ds(ds)
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


def analysis_band(length: float, ds: float, cfg: Config) -> tuple[float, float, str]:
    """(lo, hi, what sets hi): the requested band clipped to what the stretch resolves (step 6)."""
    r = cfg.roughness
    lo = max(r.band_min_cpm, r.min_cycles / length)
    nyquist = 1.0 / (2 * ds)
    return (lo, r.band_max_cpm, "requested") if r.band_max_cpm <= nyquist else (lo, nyquist, "nyquist")


def in_band(n: np.ndarray, lo: float, hi: float) -> np.ndarray:
    return (n > 0) & (n >= lo * (1 - BAND_EDGE_TOLERANCE)) & (n <= hi * (1 + BAND_EDGE_TOLERANCE))


def octave_bands(n: np.ndarray, psd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean G_d (k >= 1) per ISO octave band n_c/√2 <= n < n_c·√2; bands without an ordinate are omitted."""
    centers, means = [], []
    for centre in OCTAVE_CENTERS:
        inside = (n > 0) & (n >= centre / np.sqrt(2)) & (n < centre * np.sqrt(2))
        if inside.any():
            centers.append(centre)
            means.append(psd[inside].mean())
    return np.array(centers), np.array(means)


def _log_psd(psd: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore"):  # a zero ordinate (perfectly flat profile) gives G_d(n0) = 0
        return np.log(psd)


def _fit_w2(n: np.ndarray, log_psd: np.ndarray) -> float:
    """G_d(n0) of ln G = ln G(n0) − 2 ln(n/n0), with the log-periodogram bias correction +γ."""
    return float(np.exp(np.mean(log_psd + 2 * np.log(n / N0_CPM)) + np.euler_gamma))


def _fit_free(n: np.ndarray, log_psd: np.ndarray) -> tuple[Optional[float], Optional[float]]:
    """(waviness w, G_d(n0)) of the OLS fit ln G = A − w ln(n/n0); (None, None) if not finite."""
    t = np.log(n / N0_CPM)
    with np.errstate(divide="ignore", invalid="ignore"):
        y = log_psd
        slope = ((t - t.mean()) @ (y - y.mean())) / ((t - t.mean()) @ (t - t.mean()))
        intercept = y.mean() - slope * t.mean()
    if not (np.isfinite(slope) and np.isfinite(intercept)):
        return None, None
    return float(-slope), float(np.exp(intercept + np.euler_gamma))


def _leading(indices: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """The indices from the first up to (not including) the first one where keep is False."""
    failing = np.flatnonzero(~keep)
    return indices[: failing[0] if len(failing) else len(indices)]


@dataclass
class _Fit:
    gd_n0: float
    variance: float  #: of ln gd_n0
    free: tuple  #: (waviness, G_d(n0)) of the free fit, or (None, None)
    reason: Optional[str] = None
    noise_bound: bool = False  #: the noise dominates: gd_n0 is the upper bound of the fit without noise


def _log_fit(n: np.ndarray, log_psd: np.ndarray, used: np.ndarray) -> _Fit:
    """§4 step 7: log-periodogram regression with w = 2, and the free-w fit, over the ordinates used."""
    return _Fit(_fit_w2(n[used], log_psd[used]), LOG_FIT_VARIANCE_FACTOR / len(used), _fit_free(n[used], log_psd[used]))


def _whittle_fit(n: np.ndarray, psd: np.ndarray, used: np.ndarray, resolved: np.ndarray, noise: np.ndarray):
    """(G_d(n0), signal share w_k of each ordinate) maximising the Whittle likelihood of exponential ordinates
    with E[G_k] = S_k + N_k, S_k = Φ_k·G_d(n0)·(n_k/n0)^−2: Fisher scoring in θ = ln G_d(n0) from the
    log-regression estimate, θ ← θ + Σw_k(G_k/E[G_k] − 1) / Σw_k², w_k = S_k/E[G_k], each step at most ±1."""
    shape = resolved[used] * (n[used] / N0_CPM) ** -2.0
    g, floor = psd[used], noise[used]
    theta = math.log(max(_fit_w2(n[used], _log_psd(g)), np.finfo(float).tiny))
    for _ in range(WHITTLE_ITERATIONS):
        expected = math.exp(theta) * shape + floor
        share = _ratio(math.exp(theta) * shape, expected)
        information = float(np.sum(share**2))
        if information < 1e-12:  # the signal has vanished below the noise
            break
        step = float(np.sum(share * (_ratio(g, expected) - 1))) / information
        theta += min(max(step, -MAX_WHITTLE_STEP), MAX_WHITTLE_STEP)
    signal = math.exp(theta) * shape
    return math.exp(theta), _ratio(signal, signal + floor)


def _ratio(part: np.ndarray, whole: np.ndarray) -> np.ndarray:
    """part / whole, 0 where whole is 0 (a flat, noiseless stretch: its ordinates carry no information)."""
    return np.divide(part, whole, out=np.zeros_like(part), where=whole > 0)


def _noise_aware_fit(n: np.ndarray, psd: np.ndarray, used: np.ndarray, support: Support, cfg: Config) -> _Fit:
    """docs/noise-aware-roughness.md §4–5: the likelihood fit with the noise PSD, valid when its effective number
    of signal-dominated ordinates Σw_k² reaches min_band_points; the free-w fit on the noise-corrected logs of
    the ordinates the signal dominates (w_k ≥ ½). Otherwise the fit without noise, an upper bound, gives class A
    if it is below class A's limit, and no class else."""
    if support.noise is None:
        return _Fit(0.0, 0.0, (None, None), NOISE_UNKNOWN)
    gd, share = _whittle_fit(n, psd, used, support.resolved, support.noise)
    effective = float(np.sum(share**2))
    if effective >= cfg.roughness.min_band_points:
        strong = share >= 0.5
        corrected = _log_psd(psd[used][strong]) - np.log(support.resolved[used][strong] / share[strong])
        free = _fit_free(n[used][strong], corrected) if np.count_nonzero(strong) >= 2 else (None, None)
        return _Fit(gd, WHITTLE_VARIANCE_FACTOR / effective, free)
    upper, _ = _whittle_fit(n, psd, used, support.resolved, np.zeros(len(n)))
    if iso_class(upper) != "A":
        return _Fit(upper, 0.0, (None, None), NOISE_DOMINATES, noise_bound=True)
    free = _fit_free(n[used], _log_psd(psd[used]))
    return _Fit(upper, WHITTLE_VARIANCE_FACTOR / len(used), free, noise_bound=True)


def class_confidence(gd_n0: float, variance: float) -> float:
    """Probability that the true G_d(n0) lies in the class of the estimate, for a normal error of ln G_d(n0)
    with this variance about the estimate."""
    k = ISO_CLASSES.index(iso_class(gd_n0))
    if gd_n0 <= 0:
        return 1.0
    sigma = math.sqrt(variance)

    def below(limit):  # P(true value < limit)
        return 0.5 * math.erfc((math.log(gd_n0) - math.log(limit)) / (sigma * math.sqrt(2)))

    upper = below(ISO_CLASS_LIMITS[k]) if k < len(ISO_CLASS_LIMITS) else 1.0
    lower = below(ISO_CLASS_LIMITS[k - 1]) if k > 0 else 0.0
    return upper - lower


def classify_psd(n: np.ndarray, psd: np.ndarray, length: float, ds: float, cfg: Config,
                 support: Optional[Support] = None) -> Roughness:
    """§4 steps 6–9 on a PSD of a stretch of the given length; with ``support`` (what the points behind the bins
    support) and ``roughness.noise_aware``, the band and fit of docs/noise-aware-roughness.md."""
    lo, hi, limit = analysis_band(length, ds, cfg)
    centers, octave_gd = octave_bands(n, psd)
    result = Roughness(n=n, psd=psd, octave_centers=centers, octave_gd=octave_gd, band_limit=limit)
    used = np.flatnonzero(in_band(n, lo, hi))
    noise_aware = support is not None and cfg.roughness.noise_aware
    # The band the sampling resolves: the ordinates up to the first one it no longer does.
    resolved = _leading(used, support.resolved[used] >= cfg.roughness.min_resolved_fraction) if noise_aware else used
    if support is not None:
        result.backed_fraction, result.noise_psd = support.backed, support.noise
        floor_band = resolved if len(resolved) else used  # the band the fit uses; the requested one if none is left
        if support.noise is not None and len(floor_band):
            result.noise_floor = float(np.mean(support.noise[floor_band]))
    if len(resolved) < len(used):
        hi = float(n[resolved[-1]]) if len(resolved) else lo
        used, result.band_limit = resolved, "sampling"
    if lo >= hi or len(used) < cfg.roughness.min_band_points:
        result.reason = TOO_FEW_ORDINATES
        return result
    fit = _noise_aware_fit(n, psd, used, support, cfg) if noise_aware else _log_fit(n, _log_psd(psd), used)
    if fit.noise_bound:
        result.band_limit = "noise"
    if fit.reason:
        result.reason = fit.reason
        return result
    result.band = (lo, hi)
    result.gd_n0 = fit.gd_n0
    result.waviness, result.gd_n0_free = fit.free
    result.iso_class = iso_class(fit.gd_n0)
    result.confidence = class_confidence(fit.gd_n0, fit.variance)
    return result


def _stretch_problem(count: int, ds: float, cfg: Config) -> Optional[str]:
    if count == 0:
        return NO_VALID_BIN  # an empty profile may have no spacing
    check_ds(ds)
    if count < 2 or count * ds < cfg.roughness.min_length_m - 1e-9:
        return TOO_SHORT
    return None


def _check_support(z: np.ndarray, count, spread, names: tuple[str, str]) -> None:
    """ValueError unless ``count`` and ``spread`` are both None, or both hold one entry per bin of ``z``: one
    alone would be ignored, a shorter one misread."""
    if (count is None) != (spread is None):
        raise ValueError(f"give both {names[0]} and {names[1]}, or neither")
    for name, values in zip(names, (count, spread)):
        if values is not None and np.shape(values) != z.shape:
            raise ValueError(f"{name} must have one entry per bin of the profile {z.shape}, "
                             f"got shape {np.shape(values)}")


def analyze_roughness(z, ds: float, cfg: Config | None = None, *, count=None, spread=None) -> Roughness:
    """The whole of §4 for one profile (NaN = missing bin); noise-aware when the bins' point counts and height
    spreads (the profile's ``count`` and ``spread``, both or neither) are given."""
    cfg = cfg or Config()
    z = np.asarray(z, dtype=np.float64)
    _check_support(z, count, spread, ("count", "spread"))
    start, stop = longest_valid_stretch(z)
    problem = _stretch_problem(stop - start, ds, cfg)
    if problem:
        return Roughness(reason=problem)
    n, psd = displacement_psd(z[start:stop], ds)
    return classify_psd(n, psd, (stop - start) * ds, ds, cfg, Support.of(count, spread, start, stop, ds, n))


def vehicle_roughness(z_left, z_right, ds: float, cfg: Config | None = None, *, count_left=None, spread_left=None,
                      count_right=None, spread_right=None) -> Roughness:
    """§4 on the mean of both wheels' PSDs over the longest run of bins valid in both profiles; noise-aware
    (the mean of the two wheels' support) when both profiles' counts and spreads are given."""
    cfg = cfg or Config()
    z_left = np.asarray(z_left, dtype=np.float64)
    z_right = np.asarray(z_right, dtype=np.float64)
    if len(z_left) == 0 or len(z_right) == 0:
        return Roughness(reason=NO_VALID_BIN)
    if z_left.shape != z_right.shape:
        raise ValueError(f"left and right profiles differ in shape: {z_left.shape} vs {z_right.shape}")
    _check_support(z_left, count_left, spread_left, ("count_left", "spread_left"))
    _check_support(z_right, count_right, spread_right, ("count_right", "spread_right"))
    start, stop = longest_run(~np.isnan(z_left) & ~np.isnan(z_right))
    problem = _stretch_problem(stop - start, ds, cfg)
    if problem:
        return Roughness(reason=problem)
    n, psd_left = displacement_psd(z_left[start:stop], ds)
    _, psd_right = displacement_psd(z_right[start:stop], ds)
    left = Support.of(count_left, spread_left, start, stop, ds, n)
    right = Support.of(count_right, spread_right, start, stop, ds, n)
    support = Support.mean(left, right) if left is not None and right is not None else None
    return classify_psd(n, (psd_left + psd_right) / 2, (stop - start) * ds, ds, cfg, support)


def vehicle_from_wheels(vehicle: Roughness, left: Roughness, right: Roughness) -> Roughness:
    """The vehicle's class never contradicts both wheels (method.md §4, "Vehicle"): two declined wheels decline
    it; two classified wheels with a declined common stretch give it the mean of their G_d(n0); with one wheel
    classified its own fit stands."""
    if left.iso_class is None and right.iso_class is None:
        vehicle.iso_class, vehicle.gd_n0, vehicle.gd_n0_free, vehicle.waviness = None, None, None, None
        vehicle.band, vehicle.confidence = None, None
        vehicle.reason = "both wheels declined"
        return vehicle
    if vehicle.iso_class is not None or left.iso_class is None or right.iso_class is None:
        return vehicle
    vehicle.gd_n0 = (left.gd_n0 + right.gd_n0) / 2
    vehicle.iso_class = iso_class(vehicle.gd_n0)
    vehicle.gd_n0_free = vehicle.waviness = None
    vehicle.confidence = min(left.confidence, right.confidence)
    vehicle.band = (min(left.band[0], right.band[0]), max(left.band[1], right.band[1]))
    vehicle.band_limit, vehicle.reason = "wheels", None
    return vehicle
