// SPDX-License-Identifier: BSD-3-Clause
// Stage 2 — wheel paths from speed and yaw rate (nonholonomic rigid motion about the ICR).
//
// ICR at (0, y_icr) with y_icr = V/ω for every sign of V and ω (left turn forward: y_icr > 0).
// Wheels at y = ±track/2: r_left = |y_icr − track/2|, r_right = |y_icr + track/2| — for a left turn
// that is r − track/2 (inner) and r + track/2 (outer); for a right turn the other way round.
#pragma once

#include <algorithm>
#include <cmath>
#include <optional>

#include "roadpreview/core/config.hpp"
#include "roadpreview/core/status.hpp"

namespace roadpreview {

enum class PathStatus { Arc, Straight, Stopped };
enum class Wheel { Left, Right };

struct WheelPaths {
    PathStatus status = PathStatus::Stopped;
    double direction = 0.0;     ///< +1 forward, −1 reversing (looks behind), 0 stopped
    double rotation = 0.0;      ///< sign(ω): the sense in which the wheels sweep about the ICR
    double icr_y = 0.0;         ///< m, Arc only
    double left_radius = 0.0;   ///< m, Arc only
    double right_radius = 0.0;  ///< m, Arc only
    double track_width = 0.0;   ///< m

    double wheel_y(Wheel w) const { return w == Wheel::Left ? 0.5 * track_width : -0.5 * track_width; }
    double radius(Wheel w) const { return w == Wheel::Left ? left_radius : right_radius; }
};

/// |speed| above this is no ground vehicle's (3,600 km/h): a unit or a field mixed up, refused before it places a
/// fused map's pose beyond what its cell indices hold.
constexpr double kMaxSpeedMps = 1000.0;
/// |yaw rate| above this (16 turns a second) is no vehicle's either.
constexpr double kMaxYawRateRps = 100.0;

/// Speed not finite or beyond ±kMaxSpeedMps, yaw rate not finite or beyond ±kMaxYawRateRps:
/// StatusCode::InvalidArgument with the message plan_paths throws.
Status check_motion(double speed_mps, double yaw_rate_rps) noexcept;

/// Throws std::invalid_argument for a speed or yaw rate check_motion refuses (its message).
WheelPaths plan_paths(double speed_mps, double yaw_rate_rps, double track_width, const PathConfig& cfg);

/// Arc length s ≥ 0 travelled by wheel `w` until it is beside (x, y), if (x, y) lies in that wheel's
/// corridor (within tire_width/2 of its path) ahead of it in the direction of travel; nullopt otherwise.
/// Inline: the profile and obstacle stages ask it for every ground and clustered point, twice.
inline std::optional<double> arc_length(const WheelPaths& p, Wheel w, double x, double y, double tire_width) {
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
    // In the corridor when |ρ − r_w| ≤ half for ρ = |u|: compared squared, so the many points outside it cost no
    // square root.
    const double rho_sq = ux * ux + uy * uy;
    const double inner = std::max(r_w - half, 0.0), outer = r_w + half;
    if (rho_sq < inner * inner || rho_sq > outer * outer || r_w <= 0.0) return std::nullopt;
    const double w0y = y_w - p.icr_y;  // wheel relative to the ICR (its x is 0)
    const double phi = std::atan2(-w0y * ux, w0y * uy);  // angle from w0 to u: atan2(w0 × u, w0 · u)
    if (phi * p.rotation < 0.0) return std::nullopt;      // behind the wheel
    return std::abs(phi) * r_w;
}

const char* to_string(PathStatus s);

}  // namespace roadpreview
