// SPDX-License-Identifier: BSD-3-Clause
// Internal: the profile stage into profiles the caller keeps, with buffers kept between frames so that a stream of
// frames allocates nothing once they have grown.
#pragma once

#include <cstdint>
#include <vector>

#include "ground/plane_fit.hpp"
#include "roadpreview/profile/profile.hpp"

namespace roadpreview {

/// A ground point in a wheel's corridor: its bin, height and height variance (m², 0 when unknown).
struct Hit {
    std::int32_t bin;
    double z;
    double variance;
};

struct ProfileScratch {
    std::vector<Hit> hits[2];  // left, right
    std::vector<double> variance_sum, sorted;
    std::vector<std::size_t> start, next;
    // local_ground_heights
    std::vector<std::int64_t> band;
    std::vector<Eigen::Index> corridor;  // corridor points grouped by band, band k's from band_start[k]
    std::vector<std::size_t> band_start, band_next;
    std::vector<std::uint8_t> in_corridor, fitted;
    std::vector<double> range, nearest, farthest, offsets;
    std::vector<Plane> plane;
};

/// local_ground_heights into `z`.
void local_ground_heights(PointsView points, const std::vector<std::uint8_t>& mask, const Plane& frame, double band_m,
                          const WheelPaths& paths, ProfileScratch& s, std::vector<double>& z);

/// build_profiles into `left` and `right`.
void build_profiles(PointsView points, const std::vector<std::uint8_t>& mask, const Levelling& L,
                    const WheelPaths& paths, double tire_width, const ProfileConfig& cfg, const BlockedBins* blocked,
                    const std::vector<double>* local_z, const std::vector<float>* height_variances, ProfileScratch& s,
                    Profile& left, Profile& right);

}  // namespace roadpreview
