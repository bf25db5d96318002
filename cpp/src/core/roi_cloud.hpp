// SPDX-License-Identifier: BSD-3-Clause
// Internal: the one per-frame copy of the cloud — base-frame points of the front ROI, stored as a PCL
// cloud so that RANSAC (and later clustering) use it in place, and viewed as N×3 floats by everything else.
// The points are ordered by square cells of the ROI (a counting sort, stable: input order within a cell), so
// that every later stage reads memory in spatial order whatever the order of the input rows.
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
    std::vector<std::int32_t> input_order;  ///< the ROI points' positions in the order of their input rows
    std::int64_t finite = 0;                ///< input rows with finite x, y, z
    std::vector<float> height_variance;     ///< m² per ROI point (from its range variance); empty when unknown
    std::vector<std::int32_t> error_group;  ///< each ROI point's input error group; empty when unknown

    Eigen::Index size() const { return static_cast<Eigen::Index>(input_index.size()); }
    PointsView view() const {  // pcl::PointXYZ is x, y, z + one padding float
        static_assert(sizeof(pcl::PointXYZ) == 4 * sizeof(float));
        return points_view(cloud->points.empty() ? nullptr : cloud->points[0].data, size(), 4);
    }

    // Scratch of crop_roi, kept so that a stream of frames allocates nothing once the buffers have grown.
    struct Candidate {
        float x, y, z;
        std::uint32_t cell;
        std::int32_t row;
    };
    std::vector<Candidate> scratch;
    std::vector<std::uint32_t> cell_start;
};

/// Transform, drop non-finite rows (counted), crop to the ROI and order the points by cell; reuses `out`'s
/// buffers. The rows are transformed on up to `threads` threads (the same answer for any number).
void crop_roi(PointsView input, const RigidTransform& T, const GroundConfig& g, RoiCloud& out, int threads = 1);

/// Each ROI point's height variance (none: cleared): from its input row's range variance, an error along the line of
/// sight from the sensor (at T's origin) moving the point by u_z per metre, u the ray's direction; plus, with its
/// beam known and beam_sigma_rad > 0, its beam's elevation error, which moves it by its horizontal distance d from
/// the sensor per radian (d²·σ²). And its error group (none: cleared): its input row's, else its beam while that
/// error is counted.
void roi_point_errors(const PointErrors& errors, const RigidTransform& T, double beam_sigma_rad, RoiCloud& roi);

}  // namespace roadpreview
