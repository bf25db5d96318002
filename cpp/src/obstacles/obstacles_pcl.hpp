// SPDX-License-Identifier: BSD-3-Clause
// Internal: obstacles on the pipeline's PCL-backed ROI cloud, and the points the stage clusters.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <tuple>
#include <vector>

#include "roadpreview/obstacles/obstacles.hpp"
#include "core/roi_cloud.hpp"
#include "obstacles/grid_radius_search.hpp"

namespace roadpreview {

using Voxel = std::array<std::int64_t, 3>;  // voxel indices in x, y, z

/// A Euclidean cluster's size, nearest x and lowest input row (what ranks the clusters).
struct ClusterExtent {
    std::int64_t count = 0;
    float x_min = std::numeric_limits<float>::infinity();
    pcl::index_t first = std::numeric_limits<pcl::index_t>::max();
    bool operator<(const ClusterExtent& o) const { return std::tie(x_min, first) < std::tie(o.x_min, o.first); }
};

/// The obstacle stage's buffers, kept by the pipeline so that a stream of frames allocates nothing once they have
/// grown (the search object and its grid included).
struct ObstacleScratch {
    ObstacleScratch();
    ~ObstacleScratch();
    pcl::Indices candidates;                      // the non-ground points
    std::vector<Voxel> voxel;                     // of each candidate
    std::vector<std::int32_t> order, sorted;      // candidates by voxel
    std::vector<std::uint32_t> next;              // counting sorts
    pcl::PointCloud<pcl::PointXYZ>::Ptr representatives{new pcl::PointCloud<pcl::PointXYZ>};
    std::vector<std::int32_t> representative_of;  // of each candidate
    pcl::shared_ptr<GridRadiusSearch> search;     // made for the first frame's cluster tolerance
    double search_edge = 0.0;
    ComponentScratch components;
    std::vector<std::int32_t> component_of;       // of each representative
    std::vector<ClusterExtent> extent;            // of each component
    std::vector<std::int32_t> kept, id;           // components within the size limits, and their ranks
    std::vector<std::int32_t> candidate_label;
    std::vector<std::uint32_t> member_start;      // each cluster's points
    std::vector<pcl::index_t> members;
    std::vector<double> heights;                  // of the ground around one cluster
};

/// find_obstacles on the ROI cloud into `out`, reusing its buffers and the scratch's.
void find_obstacles(const RoiCloud& roi, const std::vector<std::uint8_t>& ground_mask, const Plane& plane,
                    const ObstaclesConfig& cfg, ObstacleScratch& scratch, Clustering& out);

/// find_obstacles on the ROI cloud; `ground_mask` and the labels have one entry per ROI point.
Clustering find_obstacles(const RoiCloud& roi, const std::vector<std::uint8_t>& ground_mask, const Plane& plane,
                          const ObstaclesConfig& cfg);

/// What the stage hands PCL's Euclidean clustering for the `candidates` among `points`: their voxel centroids
/// (voxel_m > 0) or the candidates themselves (bench/cluster_search.cpp).
pcl::PointCloud<pcl::PointXYZ>::Ptr cluster_representatives(PointsView points, const pcl::Indices& candidates,
                                                            double voxel_m);

}  // namespace roadpreview
