// SPDX-License-Identifier: BSD-3-Clause
// The profile read a fixed distance ahead (docs/method.md §10, "Readout"): the moving-average paper's array. Each
// frame reads each wheel's profile into an array along the drive from `ahead_m` ahead on; the array shifts as the
// vehicle drives on, and what lies nearer than ahead_m keeps what the last frame that had it ahead_m or more ahead
// read of it (with a fused map: after every frame that saw it from further away) — the stretch between the wheel
// and ahead_m that a suspension controller consumes.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "roadpreview/core/config.hpp"
#include "roadpreview/fusion/fusion.hpp"
#include "roadpreview/pipeline/pipeline.hpp"
#include "roadpreview/route/drive_distance.hpp"

namespace roadpreview {

/// One wheel's readout: the bins of the drive grid from the wheel to ahead_m, nearest first.
struct ReadoutProfile {
    std::vector<double> s;            ///< m, arc length along the wheel's current path to the bin's centre
    std::vector<double> z;            ///< m, the height read; NaN where none was
    std::vector<std::int32_t> count;  ///< the points behind the nearer profile bin it was read from (0: interpolated)
};

class ProfileReadout {
public:
    /// Throws std::invalid_argument on a bad config, or when `ahead_m` is not a positive number of metres within
    /// the profiles' length (profile.preview_length_m).
    ProfileReadout(const Config& cfg, double ahead_m);

    /// Adds the next frame (drive order): the drive moves on as for the route, the bins behind the wheels drop
    /// out, and a frame with profiles is read from ahead_m on (a wheel with more than kMaxDrivePerWheelMetre of
    /// drive per metre of its path reads nothing). Throws std::invalid_argument as RouteBuilder::add, leaving the
    /// readout as it was.
    void add(const Result& r, const std::optional<Pose2>& pose = std::nullopt);

    double ahead_m() const { return ahead_m_; }
    std::size_t frames() const { return drive_.frames(); }
    double distance_m() const { return drive_.metres(); }  ///< driven by the last frame added
    const ReadoutProfile& left() const { return left_.out; }
    const ReadoutProfile& right() const { return right_.out; }

private:
    struct Bin {
        double z;
        std::int32_t count;
    };
    struct WheelArray {
        std::vector<Bin> bins;  // drive bins first, first + 1, …
        std::int64_t first = 0;
        double drive_per_metre = 1.0;  // the wheel's q of the last frame it read (docs/method.md §10)
        ReadoutProfile out;
    };
    void shift(WheelArray& w) const;
    void read(const Profile& p, WheelArray& w) const;
    std::optional<Bin> profile_at(const Profile& p, double s) const;
    void state(WheelArray& w) const;

    double ahead_m_, ds_, reach_m_;
    DriveDistance drive_;
    WheelArray left_, right_;
};

}  // namespace roadpreview
