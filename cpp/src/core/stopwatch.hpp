// SPDX-License-Identifier: BSD-3-Clause
// Internal: stage timings in milliseconds.
#pragma once

#include <chrono>

namespace roadpreview {

using Clock = std::chrono::steady_clock;

/// Milliseconds since `mark`, which moves to now.
inline double ms_since(Clock::time_point& mark) {
    const auto now = Clock::now();
    const double ms = std::chrono::duration<double, std::milli>(now - mark).count();
    mark = now;
    return ms;
}

}  // namespace roadpreview
