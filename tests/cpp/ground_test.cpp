#include <gtest/gtest.h>

#include <cmath>

#include <roadpreview/ground/ground.hpp>

#include "scenes.hpp"

namespace rp = roadpreview;

namespace {

rp::PointsView view(const scenes::Cloud& c) { return rp::points_view(c.data(), c.rows(), 3); }

// Unit normal of z = a·x + b·y + c, pointing up.
Eigen::Vector3d up_normal(double a, double b) { return Eigen::Vector3d(-a, -b, 1.0).normalized(); }

}  // namespace

TEST(Ground, PcaPlaneOfExactPlanePointsIsExact) {
    const double a = std::tan(3.0 * M_PI / 180), b = -std::tan(2.0 * M_PI / 180), c = -1.7;
    const scenes::Cloud pts = scenes::plane(a, b, c, 5000);
    const auto pl = rp::fit_plane(view(pts));
    ASSERT_TRUE(pl);
    const Eigen::Vector3d n = up_normal(a, b);
    EXPECT_NEAR((*pl)[0], n.x(), 1e-6);
    EXPECT_NEAR((*pl)[1], n.y(), 1e-6);
    EXPECT_NEAR((*pl)[2], n.z(), 1e-6);
    EXPECT_NEAR((*pl)[3], -c * n.z(), 1e-5);
}

TEST(Ground, PcaIterationsDropWhatStandsAboveTheGround) {
    const double a = 0.03, b = -0.01, c = -1.8;
    scenes::Cloud ground = scenes::plane(a, b, c, 20000);
    scenes::Cloud boxes = scenes::plane(a, b, c + 1.0, 4000, 10.0, 14.0, 2.0, 7);  // a 1 m high slab
    const scenes::Cloud pts = scenes::concat(ground, boxes);
    rp::GroundConfig cfg;
    cfg.method = rp::GroundMethod::Pca;
    const rp::GroundFit fit = rp::fit_ground(view(pts), cfg);
    ASSERT_TRUE(fit.plane);
    const Eigen::Vector3d n = up_normal(a, b);
    EXPECT_NEAR((*fit.plane)[0], n.x(), 1e-5);
    EXPECT_NEAR((*fit.plane)[2], n.z(), 1e-6);
    EXPECT_EQ(fit.count, 20000);
    for (Eigen::Index i = 0; i < pts.rows(); ++i) EXPECT_EQ(fit.mask[i], i < 20000 ? 1 : 0) << i;
}

TEST(Ground, NormalPointsUpWhateverTheSolverReturns) {
    const scenes::Cloud pts = scenes::plane(-0.2, 0.1, 3.0, 1000);
    const auto pl = rp::fit_plane(view(pts));
    ASSERT_TRUE(pl);
    EXPECT_GT((*pl)[2], 0.0);
    EXPECT_NEAR(std::hypot((*pl)[0], (*pl)[1], (*pl)[2]), 1.0, 1e-12);
}

TEST(Ground, TooFewOrCollinearPointsGiveNoGround) {
    scenes::Cloud two(2, 3);
    two << 1, 0, 0, 2, 0, 0;
    EXPECT_FALSE(rp::fit_ground(view(two), rp::GroundConfig{}).plane);
    scenes::Cloud line(50, 3);
    for (int i = 0; i < 50; ++i) line.row(i) << float(i), float(2 * i), 0.0f;
    const rp::GroundFit fit = rp::fit_ground(view(line), rp::GroundConfig{});
    EXPECT_FALSE(fit.plane);
    EXPECT_EQ(fit.count, 0);
    scenes::Cloud none(0, 3);
    EXPECT_FALSE(rp::fit_ground(view(none), rp::GroundConfig{}).plane);
}

class RansacGround : public ::testing::TestWithParam<unsigned> {};

TEST_P(RansacGround, InliersLieWithinTheThresholdOfItsPlane) {
    rp::GroundConfig cfg;
    cfg.method = rp::GroundMethod::Ransac;
    cfg.ransac_seed = GetParam();
    scenes::Cloud ground = scenes::plane(0.02, 0.01, -1.8, 10000, 1, 40, 9, GetParam());
    for (Eigen::Index i = 0; i < ground.rows(); ++i) ground(i, 2) += 0.03f * std::sin(float(i));  // rough
    const scenes::Cloud pts = scenes::concat(ground, scenes::plane(0.0, 0.0, 0.5, 3000, 5, 30, 9, 3));
    const rp::GroundFit fit = rp::fit_ground(view(pts), cfg);
    ASSERT_TRUE(fit.plane);
    EXPECT_GT((*fit.plane)[2], std::cos(cfg.max_tilt_deg * M_PI / 180));
    std::int64_t count = 0;
    for (Eigen::Index i = 0; i < pts.rows(); ++i) {
        const double h = rp::height_above(*fit.plane, pts(i, 0), pts(i, 1), pts(i, 2));
        if (fit.mask[i]) {
            ++count;
            EXPECT_LE(std::abs(h), cfg.ransac_distance_m + 1e-6);
        } else {
            EXPECT_GT(std::abs(h), cfg.ransac_distance_m - 1e-6);
        }
    }
    EXPECT_EQ(count, fit.count);
    EXPECT_GE(fit.count, 9900);       // the rough ground
    EXPECT_LE(fit.count, 10000);      // and not the raised slab
}

// On rough ground (every draw keeps other points) the seed decides the plane: the same seed the same plane, bit for
// bit, another seed another.
TEST_P(RansacGround, SameSeedSameResult) {
    rp::GroundConfig cfg;
    cfg.method = rp::GroundMethod::Ransac;
    cfg.ransac_seed = GetParam();
    scenes::Cloud pts = scenes::plane(0.02, 0.01, -1.8, 5000, 1, 40, 9, 5);
    // ±0.3 m of relief against the 0.2 m consensus distance: each draw keeps another part of the points.
    for (Eigen::Index i = 0; i < pts.rows(); ++i) pts(i, 2) += 0.3f * std::sin(float(i));
    const rp::GroundFit a = rp::fit_ground(view(pts), cfg), b = rp::fit_ground(view(pts), cfg);
    ASSERT_TRUE(a.plane && b.plane);
    EXPECT_EQ(*a.plane, *b.plane);
    EXPECT_EQ(a.mask, b.mask);
    cfg.ransac_seed = GetParam() + 1;
    const rp::GroundFit other = rp::fit_ground(view(pts), cfg);
    ASSERT_TRUE(other.plane);
    EXPECT_NE(*other.plane, *a.plane);
}

// Points on a line span no plane: no ground, and nothing printed (PCL's sampler complains of each collinear draw).
TEST(Ground, RansacOnCollinearPointsIsNoGroundAndSilent) {
    rp::GroundConfig cfg;
    cfg.method = rp::GroundMethod::Ransac;
    scenes::Cloud line(50, 3);
    for (int i = 0; i < 50; ++i) line.row(i) << 2.0f + 0.5f * float(i), 0.0f, -1.8f;
    testing::internal::CaptureStderr();
    const rp::GroundFit fit = rp::fit_ground(view(line), cfg);
    EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
    EXPECT_FALSE(fit.plane);
    EXPECT_EQ(fit.status, rp::GroundStatus::NoGround);
}

INSTANTIATE_TEST_SUITE_P(Seeds, RansacGround, ::testing::Values(1u, 7u, 12345u));
