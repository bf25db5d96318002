// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/route/drive_distance.hpp"

#include <stdexcept>

#include "core/text.hpp"

namespace roadpreview {

bool DriveDistance::placeable(const Result& r, Wheel w, double reach_m, const char* who) const {
    if (r.status != FrameStatus::Ok) return false;  // no profiles: the frame only moves the drive on
    const double drive_per_metre = drive_per_wheel_metre(r.path, w);
    for (const double s : (w == Wheel::Left ? r.left : r.right).s)
        if (!(std::abs(s) <= reach_m))
            throw std::invalid_argument(frame_name(r, who) + ": a profile bin lies at " + number_text(s) +
                                        " m, beyond the profiles' reach (" + number_text(reach_m) + " m)");
    if (!(drive_per_metre > 0.0) || !std::isfinite(drive_per_metre))
        throw std::invalid_argument(frame_name(r, who) + ": the path's centre of rotation and wheel radii give no "
                                    "distance along the drive");
    return drive_per_metre <= kMaxDrivePerWheelMetre;
}

void DriveDistance::advance(const Result& r, const std::optional<Pose2>& pose, const char* who) {
    const auto fail = [&](const std::string& what) { throw std::invalid_argument(frame_name(r, who) + what); };
    if (frames_ > 0 && pose.has_value() != last_pose_.has_value())
        fail(": poses must be given for every frame or for none");
    double step = 0.0;
    if (frames_ > 0 && pose) {
        step = std::hypot(pose->x_m - last_pose_->x_m, pose->y_m - last_pose_->y_m);
    } else if (frames_ > 0) {
        double dt_s = frame_period_s_;
        if (r.timestamp && last_timestamp_) dt_s = *r.timestamp - *last_timestamp_;
        if (dt_s < 0.0) fail(" is " + number_text(-dt_s) + " s before the previous frame");
        step = std::abs(r.speed_mps) * dt_s;
    }
    if (!(step <= kMaxFrameStepM))  // NaN too
        fail(" moves the drive on by " + number_text(step) + " m (" +
             (pose ? "its pose's distance from the previous one" : "|speed| × its time since the previous frame") +
             "): more than " + number_text(kMaxFrameStepM) + " m per frame is no drive");
    metres_ += step;
    ++frames_;
    last_timestamp_ = r.timestamp;
    last_pose_ = pose;
}

std::string DriveDistance::frame_name(const Result& r, const char* who) const {
    const std::string source = r.source.empty() ? "" : " (" + r.source + ")";
    return std::string(who) + ": frame " + std::to_string(frames_) + source;
}

}  // namespace roadpreview
