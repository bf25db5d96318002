// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/profile/profile.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>

#include "core/median.hpp"
#include "ground/plane_fit.hpp"
#include "profile/profile_scratch.hpp"

namespace roadpreview {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Bins the hits of one wheel (counting sort by bin), takes per-bin medians outside blocked bins, fills short gaps.
void bin_profile(const std::vector<Hit>& hits, std::size_t bins, const ProfileConfig& cfg,
                 const std::vector<std::uint8_t>* blocked, bool grouped, ProfileScratch& s, Profile& p) {
    if (blocked) p.blocked.assign(blocked->begin(), blocked->end());
    else p.blocked.assign(bins, 0);
    if (p.blocked.size() != bins) throw std::invalid_argument("blocked bins do not match the profile's bins");
    p.ds = cfg.ds_m;
    p.s0 = 0.5 * cfg.ds_m;
    p.s.resize(bins);
    for (std::size_t k = 0; k < bins; ++k) p.s[k] = (static_cast<double>(k) + 0.5) * cfg.ds_m;
    p.count.assign(bins, 0);
    s.variance_sum.assign(bins, 0.0);
    for (const Hit& h : hits) ++p.count[static_cast<std::size_t>(h.bin)], s.variance_sum[static_cast<std::size_t>(h.bin)] += h.variance;

    s.start.assign(bins + 1, 0);
    for (std::size_t k = 0; k < bins; ++k) s.start[k + 1] = s.start[k] + static_cast<std::size_t>(p.count[k]);
    s.sorted.resize(hits.size());
    s.sorted_group.resize(grouped ? hits.size() : 0);
    s.next.assign(s.start.begin(), s.start.end() - 1);
    for (const Hit& h : hits) {
        const std::size_t at = s.next[static_cast<std::size_t>(h.bin)]++;
        s.sorted[at] = h.z;
        if (grouped) s.sorted_group[at] = h.group;
    }

    p.z.assign(bins, kNaN);
    p.spread.assign(bins, kNaN);
    const auto group_at = [&](std::size_t k) {
        return s.sorted_group.begin() + static_cast<std::ptrdiff_t>(s.start[k]);
    };
    for (std::size_t k = 0; k < bins; ++k) {
        if (p.count[k] == 0 || p.blocked[k]) continue;  // an obstacle's points are not road
        const auto first = s.sorted.begin() + static_cast<std::ptrdiff_t>(s.start[k]);
        const auto last = s.sorted.begin() + static_cast<std::ptrdiff_t>(s.start[k + 1]);
        if (p.count[k] > 1) {
            const double n = p.count[k];
            const double groups = grouped ? static_cast<double>(distinct_count(group_at(k), group_at(k + 1))) : n;
            p.spread[k] = noise_spread(sample_spread(first, last), s.variance_sum[k] / n, n / groups);
        } else if (s.variance_sum[k] > 0.0) {  // one point: the variance its sensor states, not a pool of others'
            p.spread[k] = std::sqrt(s.variance_sum[k]);
        }
        p.z[k] = median(first, last);
    }
    fill_gaps(p.z, cfg.ds_m, cfg.max_gap_m, &p.blocked);
}

// A profile's bins and statistics emptied, its buffers kept (a stopped vehicle's).
void clear_bins(Profile& p) {
    p.s0 = p.ds = 0.0;
    for (auto* v : {&p.s, &p.z, &p.spread}) v->clear();
    p.count.clear();
    p.blocked.clear();
}

std::int64_t band_of(double range, double band_m) { return static_cast<std::int64_t>(std::min(range / band_m, 1e6)); }

// The corridor points (the ground points within kLevelCorridorHalfWidthM of the vehicle's path, those the planes
// are fitted to) grouped by band k = ⌊r / band_m⌋, in input order: band k's are corridor[band_start[k] ..
// band_start[k + 1]), with the range they span.
void assign_bands(PointsView points, const std::vector<std::uint8_t>& mask, double band_m, const WheelPaths& paths,
                  ProfileScratch& s) {
    s.found.clear();
    std::int64_t bands = 0;
    for (Eigen::Index i = 0; i < points.rows(); ++i) {
        if (!mask[static_cast<std::size_t>(i)]) continue;
        const double x = points(i, 0), y = points(i, 1);
        if (distance_from_path(paths, x, y) > kLevelCorridorHalfWidthM) continue;
        const double range = std::sqrt(x * x + y * y);  // not std::hypot: metres, far from overflow, and hypot is slower
        s.found.push_back({i, band_of(range, band_m), range});
        bands = std::max(bands, s.found.back().band + 1);
    }
    constexpr double kInf = std::numeric_limits<double>::infinity();
    const auto n = static_cast<std::size_t>(bands);
    s.nearest.assign(n, kInf);
    s.farthest.assign(n, -kInf);
    s.band_start.assign(n + 1, 0);
    for (const auto& c : s.found) {
        const auto k = static_cast<std::size_t>(c.band);
        ++s.band_start[k + 1];
        s.nearest[k] = std::min(s.nearest[k], c.range);
        s.farthest[k] = std::max(s.farthest[k], c.range);
    }
    for (std::size_t k = 0; k < n; ++k) s.band_start[k + 1] += s.band_start[k];
    s.corridor.resize(s.band_start[n]);
    s.band_next.assign(s.band_start.begin(), s.band_start.end() - 1);
    for (const auto& c : s.found) s.corridor[s.band_next[static_cast<std::size_t>(c.band)]++] = c.index;
}

// The refits' window about band k's plane: the median residual m and the half-width w of the points within
// kLevelKeepM of the plane, w = max(kLevelKeepSigmas robust standard deviations (1.4826·MAD), kLevelKeepMinM).
std::pair<double, double> keep_window(PointsView points, std::size_t k, ProfileScratch& s) {
    s.offsets.clear();
    for (std::size_t j = s.band_start[k]; j < s.band_start[k + 1]; ++j) {
        const Eigen::Index i = s.corridor[j];
        const double h = height_above(s.ground.plane[k], points(i, 0), points(i, 1), points(i, 2));
        if (std::abs(h) <= kLevelKeepM) s.offsets.push_back(h);
    }
    if (s.offsets.empty()) return {0.0, kLevelKeepMinM};
    const double m = median(s.offsets.begin(), s.offsets.end());
    for (double& h : s.offsets) h = std::abs(h - m);
    const double mad = median(s.offsets.begin(), s.offsets.end());
    return {m, std::max(kLevelKeepSigmas * 1.4826 * mad, kLevelKeepMinM)};
}

// Band k's plane from its corridor points: their PCA plane, refitted to the points within kLevelKeepM of the last
// fit and within its keep_window until the points kept no longer change (at most kLevelRefits times: a bump's
// flanks leave one refit at a time). False (plane untouched) when the first fit is degenerate.
bool fit_band_plane(PointsView points, std::size_t k, ProfileScratch& s) {
    const std::size_t first = s.band_start[k], count = s.band_start[k + 1] - first;
    s.kept.assign(count, 1);
    for (int fit = 0; fit <= kLevelRefits; ++fit) {
        const auto [centre, half_width] = fit > 0 ? keep_window(points, k, s) : std::pair{0.0, 0.0};
        Moments m;
        bool changed = fit == 0;
        for (std::size_t j = 0; j < count; ++j) {
            const Eigen::Index i = s.corridor[first + j];
            if (fit > 0) {
                const double h = height_above(s.ground.plane[k], points(i, 0), points(i, 1), points(i, 2));
                const std::uint8_t keep = std::abs(h) <= kLevelKeepM && std::abs(h - centre) <= half_width;
                changed |= keep != s.kept[j];
                s.kept[j] = keep;
                if (!keep) continue;
            }
            m.add(points.row(i).cast<double>().transpose());
        }
        if (!changed) return true;  // the same points as the last fit: it stands
        const auto f = plane_fit(m);
        if (!f) return fit > 0;  // a failed refit keeps the last fit
        s.ground.plane[k] = f->plane;
    }
    return true;
}

// Each band's plane where its corridor points span enough range to tell a grade (fit_band_plane); `fitted` marks
// those bands, the others keep the frame plane for now.
void fit_band_planes(PointsView points, const Plane& frame, double band_m, ProfileScratch& s) {
    const std::size_t bands = s.nearest.size();
    s.ground.plane.assign(bands, frame);
    s.fitted.assign(bands, 0);
    for (std::size_t k = 0; k < bands; ++k)
        if (s.farthest[k] - s.nearest[k] >= kLevelMinSpan * band_m) s.fitted[k] = fit_band_plane(points, k, s);
}

// The fitted band nearest to band k (the nearer one on a tie); nullptr when no band is fitted.
const Plane* nearest_fitted(std::size_t k, const ProfileScratch& s) {
    const std::size_t bands = s.fitted.size();
    for (std::size_t d = 1; d < bands; ++d) {
        if (k >= d && s.fitted[k - d]) return &s.ground.plane[k - d];
        if (k + d < bands && s.fitted[k + d]) return &s.ground.plane[k + d];
    }
    return nullptr;
}

// A band with corridor points that could not be fitted (too short a span, or degenerate): the normal of the nearest
// fitted band (the frame plane's if none) through the median of its corridor points — the frame plane itself may
// lie decimetres off the road that far ahead.
void place_short_bands(PointsView points, const Plane& frame, ProfileScratch& s) {
    for (std::size_t k = 0; k < s.fitted.size(); ++k) {
        if (s.fitted[k] || s.band_start[k] == s.band_start[k + 1]) continue;  // fitted, or no corridor points
        const Plane* like = nearest_fitted(k, s);
        const Plane& n = like ? *like : frame;
        s.offsets.clear();
        for (std::size_t j = s.band_start[k]; j < s.band_start[k + 1]; ++j) {
            const Eigen::Index i = s.corridor[j];
            s.offsets.push_back(n[0] * points(i, 0) + n[1] * points(i, 1) + n[2] * points(i, 2));
        }
        s.ground.plane[k] = Plane{n[0], n[1], n[2], -median(s.offsets.begin(), s.offsets.end())};
    }
}

}  // namespace

