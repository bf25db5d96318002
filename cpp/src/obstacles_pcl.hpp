// SPDX-License-Identifier: BSD-3-Clause
// Internal: obstacles on the pipeline's PCL-backed ROI cloud, clustered in place through an index list.
#pragma once

#include "roadpreview/obstacles.hpp"
#include "roi_cloud.hpp"

namespace roadpreview {

/// find_obstacles on the ROI cloud; `ground_mask` and the labels have one entry per ROI point.
Clustering find_obstacles(const RoiCloud& roi, const std::vector<std::uint8_t>& ground_mask, const Plane& plane,
                          const ObstaclesConfig& cfg);

}  // namespace roadpreview
