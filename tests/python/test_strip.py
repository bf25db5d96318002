"""docs/method.md §3, "What the strip does to the short waves": the table of F(n), the fraction of a line
profile's power that a strip tire_width wide and one bin long keeps on an isotropic road, recomputed from its
formula and measured on the simulator's field (whose lateral structure is isotropic, roadpreview.sim.road)."""

import numpy as np
import pytest
from scipy import signal

from roadpreview.sim.road import RoughField

DS = 0.1
TABLE = {0.3: [0.97, 0.89, 0.74, 0.49, 0.34, 0.20], 0.1: [0.99, 0.97, 0.91, 0.75, 0.60, 0.40]}
N_CPM = [0.2, 0.5, 1.0, 2.0, 2.83, 4.0]


def strip_fraction(n: float, width: float) -> float:
    """F(n) = sinc²(n·ds) · ∫₀^{π/2} cos θ · sinc²(n·W·tan θ) dθ, by the midpoint rule."""
    steps = 200_000
    theta = (np.arange(steps) + 0.5) * (np.pi / 2) / steps
    across = np.sum(np.cos(theta) * np.sinc(n * width * np.tan(theta)) ** 2) * (np.pi / 2) / steps
    return float(np.sinc(n * DS) ** 2 * across)


@pytest.mark.parametrize("width", sorted(TABLE))
def test_the_table_is_its_formula(width):
    assert [round(strip_fraction(n, width), 2) for n in N_CPM] == TABLE[width]


def test_the_simulated_road_averaged_over_the_strip_keeps_the_table(width=0.3):
    fine = 0.025  # the field's grid: the strip's mean is taken over its samples
    across = np.arange(-width / 2 + fine / 2, width / 2, fine)  # 12 lanes
    along = np.arange(-DS / 2 + fine / 2, DS / 2, fine)  # 4 samples per bin
    line_psd, strip_psd = [], []
    for seed in range(3):
        field = RoughField.generate(1e-3, seed=seed)
        x = np.arange(0.0, field.length_m, DS)
        for y in np.arange(1.0, field.width_m - 1.0, 1.0):  # lines 1 m apart: nearly independent above 0.5 c/m
            xf = np.arange(0.0, field.length_m, fine)
            line = field.height(xf, np.full_like(xf, y))  # the line at the field's grid: its PSD not aliased
            strip = np.mean([field.height(x + a, np.full_like(x, y + b)) for a in along for b in across], axis=0)
            n, p_line = signal.welch(line, fs=1 / fine, nperseg=800)  # 20 m segments, as the strip's
            _, p_strip = signal.welch(strip, fs=1 / DS, nperseg=200)
            line_psd.append(p_line)
            strip_psd.append(p_strip)
    ratio = np.mean(strip_psd, axis=0) / np.mean(line_psd, axis=0)[: len(strip_psd[0])]
    for k, expected in zip(N_CPM[1:4], TABLE[width][1:4]):
        got = ratio[np.argmin(abs(n - k))]
        assert got == pytest.approx(expected, rel=0.1), (k, got)
