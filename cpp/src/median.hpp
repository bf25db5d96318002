// SPDX-License-Identifier: BSD-3-Clause
// Internal: the median the method uses for profile bins and local ground levels.
#pragma once

#include <algorithm>
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

}  // namespace roadpreview
