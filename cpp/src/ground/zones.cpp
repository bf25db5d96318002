// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/ground/zones.hpp"

#include <algorithm>
#include <cmath>

#include "ground/plane_fit.hpp"

namespace roadpreview {
namespace {

constexpr Plane kLevel{0.0, 0.0, 1.0, 0.0};  // the ground level the extrinsics give: z = 0 in the base frame

// A monotonic stand-in for the angle of (u, v) in [0, 2π): values in [0, 4), no trigonometry per point.
double pseudo_angle(double u, double v) {
    if (v >= 0.0) return u >= 0.0 ? v / (u + v) : 1.0 - u / (v - u);
    return u < 0.0 ? 2.0 - v / (-u - v) : 3.0 + u / (u - v);
}

// The patch of a point: ring by horizontal distance, sector by azimuth φ = atan2(y, x) + π ∈ [0, 2π].
class ZoneModel {
public:
    explicit ZoneModel(const GroundConfig& cfg) : sectors_(cfg.zone_sectors) {
        for (const double e : cfg.zone_ring_edges_m) edges_sq_.push_back(e * e);
        first_.push_back(0);
        for (const int s : sectors_) {
            first_.push_back(first_.back() + s);
            std::vector<double> bounds;  // pseudo-angles of the sector boundaries 1 … s−1
            for (int k = 1; k < s; ++k) {
                const double phi = 2.0 * M_PI * k / s;
                bounds.push_back(pseudo_angle(std::cos(phi), std::sin(phi)));
            }
            bounds_.push_back(std::move(bounds));
        }
    }

    int rings() const { return static_cast<int>(sectors_.size()); }
    int sectors(int ring) const { return sectors_[static_cast<std::size_t>(ring)]; }
    std::int32_t first(int ring) const { return first_[static_cast<std::size_t>(ring)]; }
    std::int32_t patches() const { return first_.back(); }

