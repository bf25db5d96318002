// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/paths/path.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace roadpreview {

const char* to_string(PathStatus s) {
    switch (s) {
        case PathStatus::Arc: return "arc";
        case PathStatus::Straight: return "straight";
        case PathStatus::Stopped: return "stopped";
    }
    return "?";
}

Status check_motion(double speed_mps, double yaw_rate_rps) noexcept {
    // %f: the text std::to_string gave these messages before.
    if (!std::isfinite(speed_mps)) return Status::error(StatusCode::InvalidArgument, "speed must be finite, got %f", speed_mps);
    if (std::abs(speed_mps) > kMaxSpeedMps)
        return Status::error(StatusCode::InvalidArgument, "speed must be within ±%g m/s (no ground vehicle drives "
                             "faster: a unit mixed up?), got %g m/s", kMaxSpeedMps, speed_mps);
    if (!std::isfinite(yaw_rate_rps))
        return Status::error(StatusCode::InvalidArgument, "yaw_rate must be finite, got %f", yaw_rate_rps);
    if (std::abs(yaw_rate_rps) > kMaxYawRateRps)
        return Status::error(StatusCode::InvalidArgument, "yaw_rate must be within ±%g rad/s (no vehicle turns "
                             "faster: degrees for radians?), got %g rad/s", kMaxYawRateRps, yaw_rate_rps);
    return {};
}

WheelPaths plan_paths(double speed_mps, double yaw_rate_rps, double track_width, const PathConfig& cfg) {
    if (const Status s = check_motion(speed_mps, yaw_rate_rps); !s) throw std::invalid_argument(s.message());
    WheelPaths p;
    p.track_width = track_width;
    if (std::abs(speed_mps) <= cfg.stopped_speed_mps) return p;  // Stopped: no path to preview

    p.direction = speed_mps > 0.0 ? 1.0 : -1.0;
    // Compare |V| > R·|ω| rather than |V/ω| > R: no division, and ω = 0 falls out as straight.
    if (std::abs(speed_mps) > cfg.straight_radius_m * std::abs(yaw_rate_rps)) {
        p.status = PathStatus::Straight;
        return p;
    }
    p.status = PathStatus::Arc;
    p.rotation = yaw_rate_rps > 0.0 ? 1.0 : -1.0;
    p.icr_y = speed_mps / yaw_rate_rps;
    p.left_radius = std::abs(p.icr_y - 0.5 * track_width);
    p.right_radius = std::abs(p.icr_y + 0.5 * track_width);
    return p;
}

}  // namespace roadpreview
