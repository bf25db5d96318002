// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/profile/profile.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "core/median.hpp"
#include "ground/plane_fit.hpp"

namespace roadpreview {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Hit {
    std::int32_t bin;
    double z;
    double variance;  // m², the point's height variance (0 when unknown)
};

// Bins the hits of one wheel (counting sort by bin), takes per-bin medians outside blocked bins, fills short gaps.
Profile bin_profile(const std::vector<Hit>& hits, std::size_t bins, const ProfileConfig& cfg,
                    const std::vector<std::uint8_t>* blocked) {
    Profile p;
    p.blocked = blocked ? *blocked : std::vector<std::uint8_t>(bins, 0);
    if (p.blocked.size() != bins) throw std::invalid_argument("blocked bins do not match the profile's bins");
    p.ds = cfg.ds_m;
    p.s0 = 0.5 * cfg.ds_m;
    p.s.resize(bins);
    for (std::size_t k = 0; k < bins; ++k) p.s[k] = (static_cast<double>(k) + 0.5) * cfg.ds_m;
    p.count.assign(bins, 0);
    std::vector<double> variance_sum(bins, 0.0);
    for (const Hit& h : hits) ++p.count[static_cast<std::size_t>(h.bin)], variance_sum[static_cast<std::size_t>(h.bin)] += h.variance;

    std::vector<std::size_t> start(bins + 1, 0);
    for (std::size_t k = 0; k < bins; ++k) start[k + 1] = start[k] + static_cast<std::size_t>(p.count[k]);
    std::vector<double> sorted(hits.size());
    std::vector<std::size_t> next(start.begin(), start.end() - 1);
    for (const Hit& h : hits) sorted[next[static_cast<std::size_t>(h.bin)]++] = h.z;

    p.z.assign(bins, kNaN);
    p.spread.assign(bins, kNaN);
    for (std::size_t k = 0; k < bins; ++k) {
        if (p.count[k] == 0 || p.blocked[k]) continue;  // an obstacle's points are not road
        const auto first = sorted.begin() + static_cast<std::ptrdiff_t>(start[k]);
        const auto last = sorted.begin() + static_cast<std::ptrdiff_t>(start[k + 1]);
        if (p.count[k] > 1) p.spread[k] = noise_spread(sample_spread(first, last), variance_sum[k] / p.count[k]);
        p.z[k] = median(first, last);
    }
    fill_gaps(p.z, cfg.ds_m, cfg.max_gap_m, &p.blocked);
    return p;
}

}  // namespace

