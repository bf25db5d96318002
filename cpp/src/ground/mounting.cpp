// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/ground/mounting.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace roadpreview {

Mounting mounting_from_plane(const Plane& p) {
    Mounting m;
    m.height_m = p[3];
    m.roll_rad = std::atan2(p[1], p[2]);
    m.pitch_rad = -std::asin(std::clamp(p[0], -1.0, 1.0));
    return m;
}

std::optional<Mounting> estimate_mounting(PointsView sensor_points, const GroundConfig& cfg) {
    std::vector<float> below;  // the ground lies below the sensor: a ceiling or a canopy cannot be it
    for (Eigen::Index i = 0; i < sensor_points.rows(); ++i)
        if (sensor_points(i, 2) < 0.0f)
            for (int c = 0; c < 3; ++c) below.push_back(sensor_points(i, c));
    const GroundFit fit = fit_ground(points_view(below.data(), static_cast<Eigen::Index>(below.size() / 3), 3), cfg);
    if (!fit.plane) return std::nullopt;
    Mounting m = mounting_from_plane(*fit.plane);
    m.ground_points = fit.count;
    return m;
}

Extrinsics to_extrinsics(const Mounting& m) { return Extrinsics{0.0, 0.0, m.height_m, m.roll_rad, m.pitch_rad, 0.0}; }

MountingCheck check_mounting(const Plane& base_plane) {
    MountingCheck c;
    c.offset_m = base_plane[3];
    c.tilt_deg = std::acos(std::clamp(base_plane[2], -1.0, 1.0)) * 180.0 / M_PI;
    c.disagrees = std::abs(c.offset_m) > kMountingMaxOffsetM || c.tilt_deg > kMountingMaxTiltDeg;
    return c;
}

}  // namespace roadpreview