void fit_local_ground(PointsView points, const std::vector<std::uint8_t>& mask, const Plane& frame, double band_m,
                      const WheelPaths& paths, ProfileScratch& s) {
    assign_bands(points, mask, band_m, paths, s);
    fit_band_planes(points, frame, band_m, s);
    place_short_bands(points, frame, s);
    LocalGround& g = s.ground;
    g.has_points.resize(g.plane.size());
    for (std::size_t k = 0; k < g.plane.size(); ++k) g.has_points[k] = s.band_start[k] != s.band_start[k + 1];
    g.frame = frame;
    g.band_m = band_m;
    g.direction = paths.direction < 0.0 ? -1.0 : 1.0;
}

// Blended between band centres: t bands from its own band's centre (|t| ≤ ½), a point takes |t| of its height above
// the neighbour band it lies towards when that band has corridor points (a plane of its own) — so the levelled
// heights are continuous where two bands meet. Bands beyond the last corridor point keep the frame plane.
double LocalGround::height(double x, double y, double z) const {
    if (x * direction < 0.0) return height_above(plane.empty() ? frame : plane.front(), x, y, z);
    const double range = std::sqrt(x * x + y * y);
    const auto k = static_cast<std::size_t>(band_of(range, band_m));
    const double own = height_above(k < plane.size() ? plane[k] : frame, x, y, z);
    const double t = range / band_m - static_cast<double>(k) - 0.5;
    const bool inward = t < 0.0;
    if (inward && k == 0) return own;
    const std::size_t j = inward ? k - 1 : k + 1;
    if (j >= plane.size() || !has_points[j]) return own;  // the frame plane stands in there
    const double w = std::abs(t);
    return (1.0 - w) * own + w * height_above(plane[j], x, y, z);
}

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
    const double dy = y - paths.icr_y;
    return std::abs(std::sqrt(x * x + dy * dy) - std::abs(paths.icr_y));  // sqrt: see the ranges above
}

