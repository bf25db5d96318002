// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/route/readout.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include "core/text.hpp"

namespace roadpreview {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string metres(double v) { return number_text(v) + " m"; }

}  // namespace

ProfileReadout::ProfileReadout(const Config& cfg, double ahead_m)
    : ahead_m_(ahead_m), ds_(cfg.profile.ds_m), reach_m_(profile_reach_m(cfg)),
      drive_(cfg.fusion.frame_rate_hz) {
    validate(cfg);
    if (!(ahead_m > 0.0) || !std::isfinite(ahead_m))
        throw std::invalid_argument("readout: the distance ahead must be a positive number of metres, got " +
                                    number_text(ahead_m));
    if (ahead_m >= cfg.profile.preview_length_m)
        throw std::invalid_argument("readout: the distance ahead (" + metres(ahead_m) +
                                    ") must lie within the profiles (profile.preview_length_m " +
                                    metres(cfg.profile.preview_length_m) + ")");
}

void ProfileReadout::add(const Result& r, const std::optional<Pose2>& pose) {
    // Both wheels checked before anything changes: a frame that fails leaves the readout as it was.
    const bool read_left = drive_.placeable(r, Wheel::Left, reach_m_, "readout");
    const bool read_right = drive_.placeable(r, Wheel::Right, reach_m_, "readout");
    drive_.advance(r, pose, "readout");
    const auto wheel = [&](Wheel side, bool read_it, WheelArray& w) {
        shift(w);
        if (read_it) {
            w.drive_per_metre = drive_per_wheel_metre(r.path, side);
            read(side == Wheel::Left ? r.left : r.right, w);
        }
        state(w);
    };
    wheel(Wheel::Left, read_left, left_);
    wheel(Wheel::Right, read_right, right_);
}

// Drops the bins the wheel has passed: the array starts at the wheel's bin.
void ProfileReadout::shift(WheelArray& w) const {
    const auto passed = static_cast<std::int64_t>(std::floor(drive_.metres() / ds_));
    const auto drop = static_cast<std::size_t>(
        std::clamp<std::int64_t>(passed - w.first, 0, static_cast<std::int64_t>(w.bins.size())));
    w.bins.erase(w.bins.begin(), w.bins.begin() + static_cast<std::ptrdiff_t>(drop));
    w.first = passed;
}

// Every drive bin whose centre lies ahead_m or more ahead, read from the profile at its arc length; a bin the
// profile has no height for keeps what it held. Nearer than ahead_m nothing changes: those bins hold what the
// last frame that had them ahead_m or more ahead read of them.
void ProfileReadout::read(const Profile& p, WheelArray& w) const {
    if (p.s.empty()) return;
    const double d = drive_.metres();
    const double last_s = p.s.front() + static_cast<double>(p.s.size() - 1) * ds_ + 1e-9;  // bins are ds apart
    for (auto j = static_cast<std::int64_t>(std::ceil((d + ahead_m_) / ds_ - 0.5));; ++j) {
        const double ahead = (static_cast<double>(j) + 0.5) * ds_ - d;
        if (ahead / w.drive_per_metre > last_s) break;
        if (ahead < ahead_m_) continue;  // rounding at the start
        const std::optional<Bin> bin = profile_at(p, ahead / w.drive_per_metre);
        if (!bin) continue;
        const auto i = static_cast<std::size_t>(j - w.first);  // j ≥ the wheel's bin: ahead > 0
        if (i >= w.bins.size()) w.bins.resize(i + 1, Bin{kNaN, 0});
        w.bins[i] = *bin;
    }
}

// The profile at arc length s: a bin centre's own value, else linear between the two bins around s, both with a
// height (the paper's weighted sum of neighbouring cells).
std::optional<ProfileReadout::Bin> ProfileReadout::profile_at(const Profile& p, double s) const {
    const double at = (s - p.s.front()) / ds_;
    const double below = std::floor(at + 1e-9);
    if (below < 0.0 || below >= static_cast<double>(p.z.size())) return std::nullopt;
    const auto k = static_cast<std::size_t>(below);
    const double t = std::max(0.0, at - below);
    if (t < 1e-9) return std::isfinite(p.z[k]) ? std::optional<Bin>(Bin{p.z[k], p.count[k]}) : std::nullopt;
    if (k + 1 >= p.z.size() || !std::isfinite(p.z[k]) || !std::isfinite(p.z[k + 1])) return std::nullopt;
    return Bin{(1.0 - t) * p.z[k] + t * p.z[k + 1], t < 0.5 ? p.count[k] : p.count[k + 1]};
}

// The readout: the bins from the wheel to ahead_m, relative to the wheel.
void ProfileReadout::state(WheelArray& w) const {
    w.out.s.clear();
    w.out.z.clear();
    w.out.count.clear();
    const double d = drive_.metres();
    for (std::int64_t j = w.first;; ++j) {
        const double ahead = (static_cast<double>(j) + 0.5) * ds_ - d;
        if (ahead >= ahead_m_) break;
        if (ahead < 0.0) continue;  // the far half of the wheel's bin
        const auto i = static_cast<std::size_t>(j - w.first);
        const bool held = i < w.bins.size();
        w.out.s.push_back(ahead / w.drive_per_metre);
        w.out.z.push_back(held ? w.bins[i].z : kNaN);
        w.out.count.push_back(held ? w.bins[i].count : 0);
    }
}

}  // namespace roadpreview
