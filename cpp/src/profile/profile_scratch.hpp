// SPDX-License-Identifier: BSD-3-Clause
// Internal: the profile stage into profiles the caller keeps, with buffers kept between frames so that a stream of
// frames allocates nothing once they have grown.
#pragma once

#include <cstdint>
#include <vector>

#include "ground/plane_fit.hpp"
#include "roadpreview/profile/profile.hpp"

namespace roadpreview {

/// A ground point in a wheel's corridor: its bin, error group (−1 when unknown), height and height variance (m², 0
/// when unknown).
struct Hit {
    std::int32_t bin;
    std::int32_t group;  // beside bin: 24 bytes, no padding
    double z;
    double variance;
};

struct ProfileScratch {
    std::vector<Hit> hits[2];  // left, right
    bool grouped = false;      // the hits carry error groups
    bool stopped = false;      // the vehicle stood still: no hits, and the profiles get no bins
    std::vector<double> variance_sum, sorted;
    std::vector<std::int32_t> sorted_group;
    std::vector<std::size_t> start, next;
    // the local ground model (fit_local_ground)
    struct CorridorPoint {
        Eigen::Index index;
        std::int64_t band;
        double range;
    };
    std::vector<CorridorPoint> found;
    std::vector<Eigen::Index> corridor;  // corridor points grouped by band, band k's from band_start[k]
    std::vector<std::size_t> band_start, band_next;
    std::vector<std::uint8_t> fitted;
    std::vector<std::uint8_t> kept;  // of the band being fitted: its corridor points the last refit kept
    std::vector<double> nearest, farthest, offsets;
    LocalGround ground;  // the model fitted
};

/// The local ground model of local_ground_heights (docs/method.md §3) fitted into `s`.
void fit_local_ground(PointsView points, const std::vector<std::uint8_t>& mask, const Plane& frame, double band_m,
                      const WheelPaths& paths, ProfileScratch& s);

/// Ground point i's height above the local ground model last fitted into `s`: local_ground_heights' value for it.
inline double local_height(PointsView points, Eigen::Index i, const ProfileScratch& s) {
    return s.ground.height(points(i, 0), points(i, 1), points(i, 2));
}

/// The first half of build_profiles (what does not depend on the obstacles): each wheel's corridor points into
/// `s.hits`, with `level_local` at their heights above the local ground model last fitted into `s`.
void collect_profile_hits(PointsView points, const std::vector<std::uint8_t>& mask, const Levelling& L,
                          const WheelPaths& paths, double tire_width, const ProfileConfig& cfg, bool level_local,
                          const std::vector<float>* height_variances, const std::vector<std::int32_t>* error_groups,
                          ProfileScratch& s);

/// The second half: the hits collected in `s` binned into `left` and `right`, outside the `blocked` bins.
void bin_profile_hits(const ProfileConfig& cfg, const BlockedBins* blocked, ProfileScratch& s, Profile& left,
                      Profile& right);

/// build_profiles into `left` and `right`; with `level_local`, heights above the local ground model last fitted into
/// `s` (local_height, asked only of the points in a wheel's corridor) instead of their levelled z.
void build_profiles(PointsView points, const std::vector<std::uint8_t>& mask, const Levelling& L,
                    const WheelPaths& paths, double tire_width, const ProfileConfig& cfg, const BlockedBins* blocked,
                    bool level_local, const std::vector<float>* height_variances,
                    const std::vector<std::int32_t>* error_groups, ProfileScratch& s, Profile& left, Profile& right);

}  // namespace roadpreview