std::vector<double> local_ground_heights(PointsView points, const std::vector<std::uint8_t>& mask, const Plane& frame,
                                         double band_m, const WheelPaths& paths) {
    ProfileScratch s;
    fit_local_ground(points, mask, frame, band_m, paths, s);
    std::vector<double> z(mask.size(), kNaN);
    for (Eigen::Index i = 0; i < points.rows(); ++i)
        if (mask[static_cast<std::size_t>(i)]) z[static_cast<std::size_t>(i)] = local_height(points, i, s);
    return z;
}

std::size_t bin_count(const ProfileConfig& cfg) {
    return static_cast<std::size_t>(std::ceil(cfg.preview_length_m / cfg.ds_m - 1e-9));
}

namespace {

// The hits of each wheel's corridor (s.hits) with each ground point's height from `height(i, z_levelled)`, asked only
// of the points in a corridor; none for a stopped vehicle.
template <class Height>
void collect_hits_with(PointsView points, const std::vector<std::uint8_t>& mask, const Levelling& L,
                       const WheelPaths& paths, double tire_width, const ProfileConfig& cfg,
                       const std::vector<float>* height_variances, const std::vector<std::int32_t>* error_groups,
                       Height&& height, ProfileScratch& s) {
    if (height_variances && height_variances->size() != mask.size())
        throw std::invalid_argument("height_variances and mask differ in length");
    if (error_groups && error_groups->size() != mask.size())
        throw std::invalid_argument("error_groups and mask differ in length");
    for (auto& h : s.hits) h.clear();
    s.grouped = error_groups != nullptr;
    s.stopped = paths.status == PathStatus::Stopped;
    if (s.stopped) return;
    const std::size_t bins = bin_count(cfg);
    for (Eigen::Index i = 0; i < points.rows(); ++i) {
        if (!mask[static_cast<std::size_t>(i)]) continue;
        const auto [xl, yl, z_levelled] = L.apply(points(i, 0), points(i, 1), points(i, 2));
        std::optional<double> zl;
        for (const Wheel w : {Wheel::Left, Wheel::Right}) {
            const auto arc = arc_length(paths, w, xl, yl, tire_width);
            if (!arc || *arc >= cfg.preview_length_m) continue;
            if (!zl) zl = height(i, z_levelled);
            // s < preview but s/ds can round up to `bins`: such a point belongs to the last bin.
            const auto bin = std::min(static_cast<std::size_t>(*arc / cfg.ds_m), bins - 1);
            const double variance = height_variances ? (*height_variances)[static_cast<std::size_t>(i)] : 0.0;
            const std::int32_t group = error_groups ? (*error_groups)[static_cast<std::size_t>(i)] : -1;
            s.hits[static_cast<int>(w)].push_back({static_cast<std::int32_t>(bin), group, *zl, variance});
        }
    }
}

}  // namespace

