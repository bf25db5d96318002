// SPDX-License-Identifier: BSD-3-Clause
// Stage 3 — wheel-path height profiles: ground points in each wheel's corridor, binned along arc length,
// with the count and spread of the points behind each bin (for the noise-aware roughness).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "roadpreview/config.hpp"
#include "roadpreview/ground.hpp"
#include "roadpreview/path.hpp"
#include "roadpreview/points.hpp"
#include "roadpreview/roughness.hpp"

namespace roadpreview {

struct Profile {
    double s0 = 0.0;  ///< m, centre of the first bin
    double ds = 0.0;  ///< m, bin width
    std::vector<double> s;             ///< m, bin centres
    std::vector<double> z;             ///< m, median height per bin (levelled), NaN where missing
    std::vector<std::int32_t> count;   ///< points per bin (0 for interpolated bins)
    std::vector<double> spread;        ///< m, sample standard deviation of the bin's heights, NaN below 2 points
    Roughness roughness;
};

/// Rotation about the base origin that takes the plane normal onto +z along the shortest arc, row-major.
struct Levelling {
    double R[3][3];
};
Levelling levelling_for(const Plane* plane);  ///< identity when plane is null

/// Profiles of both wheels from ground points (base frame) selected by `mask`.
struct WheelProfiles {
    Profile left, right;
};
WheelProfiles build_profiles(PointsView points, const std::vector<std::uint8_t>& mask, const Levelling& L,
                             const WheelPaths& paths, double tire_width, const ProfileConfig& cfg);

/// Linear interpolation across interior runs of NaN no longer than max_gap_m.
void fill_gaps(std::vector<double>& z, double ds, double max_gap_m);

}  // namespace roadpreview
