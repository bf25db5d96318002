// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/route/drive_distance.hpp"

#include <stdexcept>

namespace roadpreview {

void DriveDistance::advance(const Result& r, const std::optional<Pose2>& pose, const char* who) {
    if (frames_ > 0 && pose.has_value() != last_pose_.has_value())
        throw std::invalid_argument(frame_name(r, who) + ": poses must be given for every frame or for none");
    double step = 0.0;
    if (frames_ > 0 && pose) {
        step = std::hypot(pose->x_m - last_pose_->x_m, pose->y_m - last_pose_->y_m);
    } else if (frames_ > 0) {
        double dt_s = frame_period_s_;
        if (r.timestamp && last_timestamp_) dt_s = *r.timestamp - *last_timestamp_;
        if (dt_s < 0.0)
            throw std::invalid_argument(frame_name(r, who) + " is " + std::to_string(-dt_s) +
                                        " s before the previous frame");
        step = std::abs(r.speed_mps) * dt_s;
    }
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
