// SPDX-License-Identifier: BSD-3-Clause
// What the points behind a profile's bins support (docs/noise-aware-roughness.md §1–3): the measurement noise
// each bin height carries into the PSD, and how much of the road's PSD the bins' spacing resolves.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

namespace roadpreview {

/// Support of one stretch of bins, on the frequency grid of its displacement PSD.
struct StretchSupport {
    std::optional<std::vector<double>> noise;  ///< N_k, m³: expected PSD of the bin errors; none when unmeasurable
    std::vector<double> resolved;              ///< Φ_k: share of the road's PSD that the sampling keeps
    double backed_fraction = 0.0;              ///< bins that hold points (the others are interpolated)
};

/// What pooled_variances keeps between calls: per band, its spreads, sums and pool.
struct PoolBuffers {
    std::vector<std::size_t> start, next, cells;
    std::vector<double> spreads, limit, squares, dof, pool;
    void reserve(std::size_t bands, std::size_t bins);  ///< so that calls up to that size allocate nothing
};

/// Per bin, the pooled within-bin variance Σ(c − 1)s² / Σ(c − 1) of its band (`band[j]` ≥ 0, by range; null: one
/// band), over the band's bins of 2+ points whose spread is at most `max_spread_factor` × the band's typical
/// spread (infinite: all) — its median spread, or the least median of the bands below it with `min_bins` bins
/// of 2+ points if smaller. A band with fewer than `min_bins` such bins takes the pool of the nearest band below
/// it (nearer points are the noisier: the borrowed pool errs high), else of the nearest above; when no band has
/// enough, one pool over all bands serves every band. False (`out` untouched) when there is no such bin at all.
bool pooled_variances(const std::int32_t* count, const double* spread, const std::int32_t* band, std::size_t bins,
                      double max_spread_factor, std::size_t min_bins, PoolBuffers& buffers, std::vector<double>& out);

/// Variance (m²) of each backed bin's height of a stretch (NaN for interpolated bins); nullopt when no bin holds
/// points or a single point's variance is unknown. Own sample variance s² scaled to the median (s²/2 for 2
/// points, (π/2)s²/n from 3); for a single-point bin, s² when it carries a spread (a fused map's cell knows its
/// variance), else the pooled within-bin variance of the stretch's bins of 2+ points.
std::optional<std::vector<double>> backed_variances(const std::int32_t* count, const double* spread, std::size_t bins);

/// Expected one-sided PSD of the bin errors of a stretch (independent errors of the backed bins, carried into
/// the gaps by the linear interpolation, periodic Hann window; detrend neglected), k = 0 … bins/2.
std::optional<std::vector<double>> noise_psd(const std::int32_t* count, const double* spread, std::size_t bins,
                                             double ds);

/// Φ at each frequency n: window-weighted share of the stretch in which points g apart resolve n, with the
/// power sinc⁴(n·g) that linear interpolation keeps up to 1/(2g) and none above.
std::vector<double> resolved_fraction(const std::int32_t* count, std::size_t bins, double ds,
                                      const std::vector<double>& n);

/// All of the above for bins [first, last) of a profile's count and spread.
StretchSupport stretch_support(const std::vector<std::int32_t>& count, const std::vector<double>& spread,
                               std::size_t first, std::size_t last, double ds, const std::vector<double>& n);

}  // namespace roadpreview
