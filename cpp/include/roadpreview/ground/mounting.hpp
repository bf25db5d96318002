// SPDX-License-Identifier: BSD-3-Clause
// The sensor's mounting read off the ground (docs/method.md §1, "Mounting from the ground"): its height above
// the fitted ground plane and the roll and pitch that level it; and how far a given mounting is from the ground
// the points show.
#pragma once

#include <cstdint>
#include <optional>

#include "roadpreview/core/config.hpp"
#include "roadpreview/core/points.hpp"
#include "roadpreview/ground/ground.hpp"

namespace roadpreview {

struct Mounting {
    double height_m = 0.0;   ///< sensor origin above the ground plane
    double roll_rad = 0.0;   ///< extrinsics roll and pitch that make the plane level (yaw cannot be seen)
    double pitch_rad = 0.0;
    std::int64_t ground_points = 0;  ///< points of the fit
};

/// The mounting a ground plane fitted in the sensor frame implies: with extrinsics (0, 0, h, roll, pitch, 0)
/// the plane becomes z = 0, i.e. its unit normal n = (−sin pitch, cos pitch·sin roll, cos pitch·cos roll)
/// and h = d.
Mounting mounting_from_plane(const Plane& sensor_plane);

/// Fits the ground to the sensor-frame points below the sensor (z < 0) as if the sensor were level at the base
/// origin (cfg's ROI and method) and returns the mounting it implies; nullopt without ground.
std::optional<Mounting> estimate_mounting(PointsView sensor_points, const GroundConfig& cfg);

/// Extrinsics (0, 0, height, roll, pitch, 0).
Extrinsics to_extrinsics(const Mounting& m);

/// How far the ground fitted in the base frame lies from where the extrinsics put it.
struct MountingCheck {
    double offset_m = 0.0;   ///< height of the base origin above the fitted plane (0: the height is right)
    double tilt_deg = 0.0;   ///< angle between the plane's normal and the base z axis (0: the tilt is right)
    bool disagrees = false;  ///< offset or tilt beyond the limits below
};

constexpr double kMountingMaxOffsetM = 0.3;   ///< more than this between given and fitted height: warn
constexpr double kMountingMaxTiltDeg = 5.0;   ///< a ground tilted more than this in the base frame: warn

MountingCheck check_mounting(const Plane& base_plane);

}  // namespace roadpreview
