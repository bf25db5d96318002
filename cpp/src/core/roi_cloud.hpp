// SPDX-License-Identifier: BSD-3-Clause
// Internal: the one per-frame copy of the cloud — base-frame points of the front ROI, stored as a PCL
// cloud so that RANSAC (and later clustering) use it in place, and viewed as N×3 floats by everything else.
#pragma once

#include <cstdint>
#include <vector>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "roadpreview/core/config.hpp"
#include "roadpreview/core/frames.hpp"
#include "roadpreview/core/points.hpp"

namespace roadpreview {

struct RoiCloud {
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud{new pcl::PointCloud<pcl::PointXYZ>};
    std::vector<std::int32_t> input_index;  ///< input row of each ROI point
    std::int64_t finite = 0;                ///< input rows with finite x, y, z

    Eigen::Index size() const { return static_cast<Eigen::Index>(input_index.size()); }
    PointsView view() const {  // pcl::PointXYZ is x, y, z + one padding float
        static_assert(sizeof(pcl::PointXYZ) == 4 * sizeof(float));
        return points_view(cloud->points.empty() ? nullptr : cloud->points[0].data, size(), 4);
    }
};

/// Transform, drop non-finite rows (counted), crop to the ROI; reuses `out`'s buffers.
void crop_roi(PointsView input, const RigidTransform& T, const GroundConfig& g, RoiCloud& out);

}  // namespace roadpreview
