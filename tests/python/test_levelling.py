"""Levelling by the local ground model (docs/method.md §3): what it does to long waves, and to a grade."""

import math

import numpy as np
import pytest

import roadpreview as rp
from roadpreview.config import Config
from roadpreview.reference.profile import local_ground_heights

LEVEL = np.array([0.0, 0.0, 1.0, 0.0])


def left_after_levelling(wavelength_m, band_m):
    """Mean fraction of a sine's power (over 8 phases) left after levelling, in the bands [10, 20) and [20, 30) m."""
    x = np.arange(10.0, 30.0, 0.005)
    cfg = Config(profile={"level_band_m": band_m})
    amplitude = 0.01  # m: a road, flatter than it is wide, so that PCA's normal is the vertical
    fractions = []
    for phase in np.linspace(0, 2 * np.pi, 8, endpoint=False):
        z = amplitude * np.sin(2 * np.pi * x / wavelength_m + phase)
        xyz = np.vstack([np.column_stack([x, np.full_like(x, y), z]) for y in (-1.0, 0.0, 1.0)])
        levelled = local_ground_heights(xyz, LEVEL, cfg)
        fractions.append(np.mean(levelled**2) / (amplitude**2 / 2))
    return float(np.mean(fractions))


def transfer(wavelength_m, band_m):
    """method.md §3: T = 1 − sinc²(u) − 3·j1(u)², u = π·band/λ."""
    u = math.pi * band_m / wavelength_m
    sinc, j1 = math.sin(u) / u, math.sin(u) / u**2 - math.cos(u) / u
    return 1 - sinc**2 - 3 * j1**2


@pytest.mark.parametrize("wavelength_m", [40.0, 20.0, 10.0, 5.0, 2.5, 1.0])
def test_levelling_keeps_the_fraction_of_a_long_wave_method_md_states(wavelength_m):
    assert left_after_levelling(wavelength_m, 10.0) == pytest.approx(transfer(wavelength_m, 10.0), abs=0.005)


def test_the_stated_numbers():
    """The table in method.md §3 (band 10 m)."""
    assert [round(transfer(lam, 10.0), 2) for lam in (20.0, 10.0, 5.0, 2.5)] == [0.10, 0.70, 0.92, 0.98]


def grade_frame(level_local):
    """A level road rising 3 % from 15 m, 0.1 m grid points; returns both wheels' profile heights (m)."""
    x, y = np.meshgrid(np.arange(1.0, 40.0, 0.1), np.arange(-3.0, 3.0, 0.1))
    x, y = x.ravel(), y.ravel()
    points = np.column_stack([x, y, 0.03 * np.maximum(x - 15.0, 0.0)]).astype(np.float32)
    cfg = Config(profile={"level_local": level_local}, obstacles={"enabled": False})
    results = [rp.Estimator(cfg).process(points, 5.0, 0.0), rp.reference.process(points, 5.0, 0.0, cfg)]
    return [np.concatenate([r.left.z, r.right.z]) for r in results]


def test_a_grade_change_is_not_relief():
    # The 3 % kink at 15 m lies mid-band (10–20 m): the band's plane leaves ±Δg·L/8 = ±3.75 cm (method.md §3).
    for z in grade_frame(level_local=True):
        assert np.ptp(z[np.isfinite(z)]) < 0.03 * 10.0 / 4 + 0.005
    for z in grade_frame(level_local=False):  # one plane: the kink reads as a long wave of decimetres
        assert np.ptp(z[np.isfinite(z)]) > 0.2


def spurious_returns_frame():
    """A level road (0.2 m grid) with four returns 6.7 m below it 20–21 m ahead, beside the wheel tracks: multipath
    as on a KITTI street, where they tilted the 20–30 m band's plane by 3.9 % (method.md §3)."""
    x, y = np.meshgrid(np.arange(1.0, 40.0, 0.2), np.arange(-3.0, 3.0, 0.2))
    road = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    below = np.array([[20.76, -1.38, -6.74], [20.77, -1.31, -6.74], [20.81, -1.25, -6.76], [20.06, 1.36, -6.53]])
    return np.vstack([road, below]).astype(np.float32), len(road)


@pytest.mark.parametrize("process", ["native", "reference"])
def test_spurious_returns_below_the_road_do_not_tilt_a_band(process):
    points, road = spurious_returns_frame()
    cfg = Config(obstacles={"enabled": False})
    if process == "native":
        result = rp.Estimator(cfg).process(points, 5.0, 0.0)
    else:
        result = rp.reference.process(points, 5.0, 0.0, cfg)
    assert np.asarray(result.ground_mask)[road:].all()  # the ground stage keeps them: the levelling must cope
    for z in (result.left.z, result.right.z):
        assert np.nanmax(np.abs(z)) < 0.005


def test_one_fit_per_band_is_tilted_by_them(monkeypatch):
    import roadpreview.reference.profile as profile

    monkeypatch.setattr(profile, "LEVEL_REFITS", 0)
    points, _ = spurious_returns_frame()
    result = rp.reference.process(points, 5.0, 0.0, Config(obstacles={"enabled": False}))
    assert max(np.nanmax(np.abs(result.left.z)), np.nanmax(np.abs(result.right.z))) > 0.02


def short_far_band_frame():
    """A road level to 20 m, then climbing 4 %, seen only to 32.5 m: its 30–40 m band holds 2.5 m of road."""
    x, y = np.meshgrid(np.arange(1.0, 32.5, 0.2), np.arange(-3.0, 3.0, 0.2))
    x, y = x.ravel(), y.ravel()
    return np.column_stack([x, y, 0.04 * np.maximum(x - 20.0, 0.0)]).astype(np.float32)


@pytest.mark.parametrize("process", ["native", "reference"])
def test_a_short_band_takes_its_neighbours_slope_through_its_own_points(process):
    points = short_far_band_frame()
    cfg = Config(obstacles={"enabled": False})
    if process == "native":
        result = rp.Estimator(cfg).process(points, 5.0, 0.0)
    else:
        result = rp.reference.process(points, 5.0, 0.0, cfg)
    far = points[points[:, 0] >= 30.0]
    plane = np.asarray(result.plane, dtype=float)
    assert np.median(far[:, :3] @ plane[:3] + plane[3]) > 0.05  # the frame plane lies well off the road there
    for profile in (result.left, result.right):
        s, z = np.asarray(profile.s), np.asarray(profile.z)
        assert np.nanmax(np.abs(z[s >= 30.0])) < 0.01
