// SPDX-License-Identifier: BSD-3-Clause
// Obstacles: Euclidean clusters of the non-ground ROI points (PCL), their boxes and heights above
// the local ground, and the stretch of each wheel path they block (docs/method.md §5).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "roadpreview/core/config.hpp"
#include "roadpreview/ground/ground.hpp"
#include "roadpreview/paths/path.hpp"
#include "roadpreview/core/points.hpp"

namespace roadpreview {

struct Levelling;  // profile.hpp

using Vec3 = std::array<double, 3>;

/// Box about the vertical axis: the cluster's extent along its principal horizontal directions.
struct OrientedBox {
    Vec3 center{};     ///< m, base frame
    Vec3 size{};       ///< m: length along `yaw`, width across it, height
    double yaw = 0.0;  ///< rad in (−π/2, π/2], angle of the major axis from x towards y
};

struct Cluster {
    std::int32_t id = 0;          ///< rank by nearest x (aabb_min x), ties by the lowest input row
    std::int32_t count = 0;       ///< points in the cluster
    Vec3 centroid{};              ///< m, mean of the points, base frame
    Vec3 aabb_min{}, aabb_max{};  ///< m, axis-aligned bounds, base frame
    OrientedBox obb;
    double ground_offset = 0.0;   ///< m, local ground level above the frame's ground plane
    double height = 0.0;          ///< m, highest point above the local ground
    double bottom = 0.0;          ///< m, lowest point above the local ground (above clearance_m: overhead)
};

/// A cluster in one wheel's corridor (widened by the safety margin), ahead within the preview length.
struct PathObstacle {
    std::int32_t id = 0;   ///< the Cluster's id
    double s_start = 0.0;  ///< m, arc length of its nearest point in the corridor
    double s_end = 0.0;    ///< m, arc length of its farthest point in the corridor
    double height = 0.0;   ///< m, highest of those points above the cluster's local ground
};

struct Clustering {
    std::vector<Cluster> clusters;    ///< ordered by id
    std::vector<std::int32_t> label;  ///< one per point given: the id of its cluster, −1 for none
};

/// Cluster labels of all finite `points` (−1: none): PCL's Euclidean clustering of the centroids of the
/// occupied voxels (of the points themselves when cfg.voxel_m = 0), each point joining its voxel's cluster;
/// clusters outside [min, max]_cluster_points points are dropped. Ids as in Cluster.
std::vector<std::int32_t> cluster_labels(PointsView points, const ObstaclesConfig& cfg);

/// Clusters of the base-frame `points` inside the ground ROI that are not ground (`ground_mask` 0), with
/// boxes and heights above `plane` corrected by the local ground. `label` has one entry per point given.
Clustering find_obstacles(PointsView points, const std::vector<std::uint8_t>& ground_mask, const Plane& plane,
                          const GroundConfig& roi, const ObstaclesConfig& cfg);

/// The clusters that cross wheel `w`'s corridor widened by cfg.safety_margin_m, with 0 ≤ s < preview_length_m
/// after levelling by `L` (as the profiles are), and rise there at least cfg.min_height_m above their local
/// ground, unless the whole cluster is higher than cfg.clearance_m above it (overhead); ordered by s_start then id. `points` and `clustering.label` are those of find_obstacles.
std::vector<PathObstacle> wheel_obstacles(PointsView points, const Clustering& clustering, const Plane& plane,
                                          const Levelling& L, const WheelPaths& paths, Wheel w, double tire_width,
                                          double preview_length_m, const ObstaclesConfig& cfg);

/// Per-bin flags (1 = blocked) of `bins` bins of width ds: bin k is blocked when [k·ds, (k+1)·ds) overlaps
/// [s_start − margin, s_end + margin] of any obstacle.
std::vector<std::uint8_t> blocked_bins(const std::vector<PathObstacle>& obstacles, std::size_t bins, double ds,
                                       double margin_m);

/// The same two into `out`, reusing its capacity (the pipeline's real-time path).
void wheel_obstacles(PointsView points, const Clustering& clustering, const Plane& plane, const Levelling& L,
                     const WheelPaths& paths, Wheel w, double tire_width, double preview_length_m,
                     const ObstaclesConfig& cfg, std::vector<PathObstacle>& out);
void blocked_bins(const std::vector<PathObstacle>& obstacles, std::size_t bins, double ds, double margin_m,
                  std::vector<std::uint8_t>& out);

}  // namespace roadpreview
