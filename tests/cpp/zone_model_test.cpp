// SPDX-License-Identifier: BSD-3-Clause
// The zone model's patch lookup (internal: cpp/src/ground/zone_scratch.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <vector>

#include <roadpreview/ground/zones.hpp>
#include <roadpreview/io/readers.hpp>

#include "ground/zone_scratch.hpp"
#include "scenes.hpp"

namespace rp = roadpreview;

// The zone model's table lookups give the binary searches' answer: ring = (edges² ≤ r²) − 1, sector = (bounds ≤ the
// pseudo-angle), also where a table bucket holds several edges (edges 1 mm apart), for points on the edges and for the
// default model.
TEST(ZoneModel, PatchLookupAgreesWithABinarySearch) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> coordinate(-45.0, 45.0);
    for (const auto& edges : {rp::GroundConfig{}.zone_ring_edges_m, std::vector<double>{0.0, 0.001, 0.002, 5.0, 5.001, 42.0}}) {
        rp::GroundConfig cfg;
        cfg.zone_ring_edges_m = edges;
        cfg.zone_sectors.assign(edges.size() - 1, 0);
        for (std::size_t k = 0; k < cfg.zone_sectors.size(); ++k) cfg.zone_sectors[k] = k % 2 ? 160 : 3;
        std::vector<double> edges_sq;
        for (const double e : edges) edges_sq.push_back(e * e);
        scenes::Cloud pts(20000, 3);
        for (Eigen::Index i = 0; i < pts.rows(); ++i) {
            const bool on_edge = i < 100;
            pts.row(i) << float(on_edge ? edges[static_cast<std::size_t>(i) % edges.size()] : coordinate(rng)),
                float(on_edge ? 0.0 : coordinate(rng)), 0.0f;
        }
        const auto patch = rp::zone_patches(rp::points_view(pts.data(), pts.rows(), 3), cfg);
        for (Eigen::Index i = 0; i < pts.rows(); ++i) {
            const double x = pts(i, 0), y = pts(i, 1);
            const auto ring = std::upper_bound(edges_sq.begin(), edges_sq.end(), x * x + y * y) - edges_sq.begin() - 1;
            std::int32_t expected = -1;
            if (ring >= 0 && ring + 1 < static_cast<std::ptrdiff_t>(edges.size())) {
                const int sectors = cfg.zone_sectors[static_cast<std::size_t>(ring)];
                std::vector<double> bounds;
                for (int k = 1; k < sectors; ++k)
                    bounds.push_back(rp::pseudo_angle(std::cos(2.0 * M_PI * k / sectors), std::sin(2.0 * M_PI * k / sectors)));
                const auto sector = std::upper_bound(bounds.begin(), bounds.end(), rp::pseudo_angle(-x, -y)) - bounds.begin();
                expected = std::accumulate(cfg.zone_sectors.begin(), cfg.zone_sectors.begin() + ring, 0) +
                           static_cast<std::int32_t>(sector);
            }
            ASSERT_EQ(patch[static_cast<std::size_t>(i)], expected) << "point " << i << " at " << x << ", " << y;
        }
    }
}

// The azimuth groups that can be fitted apart: every ring's sector boundaries fall on the groups' boundaries, and a
// patch's inner reference (the inner patch holding its central azimuth) lies in its own group.
TEST(ZoneModel, AzimuthGroupsHoldEachPatchsInnerReference) {
    const auto groups_of = [](std::vector<int> sectors) {
        rp::GroundConfig cfg;
        cfg.zone_ring_edges_m.resize(sectors.size() + 1);
        std::iota(cfg.zone_ring_edges_m.begin(), cfg.zone_ring_edges_m.end(), 1.0);
        cfg.zone_sectors = std::move(sectors);
        return rp::ZoneModel(cfg);
    };
    EXPECT_EQ(rp::ZoneModel(rp::GroundConfig{}).azimuth_groups(), 8);  // 16, 24, …, 160 sectors
    EXPECT_EQ(groups_of({3, 160}).azimuth_groups(), 1);
    EXPECT_EQ(groups_of({12, 18, 30}).azimuth_groups(), 6);
    const rp::ZoneModel zones(rp::GroundConfig{});
    const int groups = zones.azimuth_groups();
    for (int ring = 1; ring < zones.rings(); ++ring)
        for (int sector = 0; sector < zones.sectors(ring); ++sector) {
            const int inner = zones.inner_sector(ring, sector);
            // the inner sector's span holds this sector's central azimuth, and lies in the same group
            EXPECT_LE(inner * zones.sectors(ring) * 2, (2 * sector + 1) * zones.sectors(ring - 1));
            EXPECT_GT((inner + 1) * zones.sectors(ring) * 2, (2 * sector + 1) * zones.sectors(ring - 1));
            EXPECT_EQ(sector / (zones.sectors(ring) / groups), inner / (zones.sectors(ring - 1) / groups))
                << "ring " << ring << ", sector " << sector;
        }
}

// More threads than the machine has cores (the pipeline asks for at most as many): the groups still go to distinct
// per-thread buffers, and the mask and plane are those of one thread.
TEST(ZoneModel, GroundOnFourThreadsIsThatOfOne) {
    const rp::Frame frame = rp::read_frame(std::string(ROADPREVIEW_TEST_DATA) + "/semantickitti/000000.bin");
    scenes::Cloud pts = frame.points.leftCols(3);
    pts.col(2).array() += 1.73f;  // the base frame: the ground at z = 0
    const rp::PointsView view = rp::points_view(pts.data(), pts.rows(), 3);
    const rp::GroundConfig cfg;
    rp::ZoneScratch one_scratch(cfg), four_scratch(cfg);
    rp::GroundFit one, four;
    for (int repeat = 0; repeat < 3; ++repeat) {
        rp::zone_ground(view, cfg, one_scratch, one, 1);
        rp::zone_ground(view, cfg, four_scratch, four, 4);
        ASSERT_TRUE(one.plane && four.plane);
        EXPECT_EQ(*one.plane, *four.plane);
        EXPECT_EQ(one.mask, four.mask);
        EXPECT_EQ(one.count, four.count);
        EXPECT_GT(one.count, 10000);
    }
}
