// SPDX-License-Identifier: BSD-3-Clause
// Stage 3 — wheel-path height profiles: ground points in each wheel's corridor, binned along arc length,
// with the count and spread of the points behind each bin (for the noise-aware roughness).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "roadpreview/core/config.hpp"
#include "roadpreview/ground/ground.hpp"
#include "roadpreview/obstacles/obstacles.hpp"
#include "roadpreview/paths/path.hpp"
#include "roadpreview/core/points.hpp"
#include "roadpreview/roughness/roughness.hpp"

namespace roadpreview {

struct Profile {
    double s0 = 0.0;  ///< m, centre of the first bin
    double ds = 0.0;  ///< m, bin width
    std::vector<double> s;             ///< m, bin centres
    std::vector<double> z;             ///< m, median height per bin (levelled), NaN where missing
    std::vector<std::int32_t> count;   ///< points per bin (0 for interpolated bins)
    std::vector<double> spread;        ///< m, sample standard deviation of the bin's heights, NaN below 2 points;
                                       ///< raised by stated point errors, and one point's stated σ
                                       ///< (build_profiles); a fused map's bins: the spread giving the map's
                                       ///< variance, one point's too
    Roughness roughness;
    std::vector<std::uint8_t> blocked;  ///< 1 where an obstacle covers the bin (z is NaN there), docs/method.md §5
    std::optional<std::vector<PathObstacle>> obstacles;  ///< in this wheel's path; nullopt: clustering is off
};

/// Rotation about the base origin that takes the plane normal onto +z along the shortest arc, row-major.
struct Levelling {
    double R[3][3];

    std::array<double, 3> apply(double x, double y, double z) const {
        return {R[0][0] * x + R[0][1] * y + R[0][2] * z, R[1][0] * x + R[1][1] * y + R[1][2] * z,
                R[2][0] * x + R[2][1] * y + R[2][2] * z};
    }
};
Levelling levelling_for(const Plane* plane);  ///< identity when plane is null

/// Half-width of the corridor about the vehicle's path whose ground points the local planes are fitted to (m):
/// the wheel tracks of a car or truck (track ≤ 2 m) and a margin, not the kerbs, pavements and parked cars beside
/// the road (docs/method.md §3).
constexpr double kLevelCorridorHalfWidthM = 1.5;
/// A band's plane is fitted only when its corridor points span at least this fraction of the band in range.
constexpr double kLevelMinSpan = 0.5;
/// A band's plane is refitted to the corridor points within kLevelKeepM of the last fit (either side: a few
/// spurious returns metres below the road tilted a plane by 3.9 %) and within kLevelKeepSigmas robust standard
/// deviations (at least kLevelKeepMinM) of their median height above it (a bump is not the ground's grade), until
/// the points kept no longer change, at most kLevelRefits times (docs/method.md §3).
constexpr double kLevelKeepM = 0.2;
constexpr double kLevelKeepSigmas = 3.0;
constexpr double kLevelKeepMinM = 0.005;
constexpr int kLevelRefits = 8;

/// Distance of a base-frame point (x, y) from the path of the vehicle's centre: |y| on a straight path, the
/// distance from its circle about the ICR on an arc.
double distance_from_path(const WheelPaths& paths, double x, double y);

/// One frame's local ground model (docs/method.md §3): a plane per band k = ⌊r / band_m⌋ of horizontal range r,
/// blended between band centres, the frame plane beyond the last band with corridor points. The single frame's
/// profiles take their heights above it, and a fused map's profiles are read above the last fused frame's (§7).
struct LocalGround {
    std::vector<Plane> plane;              ///< of each band out to the farthest corridor point
    std::vector<std::uint8_t> has_points;  ///< of each band: it has corridor points (a plane of its own)
    Plane frame{0.0, 0.0, 1.0, 0.0};       ///< the frame's ground plane
    double band_m = 0.0;
    double direction = 1.0;  ///< the side of the base origin the corridor lies on (x·direction > 0; −1 reversing)

    /// Height of the base-frame point (x, y, z) above the model; a point on the other side of the base origin
    /// (the road already driven) takes the nearest band's plane, unblended: the farther bands lie ahead.
    double height(double x, double y, double z) const;
};

/// Levelling by the local ground model (docs/method.md §3): each ground point's height above its band's plane.
/// Bands are k = ⌊r / band_m⌋ of horizontal distance r = √(x² + y²). A band's plane is the PCA plane of its ground
/// points within kLevelCorridorHalfWidthM of the vehicle's path, refitted to those near it (kLevelKeepM,
/// kLevelKeepSigmas), when they span at least kLevelMinSpan of the band in range; otherwise (or for a degenerate
/// fit) the normal of the nearest fitted band (the frame plane's if none) through their median; the frame plane for
/// a band without corridor points. The road reads about 0 whatever the frame plane's offset. One entry per point,
/// NaN off the ground.
std::vector<double> local_ground_heights(PointsView points, const std::vector<std::uint8_t>& mask, const Plane& frame,
                                         double band_m, const WheelPaths& paths);

/// Bins per profile, K = ceil(preview_length / ds) (docs/method.md §3).
std::size_t bin_count(const ProfileConfig& cfg);

/// Profiles of both wheels from ground points (base frame) selected by `mask`.
struct WheelProfiles {
    Profile left, right;
};
/// Each wheel's bins covered by obstacles (see blocked_bins): their z is NaN and gap filling does not cross them.
struct BlockedBins {
    std::vector<std::uint8_t> left, right;
};
/// With `local_z` (one per point), a ground point's height is local_z[i] instead of its levelled z (the
/// positions along and across the path stay those that `L` gives): levelling by the local ground model. With
/// `height_variances` (m² per point, e.g. stereo depth noise) a bin's spread is at least the root of its points'
/// mean variance (a single point's spread is the root of its own); with `error_groups` (one per point, see
/// PointErrors) it is scaled by √(points per distinct group) so that the bin's rated noise counts each group once
/// (docs/method.md §12).
WheelProfiles build_profiles(PointsView points, const std::vector<std::uint8_t>& mask, const Levelling& L,
                             const WheelPaths& paths, double tire_width, const ProfileConfig& cfg,
                             const BlockedBins* blocked = nullptr, const std::vector<double>* local_z = nullptr,
                             const std::vector<float>* height_variances = nullptr,
                             const std::vector<std::int32_t>* error_groups = nullptr);

/// Linear interpolation across interior runs of NaN no longer than max_gap_m. With `blocked`, a blocked bin
/// counts as missing and a run holding one is left as it is: nothing is interpolated across an obstacle.
void fill_gaps(std::vector<double>& z, double ds, double max_gap_m, const std::vector<std::uint8_t>* blocked = nullptr);

}  // namespace roadpreview
