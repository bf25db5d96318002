// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/ground/zones.hpp"

#include <algorithm>
#include <cmath>

#include "core/median.hpp"
#include "core/parallel.hpp"
#include "ground/plane_fit.hpp"
#include "ground/zone_scratch.hpp"

namespace roadpreview {
namespace {

constexpr Plane kLevel{0.0, 0.0, 1.0, 0.0};  // the ground level the extrinsics give: z = 0 in the base frame

Eigen::Vector3d row(PointsView pts, Eigen::Index i) { return pts.row(i).cast<double>().transpose(); }

// Point indices grouped by patch (counting sort): patch k holds order[start[k] … start[k+1]).
void group_by_patch(std::int32_t patches, ZoneScratch& z) {
    z.start.assign(static_cast<std::size_t>(patches) + 1, 0);
    for (const auto p : z.patch)
        if (p >= 0) ++z.start[static_cast<std::size_t>(p) + 1];
    for (std::size_t k = 0; k < static_cast<std::size_t>(patches); ++k) z.start[k + 1] += z.start[k];
    z.order.resize(static_cast<std::size_t>(z.start.back()));
    z.next.assign(z.start.begin(), z.start.end() - 1);
    for (std::size_t i = 0; i < z.patch.size(); ++i)
        if (z.patch[i] >= 0) z.order[static_cast<std::size_t>(z.next[static_cast<std::size_t>(z.patch[i])]++)] = static_cast<std::int32_t>(i);
}

// The paper's fit on a point set: fit, keep the points at most pca_threshold_m above (and max_depth_m below),
// pca_iterations times, of the points `eligible(i)` admits (a patch's: not under its reference's depth floor).
// `kept` enters as the set the first fit uses and leaves as the points the last fit keeps.
template <class Eligible>
std::optional<PlaneFit> iterate_fit(const std::vector<Eigen::Vector3d>& pts, std::vector<std::uint8_t>& kept,
                                    const GroundConfig& cfg, Eligible&& eligible) {
    Moments m;  // of the points kept so far
    for (std::size_t i = 0; i < pts.size(); ++i)
        if (kept[i]) m.add(pts[i]);
    std::optional<PlaneFit> fit;
    for (int k = 0; k < cfg.pca_iterations; ++k) {
        fit = plane_fit(m);
        if (!fit) return std::nullopt;
        // The selection, and the next fit's moments updated by the points it drops and takes back (after the
        // first fit few change): the last selection needs none.
        const bool last = k + 1 == cfg.pca_iterations;
        bool changed = false;
        for (std::size_t i = 0; i < pts.size(); ++i) {
            const double h = height_above(fit->plane, pts[i].x(), pts[i].y(), pts[i].z());
            const bool keep = h <= cfg.pca_threshold_m && h >= -cfg.max_depth_m && eligible(i);
            if (keep == static_cast<bool>(kept[i])) continue;
            changed = true;
            kept[i] = keep;
            if (last) continue;
            if (keep)
                m.add(pts[i]);
            else
                m.remove(pts[i]);
        }
        if (!changed) break;  // the same points again: every later fit would be this one
    }
    return fit;
}

// The points the root fit starts from: the horizontal slab `pca_threshold_m` thick that holds the most of them —
// the road, whose heights crowd together, where a car's or a wall's side spreads over metres of height. Started
// from every point, the first fit leaned 10° through a car beside a stereo camera and kept its side as ground.
// Heights are counted in bins a quarter of the slab thick within ±kSlabSearchM of the level (docs/method.md §1).
// `count` and `bin` are the histogram's and each point's bin's buffers; `in` receives the mask.
void densest_slab(const std::vector<Eigen::Vector3d>& pts, double thickness_m, std::vector<int>& count,
                  std::vector<int>& bin, std::vector<std::uint8_t>& in) {
    constexpr double kSlabSearchM = 20.0;  // a 10 m mounting plus the tilt limit over the root disc
    constexpr int kBinsPerSlab = 4;
    const double bin_m = thickness_m / kBinsPerSlab;
    const auto bins = static_cast<int>(std::ceil(2.0 * kSlabSearchM / bin_m));
    const auto bin_of = [&](double z) {
        const double at = std::floor((z + kSlabSearchM) / bin_m);
        return at >= 0.0 && at < bins ? static_cast<int>(at) : -1;
    };
    count.assign(static_cast<std::size_t>(bins) + kBinsPerSlab, 0);
    in.resize(pts.size());
    bin.resize(pts.size());
    for (std::size_t i = 0; i < pts.size(); ++i)
        if ((bin[i] = bin_of(pts[i].z())) >= 0) ++count[static_cast<std::size_t>(bin[i])];
    int best = 0, most = -1, window = 0;  // window = points in bins [b, b + kBinsPerSlab)
    for (int b = 0; b < kBinsPerSlab; ++b) window += count[static_cast<std::size_t>(b)];
    for (int b = 0; b < bins; ++b) {
        if (window > most) most = window, best = b;  // ties keep the lower slab
        window += count[static_cast<std::size_t>(b + kBinsPerSlab)] - count[static_cast<std::size_t>(b)];
    }
    std::transform(bin.begin(), bin.end(), in.begin(), [&](int b) { return b >= best && b < best + kBinsPerSlab; });
}

// The reference of the innermost ring: the paper's fit of the points within zone_root_m (the road the vehicle
// stands on) started from their densest slab; nullopt (the level the extrinsics give stands in) when that fails
// or is too steep.
std::optional<Plane> root_reference(PointsView points, const GroundConfig& cfg, ZoneScratch& z) {
    PatchScratch& near = z.fitting.front();
    near.pts.clear();
    const double r_sq = cfg.zone_root_m * cfg.zone_root_m;
    for (Eigen::Index i = 0; i < points.rows(); ++i) {
        const Eigen::Vector3d p = row(points, i);
        if (p.x() * p.x() + p.y() * p.y() < r_sq) near.pts.push_back(p);
    }
    densest_slab(near.pts, cfg.pca_threshold_m, z.slab_counts, z.slab_bins, near.ground);
    const auto fit = iterate_fit(near.pts, near.ground, cfg, [](std::size_t) { return true; });
    return fit && within_tilt(fit->plane, cfg.max_tilt_deg) ? std::optional<Plane>(fit->plane) : std::nullopt;
}

struct PatchResult {
    std::optional<Plane> plane;  // accepted patches only
    bool too_steep = false;      // its fit failed the uprightness test
};

// What a patch hands on to the next ring: its own plane; else, unless it failed the uprightness test (a wall, a
// car's side), the reference it was given moved to the median height of its ground points within
// pca_threshold_m of it (at least kMinAnchorPoints): the ground handed outward follows what each ring sees. One
// plane handed on unchanged across rings of one arc each (a sparse sensor's) drifts over a crest: on the bundled
// OS-1-32 capture a 1.6 % plane fitted 10 m ahead stood 26 cm above the road 20 m ahead, and the foot of an object
// there was ground (docs/method.md §1).
Plane handed_on(const Plane& reference, const PatchResult& result, const GroundConfig& cfg, PatchScratch& z) {
    constexpr std::size_t kMinAnchorPoints = 3;
    if (result.plane) return *result.plane;
    if (result.too_steep) return reference;
    z.anchor.clear();
    for (std::size_t i = 0; i < z.heights.size(); ++i)
        if (z.ground[i] && std::abs(z.heights[i]) <= cfg.pca_threshold_m) z.anchor.push_back(z.heights[i]);
    if (z.anchor.size() < kMinAnchorPoints) return reference;
    Plane moved = reference;
    moved[3] -= median(z.anchor.begin(), z.anchor.end());  // height_above(moved, p) = height_above(reference, p) − m
    return moved;
}

// One patch (its points z.pts; their ground flags left in z.ground): seeds = points at most `threshold` above
// the mean of the lowest seed points (heights above the reference, and never more than `threshold` above the
// reference), the paper's fit from them, then the breadth, uprightness, elevation and flatness tests. A patch with
// too few points or seeds for a fit, or whose fit fails a test, keeps the reference: its points at most
// `threshold` above it are ground. Points more than max_depth_m below the reference are neither.
PatchResult fit_patch(const Plane& reference, const GroundConfig& cfg, PatchScratch& z) {
    const auto& pts = z.pts;
    z.heights.resize(pts.size());
    for (std::size_t i = 0; i < pts.size(); ++i)
        z.heights[i] = height_above(reference, pts[i].x(), pts[i].y(), pts[i].z());
    const double floor_h = -cfg.max_depth_m;  // deeper: a return from under the road (a reflection, multipath)
    const auto inherit = [&](bool too_steep) {  // no plane of its own: the inner ground goes on
        z.ground.resize(pts.size());
        for (std::size_t i = 0; i < pts.size(); ++i)
            z.ground[i] = z.heights[i] <= cfg.pca_threshold_m && z.heights[i] >= floor_h;
        return PatchResult{std::nullopt, too_steep};
    };
    z.low.clear();
    for (const double h : z.heights)
        if (h >= floor_h) z.low.push_back(h);
    if (static_cast<int>(z.low.size()) < cfg.zone_min_points) return inherit(false);
    const auto lowest = std::min<std::size_t>(static_cast<std::size_t>(cfg.zone_seed_points), z.low.size());
    std::nth_element(z.low.begin(), z.low.begin() + static_cast<std::ptrdiff_t>(lowest - 1), z.low.end());
    double low_mean = 0.0;
    for (std::size_t i = 0; i < lowest; ++i) low_mean += z.low[i];
    low_mean = std::min(low_mean / static_cast<double>(lowest), 0.0);  // never seeds above the reference's band
    z.ground.resize(pts.size());
    for (std::size_t i = 0; i < pts.size(); ++i)
        z.ground[i] = z.heights[i] <= low_mean + cfg.pca_threshold_m && z.heights[i] >= floor_h;
    const auto fit = iterate_fit(pts, z.ground, cfg, [&](std::size_t i) { return z.heights[i] >= floor_h; });
    if (!fit) return inherit(false);
    const bool upright = within_tilt(fit->plane, cfg.max_tilt_deg);

    const double step = height_above(reference, fit->centre.x(), fit->centre.y(), fit->centre.z());
    const bool near_inner_ground = std::abs(step) <= cfg.zone_max_step_m;
    const bool flat = std::sqrt(fit->flatness_m2) <= cfg.zone_max_flatness_m;
    // One ring's arc across a patch is nearly a line: any plane through it fits, and its tilt across the line
    // is noise. Such a patch neither holds a plane of its own nor fails (a sparse sensor's every patch).
    if (std::sqrt(fit->breadth_m2) < cfg.zone_min_breadth_m) return inherit(false);
    if (upright && near_inner_ground && flat) return PatchResult{fit->plane, false};
    return inherit(!upright);  // the inner ground goes on: the foot of a wall or a car is no obstacle
}

// The patches of one azimuth group, ring by ring outward: each patch's reference is the plane handed on by the inner
// patch holding its central azimuth (the root's for the innermost ring), which lies in the same group. Writes the
// group's patches' planes and flags in `z` and their ground points in `mask`.
void fit_group(PointsView points, const GroundConfig& cfg, const Plane& root, int group, ZoneScratch& z,
               PatchScratch& scratch, std::vector<std::uint8_t>& mask) {
    const ZoneModel& zones = z.zones;
    const int groups = zones.azimuth_groups();
    for (int ring = 0; ring < zones.rings(); ++ring) {
        const int per_group = zones.sectors(ring) / groups;
        for (int sector = group * per_group; sector < (group + 1) * per_group; ++sector) {
            const std::int32_t patch = zones.first(ring) + sector;
            const Plane reference =
                ring > 0 ? z.handed[static_cast<std::size_t>(zones.first(ring - 1) + zones.inner_sector(ring, sector))]
                         : root;
            const auto from = z.start[static_cast<std::size_t>(patch)], to = z.start[static_cast<std::size_t>(patch) + 1];
            scratch.pts.clear();
            for (std::int32_t k = from; k < to; ++k) scratch.pts.push_back(row(points, z.order[static_cast<std::size_t>(k)]));
            const PatchResult result = fit_patch(reference, cfg, scratch);
            z.handed[static_cast<std::size_t>(patch)] = handed_on(reference, result, cfg, scratch);
            z.too_steep[static_cast<std::size_t>(patch)] = result.too_steep;
            z.accepted[static_cast<std::size_t>(patch)] = result.plane.has_value();
            for (std::size_t k = 0; k < scratch.ground.size(); ++k)
                if (scratch.ground[k]) mask[static_cast<std::size_t>(z.order[static_cast<std::size_t>(from) + k])] = 1;
        }
    }
}

void label_patches(PointsView points, const ZoneModel& zones, std::vector<std::int32_t>& patch) {
    patch.resize(static_cast<std::size_t>(points.rows()));
    for (Eigen::Index i = 0; i < points.rows(); ++i) patch[static_cast<std::size_t>(i)] = zones.patch(points(i, 0), points(i, 1));
}

}  // namespace

std::vector<std::int32_t> zone_patches(PointsView points, const GroundConfig& cfg) {
    std::vector<std::int32_t> patch;
    label_patches(points, ZoneModel(cfg), patch);
    return patch;
}

GroundFit zone_ground(PointsView points, const GroundConfig& cfg) {
    ZoneScratch scratch(cfg);
    GroundFit fit;
    zone_ground(points, cfg, scratch, fit);
    return fit;
}

void zone_ground(PointsView points, const GroundConfig& cfg, ZoneScratch& z, GroundFit& fit, int threads) {
    const ZoneModel& zones = z.zones;
    label_patches(points, zones, z.patch);
    group_by_patch(zones.patches(), z);
    fit.mask.assign(static_cast<std::size_t>(points.rows()), 0);
    fit.plane.reset();
    fit.count = 0;
    fit.status = GroundStatus::Found;

    z.fitting.resize(static_cast<std::size_t>(std::max(threads, 1)));
    std::size_t largest = 0;
    for (std::int32_t patch = 0; patch < zones.patches(); ++patch)
        largest = std::max(largest, static_cast<std::size_t>(z.start[static_cast<std::size_t>(patch) + 1] -
                                                             z.start[static_cast<std::size_t>(patch)]));
    const std::optional<Plane> fitted_root = root_reference(points, cfg, z);
    const Plane root = fitted_root.value_or(kLevel);
    z.handed.assign(static_cast<std::size_t>(zones.patches()), root);
    z.too_steep.assign(static_cast<std::size_t>(zones.patches()), 0);
    z.accepted.assign(static_cast<std::size_t>(zones.patches()), 0);
    // Whichever thread meets the largest patch has room for it, even one that took no group before: once the
    // largest patch has been seen, no allocation.
    for (PatchScratch& scratch : z.fitting) scratch.reserve(largest);
    parallel_for(zones.azimuth_groups(), threads, [&](int group, int thread) {
        fit_group(points, cfg, root, group, z, z.fitting[static_cast<std::size_t>(thread)], fit.mask);
    });
    // The frame's plane from every ground point, patch by patch: an order of the sums that no number of threads changes.
    Moments all;
    for (std::int32_t patch = 0; patch < zones.patches(); ++patch)
        for (auto k = z.start[static_cast<std::size_t>(patch)]; k < z.start[static_cast<std::size_t>(patch) + 1]; ++k) {
            const auto i = z.order[static_cast<std::size_t>(k)];
            if (fit.mask[static_cast<std::size_t>(i)]) all.add(row(points, i));
        }
    const auto any = [](const std::vector<std::uint8_t>& flags) {
        return std::any_of(flags.begin(), flags.end(), [](std::uint8_t f) { return f != 0; });
    };
    const bool any_too_steep = any(z.too_steep);
    const bool any_accepted = fitted_root.has_value() || any(z.accepted);  // a fitted root is ground of its own
    const auto frame_plane = any_accepted ? plane_fit(all) : std::nullopt;  // ground from the level alone is none
    if (frame_plane) {
        fit.plane = frame_plane->plane;
        fit.count = all.count;
    } else {
        std::fill(fit.mask.begin(), fit.mask.end(), 0);
        // Say why: only steep patches held a plane, or none did.
        fit.status = any_too_steep ? GroundStatus::TiltedGround : GroundStatus::NoGround;
    }
}

}  // namespace roadpreview
