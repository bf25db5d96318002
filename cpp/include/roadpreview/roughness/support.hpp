// SPDX-License-Identifier: BSD-3-Clause
// What the points behind a profile's bins support (docs/noise-aware-roughness.md §1–3): the measurement noise
// each bin height carries into the PSD, and how much of the road's PSD the bins' spacing resolves.
#pragma once

#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

namespace roadpreview {

/// Support of one stretch of bins, on the frequency grid of its displacement PSD.
struct StretchSupport {
    std::optional<std::vector<double>> noise;  ///< N_k, m³: expected PSD of the bin errors; none when unmeasurable
    std::vector<double> resolved;              ///< Φ_k: share of the road's PSD that the sampling keeps
    double backed_fraction = 0.0;              ///< bins that hold points (the others are interpolated)
};

/// Variance (m²) of each backed bin's height (NaN for interpolated bins); nullopt when no bin has 2+ points
/// (with a spread within `pool_max_spread`).
/// Own sample variance s² scaled to the median (s²/2 for 2 points, (π/2)s²/n from 3), the pooled within-bin
/// variance for single-point bins — over the bins whose spread is at most `pool_max_spread` (all by default).
std::optional<std::vector<double>> backed_variances(const std::int32_t* count, const double* spread, std::size_t bins,
                                                    double pool_max_spread = std::numeric_limits<double>::infinity());

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
