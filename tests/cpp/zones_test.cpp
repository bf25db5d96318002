// SPDX-License-Identifier: BSD-3-Clause
// Zone ground and the tilt limit (docs/method.md §1): known-answer scenes.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include <roadpreview/ground/ground.hpp>
#include <roadpreview/ground/zones.hpp>

#include "scenes.hpp"

namespace rp = roadpreview;

namespace {

// Grid points of z = height(x, y) over x ∈ [1, 40), |y| ≤ 9 m, 0.25 m apart; then `extra` (not ground).
struct Scene {
    scenes::Cloud points;
    std::size_t road = 0;  // the first `road` rows are ground
};

Scene surface(const std::function<double(double, double)>& height, const scenes::Cloud& extra = scenes::Cloud(0, 3)) {
    std::vector<Eigen::Vector3f> rows;
    for (double x = 1.0; x < 40.0; x += 0.25)
        for (double y = -9.0; y <= 9.0; y += 0.25) rows.emplace_back(float(x), float(y), float(height(x, y)));
    Scene s;
    s.road = rows.size();
    s.points.resize(static_cast<Eigen::Index>(rows.size()) + extra.rows(), 3);
    for (std::size_t i = 0; i < rows.size(); ++i) s.points.row(static_cast<Eigen::Index>(i)) = rows[i].transpose();
    s.points.bottomRows(extra.rows()) = extra;
    return s;
}

rp::GroundFit zones(const scenes::Cloud& pts, double max_tilt_deg = 15.0) {
    rp::GroundConfig cfg;
    cfg.method = rp::GroundMethod::Zones;
    cfg.max_tilt_deg = max_tilt_deg;
    return rp::fit_ground(rp::points_view(pts.data(), pts.rows(), 3), cfg);
}

void expect_ground_is_the_road(const Scene& s) {
    const rp::GroundFit fit = zones(s.points);
    ASSERT_TRUE(fit.plane);
    std::size_t wrong = 0;
    for (std::size_t i = 0; i < fit.mask.size(); ++i) wrong += fit.mask[i] != (i < s.road ? 1 : 0);
    EXPECT_EQ(wrong, 0u);
}

}  // namespace

TEST(Zones, FollowAGradeOneThePlaneCannot) {
    expect_ground_is_the_road(surface([](double x, double) { return 0.03 * std::max(x - 15.0, 0.0); }));
}

TEST(Zones, FollowACrest) {
    expect_ground_is_the_road(surface([](double x, double) { return 0.05 * std::min(x, 40.0 - x); }));
}

TEST(Zones, TakeThePavementBeyondAKerb) {
    expect_ground_is_the_road(surface([](double, double y) { return std::abs(y) < 4.0 ? 0.0 : 0.15; }));
}

TEST(Zones, FollowABankedRoad) {
    expect_ground_is_the_road(surface([](double, double y) { return 0.06 * y; }));
}

TEST(Zones, LeaveAnOverheadCanopy) {
    scenes::Cloud roof = scenes::plane(0.0, 0.0, 6.7, 3000, 10.0, 20.0, 5.0);
    expect_ground_is_the_road(surface([](double, double) { return 0.0; }, roof));
}

TEST(Zones, LeaveAWallBesideTheRoad) {
    scenes::Cloud wall(39 * 10 * 27, 3);
    Eigen::Index n = 0;
    for (int i = 0; i < 390; ++i)
        for (int k = 0; k < 27; ++k) wall.row(n++) << 1.0f + 0.1f * float(i), 9.5f, 0.3f + 0.1f * float(k);
    expect_ground_is_the_road(surface([](double, double) { return 0.0; }, wall));
}

// A reflection or multipath return metres under the road (KITTI frames hold a few 9–10 m down, an OS-0-128
// capture one 9 m down in a wheel's path): the method paper keeps every point below its plane, but no wheel rolls
// on these.
TEST(Zones, LeaveReturnsFromUnderTheRoad) {
    scenes::Cloud under(4, 3);
    under << 11.0f, -0.8f, -9.2f, 11.1f, -0.8f, -9.0f, 25.0f, 3.0f, -2.5f, 6.0f, 1.0f, -6.7f;
    expect_ground_is_the_road(surface([](double x, double) { return 0.03 * std::max(x - 15.0, 0.0); }, under));
}

TEST(Ground, PcaLeavesReturnsFromUnderTheRoad) {
    scenes::Cloud under(2, 3);
    under << 11.0f, -0.8f, -9.2f, 20.0f, 2.0f, -3.0f;
    const Scene s = surface([](double, double) { return 0.0; }, under);
    rp::GroundConfig cfg;
    cfg.method = rp::GroundMethod::Pca;
    const rp::GroundFit fit = rp::fit_ground(rp::points_view(s.points.data(), s.points.rows(), 3), cfg);
    ASSERT_TRUE(fit.plane);
    for (std::size_t i = 0; i < fit.mask.size(); ++i) ASSERT_EQ(fit.mask[i], i < s.road ? 1 : 0) << i;
    EXPECT_EQ(fit.count, static_cast<std::int64_t>(s.road));
}

TEST(Zones, PatchesAreRingsBySectors) {
    rp::GroundConfig cfg;
    cfg.zone_ring_edges_m = {1.0, 5.0, 10.0};
    cfg.zone_sectors = {4, 8};
    scenes::Cloud pts(5, 3);
    // ahead (φ = π: sector 2 of 4), left (φ = 3π/2: sector 3), right (φ = π/2: sector 1), ring 1, outside
    pts << 3, 0, 0, -0.1f, 3, 0, 0.1f, -3, 0, 7, 0.5f, 0, 20, 0, 0;
    const auto patch = rp::zone_patches(rp::points_view(pts.data(), pts.rows(), 3), cfg);
    EXPECT_EQ(patch, (std::vector<std::int32_t>{2, 3, 1, 4 + 4, -1}));
}

TEST(TiltLimit, ASlopeSteeperThanTheLimitIsNotGround) {
    const Scene slope = surface([](double, double y) { return std::tan(20.0 * M_PI / 180.0) * y; });
    for (const auto method : {rp::GroundMethod::Zones, rp::GroundMethod::Pca, rp::GroundMethod::Ransac}) {
        rp::GroundConfig cfg;
        cfg.method = method;
        const auto view = rp::points_view(slope.points.data(), slope.points.rows(), 3);
        const rp::GroundFit steep = rp::fit_ground(view, cfg);
        EXPECT_FALSE(steep.plane) << rp::to_string(method);
        EXPECT_EQ(steep.status, rp::GroundStatus::TiltedGround) << rp::to_string(method);
        EXPECT_STREQ(rp::to_string(steep.status), rp::kTiltedGround);
        cfg.max_tilt_deg = 25.0;
        const rp::GroundFit allowed = rp::fit_ground(view, cfg);
        ASSERT_TRUE(allowed.plane) << rp::to_string(method);
        EXPECT_NEAR(std::acos((*allowed.plane)[2]) * 180.0 / M_PI, 20.0, 0.1);
    }
}
