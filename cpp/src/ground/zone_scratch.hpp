// SPDX-License-Identifier: BSD-3-Clause
// Internal: the zone model and the buffers of zone_ground, kept by the pipeline between frames so that a stream
// of frames allocates nothing once they have grown.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "roadpreview/ground/zones.hpp"

namespace roadpreview {

// A monotonic stand-in for the angle of (u, v) in [0, 2π): values in [0, 4), no trigonometry per point.
inline double pseudo_angle(double u, double v) {
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

struct ZoneScratch {
    explicit ZoneScratch(const GroundConfig& cfg) : zones(cfg) {}

    ZoneModel zones;
    std::vector<std::int32_t> patch;         // of each point
    std::vector<std::int32_t> order, start;  // points by patch: patch k holds order[start[k] … start[k+1])
    std::vector<std::int32_t> next;
    std::vector<Eigen::Vector3d> pts;        // the patch's points (the root's near points)
    std::vector<std::uint8_t> ground;        // of the patch's points
    std::vector<double> heights, low;        // above the reference
    std::vector<int> slab_counts;            // the root's height histogram
    std::vector<Plane> handed;               // each patch's plane for the next ring
};

/// zone_ground into `out`, reusing its mask and the scratch's buffers.
void zone_ground(PointsView points, const GroundConfig& cfg, ZoneScratch& scratch, GroundFit& out);

}  // namespace roadpreview
