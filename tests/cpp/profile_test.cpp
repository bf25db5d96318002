#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <roadpreview/profile/profile.hpp>

#include "scenes.hpp"

namespace rp = roadpreview;

namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();

rp::WheelProfiles profiles_of(const scenes::Cloud& pts, double v, double w, const rp::Plane* plane = nullptr,
                              rp::ProfileConfig cfg = {}) {
    const std::vector<std::uint8_t> all(pts.rows(), 1);
    const auto paths = rp::plan_paths(v, w, 1.6, rp::PathConfig{});
    return rp::build_profiles(rp::points_view(pts.data(), pts.rows(), 3), all, rp::levelling_for(plane), paths, 0.3, cfg);
}

}  // namespace

TEST(Profile, BinsHoldTheMedianAndTheCount) {
    scenes::Cloud pts(5, 3);
    // Three points in bin 12 (s ∈ [1.2, 1.3)), two in bin 50; one right-wheel point.
    pts << 1.21f, 0.8f, 0.10f, 1.25f, 0.7f, 0.30f, 1.29f, 0.9f, 0.20f, 5.01f, 0.8f, 0.5f, 5.05f, 0.8f, 0.7f;
    const auto w = profiles_of(pts, 5.0, 0.0);
    ASSERT_EQ(w.left.z.size(), 400u);
    EXPECT_DOUBLE_EQ(w.left.s0, 0.05);
    EXPECT_NEAR(w.left.s[12], 1.25, 1e-12);
    EXPECT_EQ(w.left.count[12], 3);
    EXPECT_NEAR(w.left.z[12], 0.20, 1e-6);
    EXPECT_EQ(w.left.count[50], 2);
    EXPECT_NEAR(w.left.z[50], 0.60, 1e-6);  // even count: mean of the middle two
    EXPECT_TRUE(std::isnan(w.left.z[11]));
    EXPECT_TRUE(std::isnan(w.left.z[51]));
    EXPECT_EQ(w.right.count[12], 0);
}

TEST(Profile, ShortInteriorGapsAreInterpolatedLongOnesAndEndsAreNot) {
    std::vector<double> z = {kNaN, 1.0, kNaN, kNaN, 4.0, kNaN, kNaN, kNaN, kNaN, kNaN, kNaN, 0.0, kNaN};
    rp::fill_gaps(z, 0.1, 0.3);
    EXPECT_TRUE(std::isnan(z[0]));
    EXPECT_DOUBLE_EQ(z[2], 2.0);
    EXPECT_DOUBLE_EQ(z[3], 3.0);
    for (int k = 5; k <= 10; ++k) EXPECT_TRUE(std::isnan(z[k])) << k;  // 0.6 m > 0.3 m
    EXPECT_TRUE(std::isnan(z[12]));
}

TEST(Profile, GapExactlyAtTheLimitIsFilled) {
    std::vector<double> z = {0.0, kNaN, kNaN, kNaN, 4.0};
    rp::fill_gaps(z, 0.1, 0.3);  // 3 × 0.1 = 0.30000000000000004 must count as 0.3
    EXPECT_DOUBLE_EQ(z[2], 2.0);
}

TEST(Profile, LevellingRemovesAMountPitch) {
    const double pitch = 2.0 * M_PI / 180;  // the road seems to rise 3.5 cm per metre
    const scenes::Cloud pts = scenes::plane(std::tan(pitch), 0.0, 0.0, 40000, 0.0, 40.0, 1.2);
    const rp::Plane pl = *rp::fit_plane(rp::points_view(pts.data(), pts.rows(), 3));
    const auto levelled = profiles_of(pts, 5.0, 0.0, &pl);
    const auto raw = profiles_of(pts, 5.0, 0.0, nullptr);
    double max_level = 0.0;
    for (double z : levelled.left.z)
        if (!std::isnan(z)) max_level = std::max(max_level, std::abs(z));
    EXPECT_LT(max_level, 1e-5);
    EXPECT_NEAR(raw.left.z[300], std::tan(pitch) * 30.05, 0.01);
}

TEST(Profile, ArcLengthBinsFollowTheWheelCircle) {
    // Left turn of radius 20 m: put one point every 0.5 m of arc on the right wheel's circle.
    const auto paths = rp::plan_paths(10.0, 0.5, 1.6, rp::PathConfig{});
    const double r = paths.right_radius;
    scenes::Cloud pts(60, 3);
    for (int i = 0; i < 60; ++i) {
        const double s = 0.25 + 0.5 * i, phi = s / r;
        pts.row(i) << float(r * std::sin(phi)), float(paths.icr_y - r * std::cos(phi)), float(0.01 * i);
    }
    const auto w = profiles_of(pts, 10.0, 0.5);
    for (int i = 0; i < 60; ++i) {
        const auto bin = static_cast<std::size_t>((0.25 + 0.5 * i) / 0.1);
        EXPECT_EQ(w.right.count[bin], 1) << i;
        EXPECT_NEAR(w.right.z[bin], 0.01 * i, 1e-6);
    }
    EXPECT_EQ(std::count(w.left.count.begin(), w.left.count.end(), 0), 400);
}

TEST(Profile, StoppedVehicleHasNoProfiles) {
    const scenes::Cloud pts = scenes::plane(0, 0, 0, 100);
    const auto w = profiles_of(pts, 0.0, 0.0);
    EXPECT_TRUE(w.left.z.empty());
    EXPECT_TRUE(w.right.z.empty());
}
