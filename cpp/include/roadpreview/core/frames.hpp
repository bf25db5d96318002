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

/// Apply T to one point.
inline void transform_point(const RigidTransform& T, const double p[3], double out[3]) {
    for (int r = 0; r < 3; ++r) out[r] = T.R[r][0] * p[0] + T.R[r][1] * p[1] + T.R[r][2] * p[2] + T.t[r];
}

}  // namespace roadpreview
