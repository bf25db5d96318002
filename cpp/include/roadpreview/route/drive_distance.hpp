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

/// A frame moves the drive on by at most this (docs/method.md §10): 1 km between two frames of a 10 Hz sensor is
/// 36,000 km/h, a speed, time stamp or pose no drive has, and bins placed beyond it would be allocated.
constexpr double kMaxFrameStepM = 1000.0;
/// A wheel with more drive distance per metre of its arc than this lies nearer to the centre of rotation than 1 %
/// of the vehicle's turning radius: its profile's 40 m would span kilometres of drive. It places nothing.
constexpr double kMaxDrivePerWheelMetre = 100.0;

/// How far from the wheel a profile's bins may lie, either way: profile.preview_length_m ahead, fusion.behind_m
/// behind. A bin beyond it was not written by the pipeline (a line edited or broken): an error, not a placement.
inline double profile_reach_m(const Config& cfg) { return cfg.profile.preview_length_m + cfg.fusion.behind_m; }

class DriveDistance {
public:
    explicit DriveDistance(double frame_rate_hz) : frame_period_s_(1.0 / frame_rate_hz) {}

    /// Moves on to frame `r`: by the distance between the poses when given, else by |speed| times the time since
    /// the previous frame (its timestamps, else the frame period). Throws std::invalid_argument starting with
    /// "<who>: frame N (source)" when the time goes back, poses are given for some frames only, or the step is
    /// not a finite number of at most kMaxFrameStepM.
    void advance(const Result& r, const std::optional<Pose2>& pose, const char* who);

    /// Whether the next frame's profile of wheel `w` can be placed along the drive: false for a frame without
    /// profiles and for a wheel with q = drive_per_wheel_metre above kMaxDrivePerWheelMetre. What the pipeline
    /// never writes (a line read back from a file may hold anything) throws std::invalid_argument starting as
    /// advance's errors: a bin not finite or beyond `reach_m`, a q that is not a finite positive number.
    bool placeable(const Result& r, Wheel w, double reach_m, const char* who) const;

    double metres() const { return metres_; }       ///< driven up to the last frame
    std::size_t frames() const { return frames_; }  ///< frames advanced to

private:
    std::string frame_name(const Result& r, const char* who) const;  // "<who>: frame N (source)", N = frames_

    double frame_period_s_;
    double metres_ = 0.0;
    std::size_t frames_ = 0;
    std::optional<double> last_timestamp_;
    std::optional<Pose2> last_pose_;
};

}  // namespace roadpreview
