// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/route/route.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <stdexcept>

#include "core/median.hpp"
#include "core/text.hpp"
#include "roadpreview/profile/profile.hpp"

namespace roadpreview {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr std::size_t kMinSharedBins = 10;  // a frame is levelled onto the drive only over ≥ 1 m of shared road

template <typename T>
void grow(std::vector<T>& v, std::size_t size, T fill) {
    if (v.size() < size) v.resize(size, fill);
}

// The golden car's rectified slope placed at the bin the car has reached, run over every valid stretch of
// an all-filled profile (NaN outside them and over each stretch's first moving average).
std::vector<double> rectified_slope_by_bin(const std::vector<double>& z, double ds) {
    std::vector<double> out(z.size(), kNaN);
    std::size_t first = 0;
    while (first < z.size()) {
        if (!std::isfinite(z[first])) {
            ++first;
            continue;
        }
        std::size_t last = first;
        while (last < z.size() && std::isfinite(z[last])) ++last;
        const std::vector<double> rs = iri_rectified_slope(z.data() + first, last - first, ds);
        const std::size_t lag = (last - first) - rs.size();  // the moving average's samples
        for (std::size_t i = 0; i < rs.size(); ++i) out[first + lag + i] = rs[i];
        first = last;
    }
    return out;
}

// IRI over bins [j0, j1): the mean rectified slope there, when the car ran over every one of them; its noise that
// of the segment's bins (`segment`, their profile) alone.
Iri segment_iri(const std::vector<double>& slope_by_bin, const Profile& segment, std::size_t j0, std::size_t j1) {
    const double ds = segment.ds;
    Iri out;
    double sum = 0.0;
    for (std::size_t j = j0; j < j1; ++j) {
        if (j >= slope_by_bin.size() || !std::isfinite(slope_by_bin[j])) {
            out.reason = IriReason::SegmentNotCovered;
            return out;
        }
        sum += slope_by_bin[j];
    }
    if (j1 <= j0) {
        out.reason = IriReason::NoValidProfile;
        return out;
    }
    out.value = 1000.0 * sum / static_cast<double>(j1 - j0);
    out.length_m = static_cast<double>(j1 - j0) * ds;
    out.noise = iri_noise(segment.count.data(), segment.spread.data(), segment.count.size(), ds);
    return out;
}

Profile segment_profile(const StitchedProfile& p, std::size_t j0, std::size_t j1) {
    Profile out;
    out.ds = p.ds;
    out.s0 = (static_cast<double>(j0) + 0.5) * p.ds;
    for (std::size_t j = j0; j < j1; ++j) {
        const bool inside = j < p.z.size();
        out.s.push_back((static_cast<double>(j) + 0.5) * p.ds);
        out.z.push_back(inside ? p.z[j] : kNaN);
        out.count.push_back(inside ? p.count[j] : 0);
        out.spread.push_back(inside ? p.spread[j] : kNaN);
    }
    return out;
}

double backed_fraction(const Profile& p) {
    if (p.count.empty()) return 0.0;
    const auto backed = std::count_if(p.count.begin(), p.count.end(), [](std::int32_t c) { return c > 0; });
    return static_cast<double>(backed) / static_cast<double>(p.count.size());
}

Pose2 interpolate(const Pose2& a, const Pose2& b, double t) {
    const double dyaw = std::remainder(b.yaw_rad - a.yaw_rad, 2.0 * M_PI);
    return {a.x_m + t * (b.x_m - a.x_m), a.y_m + t * (b.y_m - a.y_m), a.yaw_rad + t * dyaw};
}

}  // namespace

RouteBuilder::RouteBuilder(const Config& cfg) : cfg_(cfg), drive_(cfg.fusion.frame_rate_hz) { validate(cfg); }

void RouteBuilder::add(const Result& r, const std::optional<Pose2>& pose) {
    // Both wheels checked before anything changes: a frame that fails leaves the route as it was.
    const bool stitch_left = drive_.placeable(r, Wheel::Left, profile_reach_m(cfg_), "route");
    const bool stitch_right = drive_.placeable(r, Wheel::Right, profile_reach_m(cfg_), "route");
    drive_.advance(r, pose, "route");
    if (pose) track_.emplace_back(drive_.metres(), *pose);
    if (stitch_left) stitch(r.left, drive_per_wheel_metre(r.path, Wheel::Left), left_);
    if (stitch_right) stitch(r.right, drive_per_wheel_metre(r.path, Wheel::Right), right_);
}

