// SPDX-License-Identifier: BSD-3-Clause
// Internal: obstacles on the pipeline's PCL-backed ROI cloud, and the points the stage clusters.
#pragma once

#include "roadpreview/obstacles/obstacles.hpp"
#include "core/roi_cloud.hpp"

namespace roadpreview {

/// find_obstacles on the ROI cloud; `ground_mask` and the labels have one entry per ROI point.
Clustering find_obstacles(const RoiCloud& roi, const std::vector<std::uint8_t>& ground_mask, const Plane& plane,
                          const ObstaclesConfig& cfg);

/// What the stage hands PCL's Euclidean clustering for the `candidates` among `points`: their voxel centroids
/// (voxel_m > 0) or the candidates themselves (bench/cluster_search.cpp).
pcl::PointCloud<pcl::PointXYZ>::Ptr cluster_representatives(PointsView points, const pcl::Indices& candidates,
                                                            double voxel_m);

}  // namespace roadpreview
