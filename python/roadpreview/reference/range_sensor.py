"""Point range sensors (docs/method.md §11), written plainly from the method: distance calibration, samples on the
wheels' tracks, binned profiles, and the offset calibration by cross-correlation (the C++ uses ICP; the two are
meant to agree, not to share code). Readings come in as arrays, not files."""

from __future__ import annotations

import math
from typing import Optional, Sequence

import numpy as np

from .profile import fill_gaps

OUTLIER_SIGMAS = 3.5  # §11.2: residuals beyond this many robust σ (1.4826·MAD) leave the fit
MAX_ROUNDS = 10
XCORR_STEP_M = 0.002


def speed_of_sound_mps(temperature_c) -> np.ndarray:
    return 331.3 * np.sqrt(1.0 + np.asarray(temperature_c, float) / 273.15)


def calibrate_distance(counts, distances) -> dict:
    """d = a1·c + a2 by least squares; refit without |residual| > 3.5·1.4826·MAD until nothing changes."""
    c = np.asarray(counts, float)
    d = np.asarray(distances, float)
    finite = np.isfinite(c) & np.isfinite(d)
    c, d = c[finite], d[finite]
    if len(c) < 3 or np.ptp(c) == 0:
        raise ValueError("need at least 3 readings at two or more distinct counts")
    keep = np.ones(len(c), bool)
    for _ in range(MAX_ROUNDS):
        a1, a2 = np.polyfit(c[keep], d[keep], 1)
        residual = np.abs(d - (a1 * c + a2))
        sigma = max(1.4826 * np.median(residual[keep]), 1e-9 + 1e-9 * abs(a2))
        new_keep = residual <= OUTLIER_SIGMAS * sigma
        if np.array_equal(new_keep, keep) or new_keep.sum() < 3:
            keep = new_keep if new_keep.sum() >= 3 else keep
            break
        keep = new_keep
    a1, a2 = np.polyfit(c[keep], d[keep], 1)
    r = d[keep] - (a1 * c[keep] + a2)
    sst = np.sum((d[keep] - d[keep].mean()) ** 2)
    return {"a1": float(a1), "a2": float(a2), "rms_m": float(np.sqrt(np.mean(r**2))),
            "r_squared": float(1 - np.sum(r**2) / sst) if sst > 0 else 1.0, "used": int(keep.sum()),
            "rejected": int((~keep).sum())}


def distance_of_count(count, a1: float, a2: float, temperature_c=None, calibration_temperature_c: float = 20.0):
    """d = a1·c·v(T)/v(T_cal) + a2 (no temperature: the bench's)."""
    count = np.asarray(count, float)
    if temperature_c is None:
        return a1 * count + a2
    scale = speed_of_sound_mps(temperature_c) / speed_of_sound_mps(calibration_temperature_c)
    return a1 * count * scale + a2


def place(t, distance, sensor: dict, *, speed, yaw_rate=0.0, distance_driven=None, heading=None,
          b1_s: float = 0.0, b2_m: Optional[float] = None) -> dict:
    """Samples of one sensor: height z = h − d·cos(pitch); position along its wheel's track s = D − y·Θ + x with
    x = b1·v + b2 + (d − h/cos pitch)·sin pitch (b2 default: the geometric foot x_m + h·tan pitch).

    speed, yaw_rate: per reading (m/s, rad/s); distance_driven, heading: D and Θ from the start per reading
    (default: constant speed and yaw rate from t[0])."""
    t = np.asarray(t, float)
    d = np.asarray(distance, float)
    v = np.broadcast_to(np.asarray(speed, float), t.shape)
    w = np.broadcast_to(np.asarray(yaw_rate, float), t.shape)
    D = v * (t - t[0]) if distance_driven is None else np.asarray(distance_driven, float)
    theta = w * (t - t[0]) if heading is None else np.asarray(heading, float)
    pitch = math.radians(sensor["pitch_deg"])
    h = sensor["height_m"]
    if b2_m is None:
        b2_m = sensor["x_m"] + h * math.tan(pitch)
    ahead = b1_s * v + b2_m + (d - h / math.cos(pitch)) * math.sin(pitch)
    with np.errstate(divide="ignore", invalid="ignore"):
        ttw = np.where(v > 0, ahead / np.where(v > 0, v, 1.0), np.nan)
    return {"s": D - sensor["y_m"] * theta + ahead, "z": h - d * math.cos(pitch), "ahead": ahead,
            "time_to_wheel": ttw}