// The frame's backed bins, shifted by the median of their differences to the drive's profile where both
// hold data (each frame's heights are relative to its own ground plane), added with their point counts as
// weights; its blocked bins marked.
void RouteBuilder::stitch(const Profile& p, double scale, WheelSums& w) {
    const double ds = cfg_.profile.ds_m;
    std::vector<std::pair<std::size_t, std::size_t>> bins;  // (drive bin, profile bin)
    std::vector<double> differences;
    const bool knows_blocked = p.blocked.size() == p.z.size();  // lines read back may not say
    for (std::size_t k = 0; k < p.z.size(); ++k) {
        const double d = drive_.metres() + p.s[k] * scale;
        if (d < 0.0) continue;
        const auto j = static_cast<std::size_t>(std::floor(d / ds));
        if (knows_blocked && p.blocked[k]) {
            grow(w.blocked, j + 1, std::uint8_t{0});
            w.blocked[j] = 1;
        }
        if (p.count[k] <= 0 || !std::isfinite(p.z[k])) continue;
        bins.emplace_back(j, k);
        if (j < w.weight.size() && w.weight[j] > 0.0) differences.push_back(p.z[k] - w.weighted_z[j] / w.weight[j]);
    }
    const double offset = differences.size() >= kMinSharedBins ? median(differences.begin(), differences.end()) : 0.0;
    for (const auto& [j, k] : bins) {
        grow(w.weight, j + 1, 0.0);
        grow(w.weighted_z, j + 1, 0.0);
        grow(w.weighted_square, j + 1, 0.0);
        grow(w.count, j + 1, 0);
        grow(w.frames, j + 1, 0);
        grow(w.last_frame, j + 1, std::size_t{0});
        const double c = p.count[k], z = p.z[k] - offset;
        const double spread = std::isfinite(p.spread[k]) ? p.spread[k] : 0.0;
        w.weight[j] += c;
        w.weighted_z[j] += c * z;
        w.weighted_square[j] += c * (spread * spread + z * z);
        w.count[j] += p.count[k];
        if (w.last_frame[j] != drive_.frames()) w.frames[j] += 1;
        w.last_frame[j] = drive_.frames();
    }
}

StitchedProfile RouteBuilder::finished(const WheelSums& w) const {
    StitchedProfile out;
    out.ds = cfg_.profile.ds_m;
    out.count = w.count;
    out.frames = w.frames;
    for (std::size_t j = 0; j < w.weight.size(); ++j) {
        const double mean = w.weight[j] > 0.0 ? w.weighted_z[j] / w.weight[j] : kNaN;
        const double variance =
            w.weight[j] > 0.0 ? std::max(0.0, w.weighted_square[j] / w.weight[j] - mean * mean) : kNaN;
        out.z.push_back(mean);
        out.spread.push_back(w.count[j] >= 2 ? std::sqrt(variance) : kNaN);
        // Road seen by any frame outweighs an obstacle seen by another (one that moved on, or a frame's margin).
        out.blocked.push_back(j < w.blocked.size() && w.blocked[j] && !(w.weight[j] > 0.0));
    }
    fill_gaps(out.z, out.ds, cfg_.profile.max_gap_m, &out.blocked);
    return out;
}

StitchedProfile RouteBuilder::left() const { return finished(left_); }
StitchedProfile RouteBuilder::right() const { return finished(right_); }

std::optional<Pose2> RouteBuilder::pose_at(double distance_m) const {
    if (track_.empty()) return std::nullopt;
    if (distance_m <= track_.front().first) return track_.front().second;
    for (std::size_t i = 1; i < track_.size(); ++i) {
        const auto& [d0, p0] = track_[i - 1];
        const auto& [d1, p1] = track_[i];
        if (distance_m <= d1) return d1 > d0 ? interpolate(p0, p1, (distance_m - d0) / (d1 - d0)) : p1;
    }
    return std::nullopt;  // the road ahead of the last frame: the drive was never there
}

void RouteBuilder::check_segment_length(double length_m) const {
    if (!(length_m >= cfg_.profile.ds_m) || !std::isfinite(length_m))
        throw std::invalid_argument("route: segment length must be a number of metres of at least one profile bin "
                                    "(profile.ds_m " + number_text(cfg_.profile.ds_m) + " m), got " +
                                    number_text(length_m));
}

std::vector<RouteSegment> RouteBuilder::segments(double length_m) const {
    check_segment_length(length_m);
    const StitchedProfile l = left(), r = right();
    const double ds = cfg_.profile.ds_m;
    const std::size_t bins = std::max(l.z.size(), r.z.size());
    const std::vector<double> slope_l = rectified_slope_by_bin(l.z, ds), slope_r = rectified_slope_by_bin(r.z, ds);
    std::vector<RouteSegment> out;
    for (std::size_t k = 0;; ++k) {
        const auto j0 = static_cast<std::size_t>(std::llround(static_cast<double>(k) * length_m / ds));
        if (j0 >= bins) break;
        const auto end = static_cast<std::size_t>(std::llround(static_cast<double>(k + 1) * length_m / ds));
        const auto j1 = std::min(bins, end);
        RouteSegment s;
        s.length_m = length_m;
        s.start_m = static_cast<double>(j0) * ds;
        s.end_m = static_cast<double>(j1) * ds;
        s.start = pose_at(s.start_m);
        s.end = pose_at(s.end_m);
        const Profile pl = segment_profile(l, j0, j1), pr = segment_profile(r, j0, j1);
        s.left = {analyze_roughness(pl, cfg_.roughness), segment_iri(slope_l, pl, j0, j1), backed_fraction(pl)};
        s.right = {analyze_roughness(pr, cfg_.roughness), segment_iri(slope_r, pr, j0, j1), backed_fraction(pr)};
        Roughness vehicle = vehicle_roughness(pl, pr, cfg_.roughness);
        reconcile_vehicle(vehicle, s.left.roughness, s.right.roughness);  // as a frame's (method.md §4, "Vehicle")
        s.vehicle = {vehicle, vehicle_iri(s.left.iri, s.right.iri),
                     0.5 * (s.left.backed_fraction + s.right.backed_fraction)};
        out.push_back(std::move(s));
    }
    return out;
}

}  // namespace roadpreview