void collect_profile_hits(PointsView points, const std::vector<std::uint8_t>& mask, const Levelling& L,
                          const WheelPaths& paths, double tire_width, const ProfileConfig& cfg, bool level_local,
                          const std::vector<float>* height_variances, const std::vector<std::int32_t>* error_groups,
                          ProfileScratch& s) {
    if (level_local)
        collect_hits_with(points, mask, L, paths, tire_width, cfg, height_variances, error_groups,
                          [&](Eigen::Index i, double) { return local_height(points, i, s); }, s);
    else
        collect_hits_with(points, mask, L, paths, tire_width, cfg, height_variances, error_groups,
                          [](Eigen::Index, double z_levelled) { return z_levelled; }, s);
}

void bin_profile_hits(const ProfileConfig& cfg, const BlockedBins* blocked, ProfileScratch& s, Profile& left,
                      Profile& right) {
    if (s.stopped) {
        clear_bins(left);
        clear_bins(right);
        return;
    }
    const std::size_t bins = bin_count(cfg);
    const bool grouped = s.grouped;
    bin_profile(s.hits[static_cast<int>(Wheel::Left)], bins, cfg, blocked ? &blocked->left : nullptr, grouped, s, left);
    bin_profile(s.hits[static_cast<int>(Wheel::Right)], bins, cfg, blocked ? &blocked->right : nullptr, grouped, s,
                right);
}

void build_profiles(PointsView points, const std::vector<std::uint8_t>& mask, const Levelling& L,
                    const WheelPaths& paths, double tire_width, const ProfileConfig& cfg, const BlockedBins* blocked,
                    bool level_local, const std::vector<float>* height_variances,
                    const std::vector<std::int32_t>* error_groups, ProfileScratch& s, Profile& left, Profile& right) {
    collect_profile_hits(points, mask, L, paths, tire_width, cfg, level_local, height_variances, error_groups, s);
    bin_profile_hits(cfg, blocked, s, left, right);
}

WheelProfiles build_profiles(PointsView points, const std::vector<std::uint8_t>& mask, const Levelling& L,
                             const WheelPaths& paths, double tire_width, const ProfileConfig& cfg,
                             const BlockedBins* blocked, const std::vector<double>* local_z,
                             const std::vector<float>* height_variances,
                             const std::vector<std::int32_t>* error_groups) {
    if (local_z && local_z->size() != mask.size()) throw std::invalid_argument("local_z and mask differ in length");
    ProfileScratch s;
    WheelProfiles out;
    const auto height = [&](Eigen::Index i, double z_levelled) {
        return local_z ? (*local_z)[static_cast<std::size_t>(i)] : z_levelled;
    };
    collect_hits_with(points, mask, L, paths, tire_width, cfg, height_variances, error_groups, height, s);
    bin_profile_hits(cfg, blocked, s, out.left, out.right);
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
