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
    if (!std::isfinite(yaw_rate_rps))
        return Status::error(StatusCode::InvalidArgument, "yaw_rate must be finite, got %f", yaw_rate_rps);
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

std::optional<double> arc_length(const WheelPaths& p, Wheel w, double x, double y, double tire_width) {
    const double half = 0.5 * tire_width;
    const double y_w = p.wheel_y(w);
    if (p.status == PathStatus::Straight) {
        if (std::abs(y - y_w) > half) return std::nullopt;
        const double s = p.direction * x;
        return s >= 0.0 ? std::optional<double>(s) : std::nullopt;
    }
    if (p.status != PathStatus::Arc) return std::nullopt;
    const double r_w = p.radius(w);
    const double ux = x, uy = y - p.icr_y;  // point relative to the ICR
    // sqrt, not std::hypot: coordinates are metres, far from overflow, and hypot is several times slower.
    if (std::abs(std::sqrt(ux * ux + uy * uy) - r_w) > half || r_w <= 0.0) return std::nullopt;
    const double w0y = y_w - p.icr_y;  // wheel relative to the ICR (its x is 0)
    const double phi = std::atan2(-w0y * ux, w0y * uy);  // angle from w0 to u: atan2(w0 × u, w0 · u)
    if (phi * p.rotation < 0.0) return std::nullopt;      // behind the wheel
    return std::abs(phi) * r_w;
}

}  // namespace roadpreview
