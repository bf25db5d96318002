// SPDX-License-Identifier: BSD-3-Clause
// Stage 0 — input and frames: sensor-frame points → base-frame points in the front region of interest.
#pragma once

#include "roadpreview/core/config.hpp"

namespace roadpreview {

/// Row-major rotation R = Rz(yaw)·Ry(pitch)·Rx(roll) and translation t: p_base = R·p_sensor + t.
struct RigidTransform {
    double R[3][3];
    double t[3];
};

RigidTransform to_rigid_transform(const Extrinsics& e);

/// The region of interest facing the direction of travel: the configured (front) one, or, when reversing
/// (direction < 0), the same region mirrored behind the vehicle (x ∈ [−roi_x_max_m, −roi_x_min_m]).
GroundConfig roi_facing(const GroundConfig& g, double direction);

/// The region a frame is cropped to, as a sensor sees it: the base-frame box x ∈ [x_min_m, x_max_m],
/// |y| ≤ y_abs_max_m (any height), and the sensor's pose in the base frame. A reader can leave out what cannot
/// reach it (SourceOptions::roi_columns).
struct SensorRoi {
    Extrinsics sensor;
    double x_min_m = 0.0, x_max_m = 0.0, y_abs_max_m = 0.0;
};

/// The region the pipeline crops to with `cfg`: ahead (direction ≥ 0) or behind (roi_facing), the sensor at
/// effective_extrinsics(cfg).
SensorRoi sensor_roi(const Config& cfg, double direction);

/// Whether the ray origin + t·direction (t ≥ 0, sensor frame) passes over the region: some point of it can lie
/// in the region. `T` is to_rigid_transform(roi.sensor).
bool ray_reaches(const SensorRoi& roi, const RigidTransform& T, const double origin[3], const double direction[3]);

/// Apply T to one point.
inline void transform_point(const RigidTransform& T, const double p[3], double out[3]) {
    for (int r = 0; r < 3; ++r) out[r] = T.R[r][0] * p[0] + T.R[r][1] * p[1] + T.R[r][2] * p[2] + T.t[r];
}

}  // namespace roadpreview
