// SPDX-License-Identifier: BSD-3-Clause
// Stage 1 — ground on ROI points: a plane per patch of a concentric zone model (zones), the paper's iterative
// PCA plane fit (pca) or PCL RANSAC (ransac); every plane and patch within a tilt limit.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "roadpreview/core/config.hpp"
#include "roadpreview/core/points.hpp"

namespace roadpreview {

/// Plane a·x + b·y + c·z + d = 0 with (a, b, c) a unit normal and c > 0 (pointing up).
using Plane = std::array<double, 4>;

/// Signed height of p above the plane (positive on the side the normal points to).
inline double height_above(const Plane& pl, double x, double y, double z) {
    return pl[0] * x + pl[1] * y + pl[2] * z + pl[3];
}

/// PCA plane of the points (normal = eigenvector of the smallest covariance eigenvalue, through the mean).
/// `mask`, if given, selects the rows used. Returns nullopt for fewer than 3 points or a degenerate fit.
std::optional<Plane> fit_plane(PointsView points, const std::vector<std::uint8_t>* mask = nullptr);

/// The text of a frame whose only ground plane lies farther from level than ground.max_tilt_deg.
inline constexpr const char* kTiltedGround = "no ground within the tilt limit";

/// Whether ground was found, and why not (an enum, not a string: the real-time path does not allocate).
enum class GroundStatus {
    Found,         ///< a plane
    NoGround,      ///< "no ground"
    TiltedGround,  ///< kTiltedGround: the only planes lie farther from level than ground.max_tilt_deg
};

inline const char* to_string(GroundStatus s) {
    return s == GroundStatus::Found ? "" : s == GroundStatus::NoGround ? "no ground" : kTiltedGround;
}

struct GroundFit {
    std::vector<std::uint8_t> mask;  ///< 1 = ground, one entry per point given
    std::optional<Plane> plane;      ///< nullopt: no ground found
    std::int64_t count = 0;          ///< ground points
    GroundStatus status = GroundStatus::Found;  ///< Found with a plane, else why there is none
};

/// Ground among base-frame `points` by `cfg.method`; only points in the front ROI can be ground.
/// The mask has one entry per point given.
GroundFit fit_ground(PointsView points, const GroundConfig& cfg);

}  // namespace roadpreview
