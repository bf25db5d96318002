// SPDX-License-Identifier: BSD-3-Clause
// What both calibrations (method.md §8) share: whether a ground point's beam exists, how its base-frame height moves
// with its beam's elevation offset, and the gauge their offsets are relative to.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

#include <vector>

#include <Eigen/Dense>

#include "roadpreview/core/frames.hpp"

namespace roadpreview::detail {

constexpr double kPi = 3.14159265358979323846;

inline double deg(double rad) { return rad * 180.0 / kPi; }
inline double rad(double deg) { return deg * kPi / 180.0; }

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

/// Rows 1, mean/reach, reach/mean for the beams in `members` (whose reach is finite): the offsets a pitch, a
/// height and a sag of the road give every beam, which the ground cannot tell from the beams' own (method.md §8).
inline Eigen::MatrixXd gauge_columns(const std::vector<double>& reach, const std::vector<int>& members) {
    double mean = 0.0;
    for (int b : members) mean += reach[static_cast<std::size_t>(b)];
    mean /= std::max<std::size_t>(members.size(), 1);
    Eigen::MatrixXd basis(static_cast<Eigen::Index>(members.size()), 3);
    for (Eigen::Index k = 0; k < basis.rows(); ++k) {
        const double r = reach[static_cast<std::size_t>(members[static_cast<std::size_t>(k)])];
        basis.row(k) << 1.0, mean / r, r / mean;
    }
    return basis;
}

}  // namespace roadpreview::detail