    std::int32_t patch(double x, double y) const {
        const double r_sq = x * x + y * y;
        const auto ring = std::upper_bound(edges_sq_.begin(), edges_sq_.end(), r_sq) - edges_sq_.begin() - 1;
        if (ring < 0 || ring >= rings()) return -1;
        const auto& bounds = bounds_[static_cast<std::size_t>(ring)];
        // φ = angle of (−x, −y) measured from +x: atan2(y, x) + π.
        const auto sector = std::upper_bound(bounds.begin(), bounds.end(), pseudo_angle(-x, -y)) - bounds.begin();
        return first_[static_cast<std::size_t>(ring)] + static_cast<std::int32_t>(sector);
    }

private:
    std::vector<int> sectors_;
    std::vector<double> edges_sq_;
    std::vector<std::int32_t> first_;
    std::vector<std::vector<double>> bounds_;
};

Eigen::Vector3d row(PointsView pts, Eigen::Index i) { return pts.row(i).cast<double>().transpose(); }

// Point indices grouped by patch (counting sort): patch k holds order[start[k] … start[k+1]).
struct PatchLists {
    std::vector<std::int32_t> order;
    std::vector<std::int32_t> start;
};

PatchLists group_by_patch(const std::vector<std::int32_t>& patch, std::int32_t patches) {
    PatchLists lists;
    lists.start.assign(static_cast<std::size_t>(patches) + 1, 0);
    for (const auto p : patch)
        if (p >= 0) ++lists.start[static_cast<std::size_t>(p) + 1];
    for (std::size_t k = 0; k < static_cast<std::size_t>(patches); ++k) lists.start[k + 1] += lists.start[k];
    lists.order.resize(static_cast<std::size_t>(lists.start.back()));
    std::vector<std::int32_t> next(lists.start.begin(), lists.start.end() - 1);
    for (std::size_t i = 0; i < patch.size(); ++i)
        if (patch[i] >= 0) lists.order[static_cast<std::size_t>(next[static_cast<std::size_t>(patch[i])]++)] = static_cast<std::int32_t>(i);
    return lists;
}

// The paper's fit on a point set: fit, keep the points at most pca_threshold_m above, pca_iterations times.
// `kept` enters as the set the first fit uses and leaves as the points the last fit keeps.
std::optional<PlaneFit> iterate_fit(const std::vector<Eigen::Vector3d>& pts, std::vector<std::uint8_t>& kept,
                                    const GroundConfig& cfg) {
    std::optional<PlaneFit> fit;
    Moments m;  // of the points kept so far, accumulated while they are selected
    for (std::size_t i = 0; i < pts.size(); ++i)
        if (kept[i]) m.add(pts[i]);
    for (int k = 0; k < cfg.pca_iterations; ++k) {
        fit = plane_fit(m);
        if (!fit) return std::nullopt;
        m = Moments{};
        for (std::size_t i = 0; i < pts.size(); ++i) {
            kept[i] = height_above(fit->plane, pts[i].x(), pts[i].y(), pts[i].z()) <= cfg.pca_threshold_m;
            if (kept[i]) m.add(pts[i]);
        }
    }
    return fit;
}

// The points the root fit starts from: the horizontal slab `pca_threshold_m` thick that holds the most of them —
// the road, whose heights crowd together, where a car's or a wall's side spreads over metres of height. Started
// from every point, the first fit leaned 10° through a car beside a stereo camera and kept its side as ground.
// Heights are counted in bins a quarter of the slab thick within ±kSlabSearchM of the level (docs/method.md §1).
std::vector<std::uint8_t> densest_slab(const std::vector<Eigen::Vector3d>& pts, double thickness_m) {
    constexpr double kSlabSearchM = 20.0;  // a 10 m mounting plus the tilt limit over the root disc
    constexpr int kBinsPerSlab = 4;
    const double bin_m = thickness_m / kBinsPerSlab;
    const auto bins = static_cast<int>(std::ceil(2.0 * kSlabSearchM / bin_m));
    const auto bin_of = [&](double z) {
        const double at = std::floor((z + kSlabSearchM) / bin_m);
        return at >= 0.0 && at < bins ? static_cast<int>(at) : -1;
    };
    std::vector<int> count(static_cast<std::size_t>(bins) + kBinsPerSlab, 0);
    for (const auto& p : pts)
        if (const int b = bin_of(p.z()); b >= 0) ++count[static_cast<std::size_t>(b)];
    int best = 0, most = -1, window = 0;  // window = points in bins [b, b + kBinsPerSlab)
    for (int b = 0; b < kBinsPerSlab; ++b) window += count[static_cast<std::size_t>(b)];
    for (int b = 0; b < bins; ++b) {
        if (window > most) most = window, best = b;  // ties keep the lower slab
        window += count[static_cast<std::size_t>(b + kBinsPerSlab)] - count[static_cast<std::size_t>(b)];
    }
    std::vector<std::uint8_t> in(pts.size());
    std::transform(pts.begin(), pts.end(), in.begin(), [&](const Eigen::Vector3d& p) {
        const int b = bin_of(p.z());
        return b >= best && b < best + kBinsPerSlab;
    });
    return in;
}

// The reference of the innermost ring: the paper's fit of the points within zone_root_m (the road the vehicle
// stands on) started from their densest slab, or the level the extrinsics give when that fails or is too steep.
Plane root_reference(PointsView points, const GroundConfig& cfg) {
    std::vector<Eigen::Vector3d> near;
    near.reserve(static_cast<std::size_t>(points.rows()));
    const double r_sq = cfg.zone_root_m * cfg.zone_root_m;
    for (Eigen::Index i = 0; i < points.rows(); ++i) {
        const Eigen::Vector3d p = row(points, i);
        if (p.x() * p.x() + p.y() * p.y() < r_sq) near.push_back(p);
    }
    std::vector<std::uint8_t> kept = densest_slab(near, cfg.pca_threshold_m);
    const auto fit = iterate_fit(near, kept, cfg);
    return fit && within_tilt(fit->plane, cfg.max_tilt_deg) ? fit->plane : kLevel;
}

struct PatchResult {
    std::optional<Plane> plane;  // accepted patches only
    std::vector<std::uint8_t> ground;  // empty: none
    bool too_steep = false;      // its fit failed the uprightness test
};

// One patch: seeds = points at most `threshold` above the mean of the lowest seed points (heights above the
// reference, and never more than `threshold` above the reference), the paper's fit from them, then the
// uprightness, elevation and flatness tests. A patch with too few points or seeds for a fit, or whose fit fails
// a test, keeps the reference: its points at most `threshold` above it are ground.
PatchResult fit_patch(const std::vector<Eigen::Vector3d>& pts, const Plane& reference, const GroundConfig& cfg,
                      std::vector<double>& scratch) {
    PatchResult out;
    scratch.resize(pts.size());
    for (std::size_t i = 0; i < pts.size(); ++i) scratch[i] = height_above(reference, pts[i].x(), pts[i].y(), pts[i].z());
    const auto inherit = [&] {  // too few points or seeds for a plane of its own: the inner ground goes on
        PatchResult in;
        in.ground.resize(pts.size());
        for (std::size_t i = 0; i < pts.size(); ++i) in.ground[i] = scratch[i] <= cfg.pca_threshold_m;
        return in;
    };
    if (static_cast<int>(pts.size()) < cfg.zone_min_points) return inherit();
    const auto lowest = std::min<std::size_t>(static_cast<std::size_t>(cfg.zone_seed_points), pts.size());
    std::vector<double> low(scratch);
    std::nth_element(low.begin(), low.begin() + static_cast<std::ptrdiff_t>(lowest - 1), low.end());
    double low_mean = 0.0;
    for (std::size_t i = 0; i < lowest; ++i) low_mean += low[i];
    low_mean = std::min(low_mean / static_cast<double>(lowest), 0.0);  // never seeds above the reference's band
    out.ground.resize(pts.size());
    for (std::size_t i = 0; i < pts.size(); ++i) out.ground[i] = scratch[i] <= low_mean + cfg.pca_threshold_m;
    const auto fit = iterate_fit(pts, out.ground, cfg);
    if (!fit) return inherit();
    const bool upright = within_tilt(fit->plane, cfg.max_tilt_deg);

    const double step = height_above(reference, fit->centre.x(), fit->centre.y(), fit->centre.z());
    const bool near_inner_ground = std::abs(step) <= cfg.zone_max_step_m;
    const bool flat = std::sqrt(fit->flatness_m2) <= cfg.zone_max_flatness_m;
    if (upright && near_inner_ground && flat) {
        out.plane = fit->plane;
        return out;
    }
    PatchResult rejected = inherit();  // the inner ground goes on: the foot of a wall or a car is no obstacle
    rejected.too_steep = !upright;
    return rejected;
}

}  // namespace

std::vector<std::int32_t> zone_patches(PointsView points, const GroundConfig& cfg) {
    const ZoneModel zones(cfg);
    std::vector<std::int32_t> patch(static_cast<std::size_t>(points.rows()));
    for (Eigen::Index i = 0; i < points.rows(); ++i) patch[static_cast<std::size_t>(i)] = zones.patch(points(i, 0), points(i, 1));
    return patch;
}

GroundFit zone_ground(PointsView points, const GroundConfig& cfg) {
    const ZoneModel zones(cfg);
    const PatchLists lists = group_by_patch(zone_patches(points, cfg), zones.patches());
    GroundFit fit;
    fit.mask.assign(static_cast<std::size_t>(points.rows()), 0);

    const auto gather = [&](std::int32_t from, std::int32_t to, std::vector<Eigen::Vector3d>& out) {
        out.clear();
        out.reserve(static_cast<std::size_t>(to - from));
        for (std::int32_t k = from; k < to; ++k) out.push_back(row(points, lists.order[static_cast<std::size_t>(k)]));
    };
    std::vector<Eigen::Vector3d> pts;
    const Plane root = root_reference(points, cfg);

    // Each patch hands on to the next ring its own plane when accepted, else the reference it was given.
    std::vector<Plane> handed(static_cast<std::size_t>(zones.patches()), root);
    std::vector<double> scratch;
    Moments all;
    bool any_too_steep = false, any_accepted = false;
    for (int ring = 0; ring < zones.rings(); ++ring) {
        for (int sector = 0; sector < zones.sectors(ring); ++sector) {
            const std::int32_t patch = zones.first(ring) + sector;
            Plane reference = root;
            if (ring > 0) {  // the inner patch holding this patch's central azimuth
                const auto inner = (2 * static_cast<std::int64_t>(sector) + 1) * zones.sectors(ring - 1) / (2 * zones.sectors(ring));
                reference = handed[static_cast<std::size_t>(zones.first(ring - 1) + inner)];
            }
            const auto from = lists.start[static_cast<std::size_t>(patch)], to = lists.start[static_cast<std::size_t>(patch) + 1];
            gather(from, to, pts);
            const PatchResult result = fit_patch(pts, reference, cfg, scratch);
            handed[static_cast<std::size_t>(patch)] = result.plane ? *result.plane : reference;
            any_too_steep = any_too_steep || result.too_steep;
            any_accepted = any_accepted || result.plane.has_value();
            for (std::size_t k = 0; k < result.ground.size(); ++k) {
                if (!result.ground[k]) continue;
                const auto i = static_cast<std::size_t>(lists.order[static_cast<std::size_t>(from) + k]);
                fit.mask[i] = 1;
                all.add(pts[k]);
            }
        }
    }
    const auto frame_plane = any_accepted ? plane_fit(all) : std::nullopt;  // inherited ground needs a real patch
    if (frame_plane) {
        fit.plane = frame_plane->plane;
        fit.count = all.count;
    } else {
        std::fill(fit.mask.begin(), fit.mask.end(), 0);
        if (any_too_steep) fit.reason = kTiltedGround;  // say why: only steep patches held a plane
    }
    return fit;
}

}  // namespace roadpreview
