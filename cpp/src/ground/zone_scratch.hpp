// SPDX-License-Identifier: BSD-3-Clause
// Internal: the zone model and the buffers of zone_ground, kept by the pipeline between frames so that a stream
// of frames allocates nothing once they have grown.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "roadpreview/ground/zones.hpp"

namespace roadpreview {

// A monotonic stand-in for the angle of (u, v) in [0, 2π): values in [0, 4), no trigonometry per point.
inline double pseudo_angle(double u, double v) {
    if (v >= 0.0) return u >= 0.0 ? v / (u + v) : 1.0 - u / (v - u);
    return u < 0.0 ? 2.0 - v / (-u - v) : 3.0 + u / (u - v);
}

// Sorted thresholds t and, for a value v, how many of them are ≤ v (std::upper_bound's answer) by a table: bucket b
// of [lo, lo + buckets/scale) holds how many thresholds lie in buckets before it and the first one in it; more in
// it are compared one by one. The patch of every ROI point asks this twice, and a binary search's branches are
// guesses.
class Thresholds {
public:
    Thresholds(std::vector<double> sorted, double lo, double hi, int buckets)
        : t_(std::move(sorted)), lo_(lo), scale_(buckets / (hi - lo)), last_(buckets - 1),
          bucket_(static_cast<std::size_t>(buckets)) {
        for (const double t : t_) ++bucket_[static_cast<std::size_t>(bucket(t))].within;
        int before = 0;
        for (Bucket& b : bucket_) {
            b.before = before;
            if (b.within > 0) b.first = t_[static_cast<std::size_t>(before)];
            before += b.within;
        }
    }

    // Exact whatever the spacing: bucket() never decreases as v grows, so a threshold in an earlier bucket is < v
    // and one in a later bucket > v.
    int count_at_most(double v) const {
        if (std::isnan(v)) return static_cast<int>(t_.size());  // as upper_bound: NaN < t is false for every t
        const Bucket& b = bucket_[static_cast<std::size_t>(bucket(v))];
        int n = b.before + (b.first <= v);  // no branch: most buckets hold no threshold or one
        if (b.within > 1)
            while (n < b.before + b.within && t_[static_cast<std::size_t>(n)] <= v) ++n;
        return n;
    }

private:
    struct Bucket {
        int before = 0, within = 0;  // thresholds in the buckets before it, and in it
        double first = std::numeric_limits<double>::quiet_NaN();  // its first threshold (NaN: none; v ≥ NaN is false)
    };

    int bucket(double v) const {
        const double at = (v - lo_) * scale_;
        return at >= 0.0 ? static_cast<int>(std::min(at, static_cast<double>(last_))) : 0;
    }

    std::vector<double> t_;
    double lo_, scale_;
    int last_;
    std::vector<Bucket> bucket_;
};

// The patch of a point: ring by horizontal distance, sector by azimuth φ = atan2(y, x) + π ∈ [0, 2π].
class ZoneModel {
public:
    explicit ZoneModel(const GroundConfig& cfg) : sectors_(cfg.zone_sectors), rings_(ring_table(cfg.zone_ring_edges_m)) {
        first_.push_back(0);
        for (const int s : sectors_) {
            groups_ = std::gcd(groups_, s);
            first_.push_back(first_.back() + s);
            std::vector<double> bounds;  // pseudo-angles of the sector boundaries 1 … s−1
            for (int k = 1; k < s; ++k) {
                const double phi = 2.0 * M_PI * k / s;
                bounds.push_back(pseudo_angle(std::cos(phi), std::sin(phi)));
            }
            bounds_.emplace_back(std::move(bounds), 0.0, 4.0, std::min(8 * s, kMaxSectorBuckets));  // a sector spans ≥ 2
        }
    }

    int rings() const { return static_cast<int>(sectors_.size()); }
    /// Groups of azimuth that every ring's sector boundaries cut alike (the greatest common divisor of the sector
    /// counts): a patch's inner reference lies in its own group, so the groups can be fitted independently.
    int azimuth_groups() const { return std::max(groups_, 1); }
    int sectors(int ring) const { return sectors_[static_cast<std::size_t>(ring)]; }
    /// The sector of ring − 1 (ring > 0) holding the central azimuth of `sector` in `ring`: its inner reference.
    int inner_sector(int ring, int sector) const {
        return static_cast<int>((2 * static_cast<std::int64_t>(sector) + 1) * sectors(ring - 1) / (2 * sectors(ring)));
    }
    std::int32_t first(int ring) const { return first_[static_cast<std::size_t>(ring)]; }
    std::int32_t patches() const { return first_.back(); }

    std::int32_t patch(double x, double y) const {
        const int ring = rings_.count_at_most(x * x + y * y) - 1;
        if (ring < 0 || ring >= rings()) return -1;
        // φ = angle of (−x, −y) measured from +x: atan2(y, x) + π.
        const int sector = bounds_[static_cast<std::size_t>(ring)].count_at_most(pseudo_angle(-x, -y));
        return first_[static_cast<std::size_t>(ring)] + sector;
    }

private:
    static constexpr int kRingBuckets = 1024, kMaxSectorBuckets = 4096;

    static Thresholds ring_table(const std::vector<double>& edges_m) {  // of squared horizontal distance
        std::vector<double> edges_sq;
        for (const double e : edges_m) edges_sq.push_back(e * e);
        const double last = edges_sq.back();
        return Thresholds(std::move(edges_sq), 0.0, last, kRingBuckets);
    }

    std::vector<int> sectors_;
    int groups_ = 0;
    Thresholds rings_;
    std::vector<std::int32_t> first_;
    std::vector<Thresholds> bounds_;
};

// The buffers of one patch's fit (one set per thread fitting patches).
struct PatchScratch {
    std::vector<Eigen::Vector3d> pts;  // the patch's points (the root's near points)
    std::vector<std::uint8_t> ground;  // of the patch's points
    std::vector<double> heights, low;  // above the reference
    std::vector<double> anchor;        // the heights a patch without a plane of its own hands on by

    // Room for a patch of n points.
    void reserve(std::size_t n) {
        pts.reserve(n);
        ground.reserve(n);
        heights.reserve(n);
        low.reserve(n);
        anchor.reserve(n);
    }
};

struct ZoneScratch {
    explicit ZoneScratch(const GroundConfig& cfg) : zones(cfg) {}

    ZoneModel zones;
    std::vector<std::int32_t> patch;         // of each point
    std::vector<std::int32_t> order, start;  // points by patch: patch k holds order[start[k] … start[k+1])
    std::vector<std::int32_t> next;
    std::vector<int> slab_counts, slab_bins; // the root's height histogram, and each root point's bin
    std::vector<Plane> handed;               // each patch's plane for the next ring
    std::vector<std::uint8_t> too_steep, accepted;  // of each patch: its fit was too steep / it holds a plane of its own
    std::vector<PatchScratch> fitting;       // one per thread (the first also fits the root)
};

/// zone_ground into `out`, reusing its mask and the scratch's buffers; the azimuth groups fitted by up to `threads`
/// threads (the same answer for any number).
void zone_ground(PointsView points, const GroundConfig& cfg, ZoneScratch& scratch, GroundFit& out, int threads = 1);

}  // namespace roadpreview
