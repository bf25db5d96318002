"""International Roughness Index (docs/method.md §6): the ASTM E1926 golden quarter-car driven over a wheel's
profile at 80 km/h, after the 250 mm moving average; IRI = mean rectified suspension slope, in m/km."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..config import Config
from .runs import NO_VALID_BIN, longest_valid_stretch
from .support import check_ds, noise_psd

# Golden car per unit sprung mass (ASTM E1926): tyre and suspension stiffness (1/s²), damping (1/s), mass ratio.
K1, K2, C, MU = 653.0, 63.3, 6.0, 0.15
SPEED_MPS = 80.0 / 3.6
BASE_LENGTH_M = 0.25  # m, method.md §6 step 1: the smoothing before the car
INIT_LENGTH_M = 11.0  # the initial state takes the profile's mean slope over this length
TOO_SHORT = "valid stretch too short for IRI"
TOO_SPARSE = "too few bins with points for IRI"
CLASS_DECLINED = "roughness class declined"


@dataclass
class Iri:
    value: Optional[float] = None  #: m/km; None with a reason
    length: float = 0.0  #: m, the stretch it covers (0 without one)
    reason: Optional[str] = None
    backed_fraction: Optional[float] = None  #: share of the stretch's bins that hold points (None: unknown)
    noise: Optional[float] = None  #: m/km, the IRI of the stretch's bin errors alone (None: unknown)


def golden_car() -> tuple[np.ndarray, np.ndarray]:
    """(A, B) of dx/dt = A·x + B·slope with x = (sprung, its rate, unsprung, its rate), in slope units."""
    a = np.array([[0.0, 1.0, 0.0, 0.0],
                  [-K2, -C, K2, C],
                  [0.0, 0.0, 0.0, 1.0],
                  [K2 / MU, C / MU, -(K1 + K2) / MU, -C / MU]])
    b = np.array([0.0, 0.0, 0.0, K1 / MU])
    return a, b


def transition(ds: float) -> tuple[np.ndarray, np.ndarray]:
    """(ST, PR): the exact discrete step over ds at 80 km/h for an input slope held constant over the step,
    ST = exp(A·dt), PR = A⁻¹(ST − I)·B; the exponential from the eigen-decomposition of A."""
    a, b = golden_car()
    eigenvalues, vectors = np.linalg.eig(a * (ds / SPEED_MPS))
    st = (vectors @ np.diag(np.exp(eigenvalues)) @ np.linalg.inv(vectors)).real
    pr = np.linalg.solve(a, (st - np.eye(4)) @ b)
    return st, pr


def moving_average_samples(ds: float) -> int:
    """Samples in the 250 mm moving average: max(1, nearest integer to 0.25/ds, halves rounded up)."""
    return max(1, int(np.floor(BASE_LENGTH_M / ds + 0.5 + 1e-9)))


def suspension_slope(z, ds: float) -> np.ndarray:
    """Sprung − unsprung slope (m/m) of the golden car after each step of the smoothed profile: the IRI filter's
    output, whose mean absolute value is the IRI. The smoothed profile's slopes are (z[i+k] − z[i])/(k·ds) for
    the k-sample moving average; the car starts level with the profile's mean slope over its first 11 m,
    (z[a] − z[0])/(a·ds), a = the sample nearest to 11 m (or the last one)."""
    z = np.asarray(z, dtype=np.float64)
    ds = check_ds(ds)
    k = moving_average_samples(ds)
    if len(z) <= k:
        return np.zeros(0)
    a = min(int(np.floor(INIT_LENGTH_M / ds + 0.5)), len(z) - 1)  # nearest sample, halves up
    initial = (z[a] - z[0]) / (a * ds)
    state = np.array([initial, 0.0, initial, 0.0])
    st, pr = transition(ds)
    out = np.empty(len(z) - k)
    for i, slope in enumerate((z[k:] - z[:-k]) / (k * ds)):
        state = st @ state + pr * slope
        out[i] = state[0] - state[2]
    return out


def rectified_slope(z, ds: float) -> np.ndarray:
    """|sprung − unsprung slope| (m/m) after each step of the smoothed profile (see suspension_slope)."""
    return np.abs(suspension_slope(z, ds))


def iri(z, ds: float) -> float:
    """IRI of an all-finite profile sampled every ds metres, m/km."""
    return float(np.mean(rectified_slope(z, ds)) * 1000.0)


def profile_iri(z, ds: float, cfg: Config | None = None) -> Iri:
    """IRI over the longest valid stretch of a profile (NaN = missing), if it is at least iri.min_length_m."""
    cfg = cfg or Config()
    start, stop = longest_valid_stretch(z)
    if stop == start:
        return Iri(reason=NO_VALID_BIN)  # an empty profile may have no spacing
    ds = check_ds(ds)
    length = (stop - start - 1) * ds
    if length < cfg.iri.min_length_m - 1e-9 or stop - start <= moving_average_samples(ds):
        return Iri(length=length, reason=TOO_SHORT)
    return Iri(value=iri(np.asarray(z, dtype=np.float64)[start:stop], ds), length=length)


def gain(n, ds: float) -> np.ndarray:
    """|H(n)|², the IRI filter's power gain from profile height to sprung − unsprung slope at n cycles/m: the
    k-sample average's slope (z^k − 1)/(k·ds), then one step of the car, with z = exp(2πi·n·ds)."""
    st, pr = transition(ds)
    k = moving_average_samples(ds)
    out = []
    for z in np.exp(2j * np.pi * np.asarray(n, float) * ds):
        state = np.linalg.solve(z * np.eye(4) - st, pr)  # the state per unit input slope, in steady state
        out.append(abs(state[0] - state[2]) ** 2 * abs(z ** k - 1) ** 2 / (k * ds) ** 2)
    return np.array(out)


