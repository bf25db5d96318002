// SPDX-License-Identifier: BSD-3-Clause
// What both calibrations (method.md §8) read off a sensor-frame ground point: whether its beam exists, and how its
// base-frame height moves with its beam's elevation offset.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "roadpreview/core/frames.hpp"

namespace roadpreview::detail {

inline void check_beam_index(std::int32_t beam, int beam_count) {
    if (beam >= beam_count)
        throw std::invalid_argument("beam calibration: beam index " + std::to_string(beam) + " of a " +
                                    std::to_string(beam_count) + "-beam sensor");
}

/// J_δ = −r·(R ∂u/∂θ)_z of a point p at range r > 0 (≈ −horizontal range for a level sensor): its base-frame
/// height is off the road by J_δ·δ when its beam truly points δ higher than the sensor places it (method.md §8).
inline double elevation_jacobian(const double p[3], double r, const RigidTransform& T) {
    const double el = std::asin(std::clamp(p[2] / r, -1.0, 1.0)), az = std::atan2(p[1], p[0]);
    const double du[3] = {-std::sin(el) * std::cos(az), -std::sin(el) * std::sin(az), std::cos(el)};
    return -r * (T.R[2][0] * du[0] + T.R[2][1] * du[1] + T.R[2][2] * du[2]);
}

}  // namespace roadpreview::detail