def bin_profile(s, z, s0_m: float, length_m: float, ds_m: float = 0.1, max_gap_m: float = 1.0) -> dict:
    """Bins [s0 + k·ds, s0 + (k+1)·ds): median height, count, sample standard deviation; gaps ≤ max_gap filled."""
    s = np.asarray(s, float)
    z = np.asarray(z, float)
    bins = int(math.ceil(length_m / ds_m - 1e-9))
    k = np.floor((s - s0_m) / ds_m)
    inside = (k >= 0) & (k < bins)
    k = k[inside].astype(int)
    zi = z[inside]
    median = np.full(bins, np.nan)
    spread = np.full(bins, np.nan)
    count = np.bincount(k, minlength=bins).astype(np.int32)
    for b in np.flatnonzero(count):
        values = zi[k == b]
        median[b] = np.median(values)
        if len(values) > 1:
            spread[b] = np.std(values, ddof=1)
    return {"s": s0_m + (np.arange(bins) + 0.5) * ds_m, "z": fill_gaps(median, ds_m, max_gap_m), "count": count,
            "spread": spread}


def xcorr_shift(x, z, ref_x, ref_z, guess_m: float, search_m: float) -> float:
    """The lag L within guess ± search maximising the correlation of z with the reference at x + L (samples off
    the reference left out), on a 2 mm grid, refined by a parabola through the peak and its neighbours."""
    x = np.asarray(x, float)
    z = np.asarray(z, float)
    k = int(math.ceil(search_m / XCORR_STEP_M))
    lags = guess_m + np.arange(-k, k + 1) * XCORR_STEP_M
    corr = np.full(len(lags), -1.0)
    for i, lag in enumerate(lags):
        q = x + lag
        on = (q >= ref_x[0]) & (q <= ref_x[-1])
        if on.sum() >= 3 and np.std(z[on]) > 0:
            r = np.interp(q[on], ref_x, ref_z)
            if np.std(r) > 0:
                corr[i] = np.corrcoef(z[on], r)[0, 1]
    best = int(np.argmax(corr))
    frac = 0.0
    if 0 < best < len(lags) - 1:
        den = corr[best - 1] - 2 * corr[best] + corr[best + 1]
        if den < 0:
            frac = 0.5 * (corr[best - 1] - corr[best + 1]) / den
    return float(lags[best] + frac * XCORR_STEP_M)


def calibrate_offset(runs: Sequence[tuple], ref_x, ref_z, guess_m: float, search_m: float = 0.5) -> dict:
    """b1, b2 of x = b1·v + b2 from runs [(s with b1 = b2 = 0, z, mean speed)] by cross-correlation shifts and
    an ordinary least-squares line; fewer than two distinct speeds is an error."""
    speeds = np.array([float(v) for _, _, v in runs])
    if len(speeds) < 2 or np.ptp(speeds) <= 0.1 * np.max(np.abs(speeds)):
        raise ValueError("offset calibration needs runs at two or more distinct speeds")
    shifts = np.array([xcorr_shift(x, z, ref_x, ref_z, guess_m, search_m) for x, z, _ in runs])
    b1, b2 = np.polyfit(speeds, shifts, 1)
    return {"b1_s": float(b1), "b2_m": float(b2), "shifts_m": shifts, "speeds_mps": speeds}