def noise_iri(count, spread, ds: float) -> Optional[float]:
    """The IRI (m/km) that the bin errors of a stretch alone give: their periodogram over the whole stretch (as
    support.noise_psd, without a window), through the filter's gain; a zero-mean Gaussian's mean absolute value
    is √(2/π) of its RMS. None when the bins' variances are unknown."""
    psd = noise_psd(count, spread, ds, windowed=False)
    if psd is None:
        return None
    n = len(count)
    frequency = np.arange(len(psd)) / (n * ds)
    power = np.sum(psd[1:] * gain(frequency[1:], ds)) / (n * ds)
    return float(1000.0 * np.sqrt(2 / np.pi * power))


def wheel_iri(z, count, ds: float, wheel_class: Optional[str], cfg: Config | None = None, spread=None) -> Iri:
    """A wheel's IRI as the pipeline reports it: profile_iri, plus the share of the stretch's bins with points
    (count > 0) and, with their spreads, the IRI of their errors alone; no value when that share is below
    iri.min_backed_fraction, or when the wheel has no class."""
    cfg = cfg or Config()
    result = profile_iri(z, ds, cfg)
    start, stop = longest_valid_stretch(z)
    if stop > start:
        result.backed_fraction = float(np.mean(np.asarray(count)[start:stop] > 0))
    if result.reason is None and spread is not None:
        result.noise = noise_iri(np.asarray(count)[start:stop], np.asarray(spread)[start:stop], ds)
    if result.value is None:
        return result
    if result.backed_fraction < cfg.iri.min_backed_fraction - 1e-12:
        result.value, result.reason = None, TOO_SPARSE
    elif wheel_class is None:
        result.value, result.reason = None, CLASS_DECLINED
    return result


def vehicle_iri(left: Iri, right: Iri) -> Iri:
    """The mean of both wheels' IRI (the mean roughness index), when both have one; backed fraction: the mean."""
    backed = None
    if left.backed_fraction is not None and right.backed_fraction is not None:
        backed = (left.backed_fraction + right.backed_fraction) / 2
    noise = None if left.noise is None or right.noise is None else (left.noise + right.noise) / 2
    if left.value is None or right.value is None:
        return Iri(reason=left.reason or right.reason, backed_fraction=backed, noise=noise)
    return Iri(value=(left.value + right.value) / 2, length=min(left.length, right.length), backed_fraction=backed,
               noise=noise)
