// SPDX-License-Identifier: BSD-3-Clause
// How far the vehicle has driven, frame by frame (docs/method.md §10, "Drive distance"), and where a wheel's
// profile bins lie along it: what the route (RouteBuilder) and the readout (ProfileReadout) place frames by.
#pragma once

#include <cmath>
#include <cstddef>
#include <optional>
#include <string>

#include "roadpreview/fusion/fusion.hpp"
#include "roadpreview/pipeline/pipeline.hpp"

namespace roadpreview {

/// Drive distance per metre of a wheel's arc length: |y_icr| / r_w on an arc, 1 on a straight path.
inline double drive_per_wheel_metre(const WheelPaths& p, Wheel w) {
    if (p.status != PathStatus::Arc || p.radius(w) <= 0.0) return 1.0;
    return std::abs(p.icr_y) / p.radius(w);
}

class DriveDistance {
public:
    explicit DriveDistance(double frame_rate_hz) : frame_period_s_(1.0 / frame_rate_hz) {}

    /// Moves on to frame `r`: by the distance between the poses when given, else by |speed| times the time since
    /// the previous frame (its timestamps, else the frame period). Throws std::invalid_argument starting with
    /// "<who>: frame N (source)" when the time goes back or poses are given for some frames only.
    void advance(const Result& r, const std::optional<Pose2>& pose, const char* who);

    double metres() const { return metres_; }       ///< driven up to the last frame
    std::size_t frames() const { return frames_; }  ///< frames advanced to

private:
    std::string frame_name(const Result& r, const char* who) const;

    double frame_period_s_;
    double metres_ = 0.0;
    std::size_t frames_ = 0;
    std::optional<double> last_timestamp_;
    std::optional<Pose2> last_pose_;
};

}  // namespace roadpreview
