// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/core/frames.hpp"

#include <cmath>

#include "core/roi_cloud.hpp"

namespace roadpreview {

RigidTransform to_rigid_transform(const Extrinsics& e) {
    const double cr = std::cos(e.roll_rad), sr = std::sin(e.roll_rad);
    const double cp = std::cos(e.pitch_rad), sp = std::sin(e.pitch_rad);
    const double cy = std::cos(e.yaw_rad), sy = std::sin(e.yaw_rad);
    // Rz(yaw) · Ry(pitch) · Rx(roll)
    return RigidTransform{{{cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr},
                           {sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr},
                           {-sp, cp * sr, cp * cr}},
                          {e.x_m, e.y_m, e.z_m}};
}

void crop_roi(PointsView input, const RigidTransform& T, const GroundConfig& g, RoiCloud& out) {
    auto& pts = out.cloud->points;
    pts.clear();
    out.input_index.clear();
    out.finite = 0;
    for (Eigen::Index i = 0; i < input.rows(); ++i) {
        const double p[3] = {input(i, 0), input(i, 1), input(i, 2)};
        if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) continue;
        ++out.finite;
        double b[3];
        transform_point(T, p, b);
        if (b[0] < g.roi_x_min_m || b[0] > g.roi_x_max_m || std::abs(b[1]) > g.roi_y_abs_max_m) continue;
        pts.emplace_back(static_cast<float>(b[0]), static_cast<float>(b[1]), static_cast<float>(b[2]));
        out.input_index.push_back(static_cast<std::int32_t>(i));
    }
    out.cloud->width = static_cast<std::uint32_t>(pts.size());
    out.cloud->height = 1;
}

void roi_height_variances(const float* range_variances_m2, const RigidTransform& T, RoiCloud& roi) {
    roi.height_variance.clear();
    if (!range_variances_m2) return;
    roi.height_variance.resize(roi.input_index.size());
    for (std::size_t i = 0; i < roi.input_index.size(); ++i) {
        const auto& p = roi.cloud->points[i];
        const double dx = p.x - T.t[0], dy = p.y - T.t[1], dz = p.z - T.t[2];
        const double squared_range = dx * dx + dy * dy + dz * dz;
        const double uz2 = squared_range > 0.0 ? dz * dz / squared_range : 1.0;
        const double v = range_variances_m2[roi.input_index[i]];
        roi.height_variance[i] = static_cast<float>(std::isfinite(v) && v > 0.0 ? uz2 * v : 0.0);
    }
}

}  // namespace roadpreview