Levelling levelling_for(const Plane* plane) {
    Levelling L{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
    if (!plane) return L;
    const double a = (*plane)[0], b = (*plane)[1], c = (*plane)[2];  // unit normal, c > 0
    // Shortest-arc rotation taking (a, b, c) onto (0, 0, 1) (Rodrigues' formula, axis n × z).
    const double k = 1.0 / (1.0 + c);
    L = Levelling{{{1.0 - a * a * k, -a * b * k, -a}, {-a * b * k, 1.0 - b * b * k, -b}, {a, b, c}}};
    return L;
}

double distance_from_path(const WheelPaths& paths, double x, double y) {
    if (paths.status != PathStatus::Arc) return std::abs(y);
    return std::abs(std::hypot(x, y - paths.icr_y) - std::abs(paths.icr_y));
}

std::vector<double> local_ground_heights(PointsView points, const std::vector<std::uint8_t>& mask, const Plane& frame,
                                         double band_m, const WheelPaths& paths) {
    std::vector<std::int64_t> band(mask.size(), -1);
    std::vector<double> range(mask.size(), 0.0);
    std::int64_t bands = 0;
    for (Eigen::Index i = 0; i < points.rows(); ++i) {
        const auto at = static_cast<std::size_t>(i);
        if (!mask[at]) continue;
        range[at] = std::hypot(static_cast<double>(points(i, 0)), static_cast<double>(points(i, 1)));
        band[at] = static_cast<std::int64_t>(std::min(range[at] / band_m, 1e6));
        bands = std::max(bands, band[at] + 1);
    }
    std::vector<Moments> moments(static_cast<std::size_t>(bands));
    constexpr double kInf = std::numeric_limits<double>::infinity();
    std::vector<double> nearest(moments.size(), kInf), farthest(moments.size(), -kInf);
    for (Eigen::Index i = 0; i < points.rows(); ++i) {
        const auto at = static_cast<std::size_t>(i);
        if (band[at] < 0 || distance_from_path(paths, points(i, 0), points(i, 1)) > kLevelCorridorHalfWidthM) continue;
        const auto k = static_cast<std::size_t>(band[at]);
        moments[k].add(points.row(i).cast<double>().transpose());
        nearest[k] = std::min(nearest[k], range[at]);
        farthest[k] = std::max(farthest[k], range[at]);
    }
    std::vector<Plane> plane(moments.size(), frame);
    for (std::size_t k = 0; k < moments.size(); ++k)
        if (farthest[k] - nearest[k] >= kLevelMinSpan * band_m)  // a short patch cannot tell a grade
            if (const auto fit = plane_fit(moments[k])) plane[k] = fit->plane;
    std::vector<double> z(mask.size(), kNaN);
    for (Eigen::Index i = 0; i < points.rows(); ++i) {
        const auto k = band[static_cast<std::size_t>(i)];
        if (k >= 0)
            z[static_cast<std::size_t>(i)] =
                height_above(plane[static_cast<std::size_t>(k)], points(i, 0), points(i, 1), points(i, 2));
    }
    return z;
}

std::size_t bin_count(const ProfileConfig& cfg) {
    return static_cast<std::size_t>(std::ceil(cfg.preview_length_m / cfg.ds_m - 1e-9));
}

WheelProfiles build_profiles(PointsView points, const std::vector<std::uint8_t>& mask, const Levelling& L,
                             const WheelPaths& paths, double tire_width, const ProfileConfig& cfg,
                             const BlockedBins* blocked, const std::vector<double>* local_z,
                             const std::vector<float>* height_variances) {
    if (local_z && local_z->size() != mask.size()) throw std::invalid_argument("local_z and mask differ in length");
    if (height_variances && height_variances->size() != mask.size())
        throw std::invalid_argument("height_variances and mask differ in length");
    WheelProfiles out;
    if (paths.status == PathStatus::Stopped) return out;
    const std::size_t bins = bin_count(cfg);
    std::vector<Hit> hits[2];
    for (Eigen::Index i = 0; i < points.rows(); ++i) {
        if (!mask[static_cast<std::size_t>(i)]) continue;
        const auto [xl, yl, z_levelled] = L.apply(points(i, 0), points(i, 1), points(i, 2));
        const double zl = local_z ? (*local_z)[static_cast<std::size_t>(i)] : z_levelled;
        for (const Wheel w : {Wheel::Left, Wheel::Right}) {
            const auto s = arc_length(paths, w, xl, yl, tire_width);
            if (!s || *s >= cfg.preview_length_m) continue;
            // s < preview but s/ds can round up to `bins`: such a point belongs to the last bin.
            const auto bin = std::min(static_cast<std::size_t>(*s / cfg.ds_m), bins - 1);
            const double variance = height_variances ? (*height_variances)[static_cast<std::size_t>(i)] : 0.0;
            hits[static_cast<int>(w)].push_back({static_cast<std::int32_t>(bin), zl, variance});
        }
    }
    out.left = bin_profile(hits[static_cast<int>(Wheel::Left)], bins, cfg, blocked ? &blocked->left : nullptr);
    out.right = bin_profile(hits[static_cast<int>(Wheel::Right)], bins, cfg, blocked ? &blocked->right : nullptr);
    return out;
}

void fill_gaps(std::vector<double>& z, double ds, double max_gap_m, const std::vector<std::uint8_t>* blocked) {
    if (blocked && blocked->size() != z.size()) throw std::invalid_argument("fill_gaps: blocked and z differ in length");
    std::size_t last_valid = z.size();  // none yet
    bool gap_blocked = false;           // the current run of missing bins holds a blocked one
    for (std::size_t k = 0; k < z.size(); ++k) {
        const bool is_blocked = blocked && (*blocked)[k];
        if (std::isnan(z[k]) || is_blocked) {  // a blocked bin is never an end of an interpolation
            gap_blocked = gap_blocked || is_blocked;
            continue;
        }
        if (last_valid != z.size() && k - last_valid > 1 && !gap_blocked) {
            const std::size_t gap = k - last_valid - 1;
            if (static_cast<double>(gap) * ds <= max_gap_m + 1e-9) {
                const double z0 = z[last_valid], z1 = z[k];
                for (std::size_t j = 1; j <= gap; ++j)
                    z[last_valid + j] = z0 + (z1 - z0) * static_cast<double>(j) / static_cast<double>(gap + 1);
            }
        }
        last_valid = k;
        gap_blocked = false;
    }
}

}  // namespace roadpreview
