// SPDX-License-Identifier: BSD-3-Clause
// Internal: the median the method uses for profile bins, map cells and local ground levels, and the bins' spread.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace roadpreview {

/// Median of [first, last) (mean of the two middle values for an even count); reorders them. Not empty.
inline double median(std::vector<double>::iterator first, std::vector<double>::iterator last) {
    const auto n = last - first;
    const auto upper = first + n / 2;
    std::nth_element(first, upper, last);
    if (n % 2 == 1) return *upper;
    return 0.5 * (*std::max_element(first, upper) + *upper);
}

// Sample standard deviation (n − 1 in the denominator) of at least two values.
inline double sample_spread(std::vector<double>::const_iterator first, std::vector<double>::const_iterator last) {
    const double n = static_cast<double>(last - first);
    double mean = 0.0, squares = 0.0;
    for (auto it = first; it != last; ++it) mean += *it;
    mean /= n;
    for (auto it = first; it != last; ++it) squares += (*it - mean) * (*it - mean);
    return std::sqrt(squares / (n - 1.0));
}

/// The spread a bin or cell reports for its noise: the sample spread of its heights, raised to the root of its
/// points' mean height variance when the sensor states one (stereo: correlated matching errors hide from the
/// sample spread), and scaled by √(points per error group) when its points share errors in groups, so that
/// spread²/points, the way the roughness stage rates a bin's median, counts each group once. NaN stays NaN (fewer
/// than two points).
inline double noise_spread(double sample_spread, double mean_point_variance, double points_per_group = 1.0) {
    if (std::isnan(sample_spread)) return sample_spread;
    return std::sqrt(std::max(sample_spread * sample_spread, mean_point_variance) * points_per_group);
}

/// How many distinct values [first, last) holds; reorders them.
inline std::size_t distinct_count(std::vector<std::int32_t>::iterator first, std::vector<std::int32_t>::iterator last) {
    std::sort(first, last);
    return static_cast<std::size_t>(std::unique(first, last) - first);
}

}  // namespace roadpreview
