#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <roadpreview/paths/path.hpp>

namespace rp = roadpreview;

namespace {
const rp::PathConfig kCfg;
constexpr double kTrack = 1.6, kTire = 0.3;
}  // namespace

TEST(Path, LeftTurnHasTheCentreOnTheLeftAndTheLeftWheelInside) {
    const auto p = rp::plan_paths(10.0, 0.5, kTrack, kCfg);  // r = 20 m
    ASSERT_EQ(p.status, rp::PathStatus::Arc);
    EXPECT_DOUBLE_EQ(p.icr_y, 20.0);
    EXPECT_DOUBLE_EQ(p.left_radius, 20.0 - 0.8);
    EXPECT_DOUBLE_EQ(p.right_radius, 20.0 + 0.8);
}

TEST(Path, RightTurnMirrorsTheLeftTurn) {
    const auto p = rp::plan_paths(10.0, -0.5, kTrack, kCfg);
    ASSERT_EQ(p.status, rp::PathStatus::Arc);
    EXPECT_DOUBLE_EQ(p.icr_y, -20.0);
    EXPECT_DOUBLE_EQ(p.left_radius, 20.8);
    EXPECT_DOUBLE_EQ(p.right_radius, 19.2);
}

TEST(Path, ZeroYawRateOrAHugeRadiusIsStraight) {
    EXPECT_EQ(rp::plan_paths(10.0, 0.0, kTrack, kCfg).status, rp::PathStatus::Straight);
    EXPECT_EQ(rp::plan_paths(10.0, 0.009, kTrack, kCfg).status, rp::PathStatus::Straight);  // 1111 m
    EXPECT_EQ(rp::plan_paths(10.0, 0.011, kTrack, kCfg).status, rp::PathStatus::Arc);       // 909 m
}

TEST(Path, ZeroSpeedIsStoppedWithoutDividing) {
    const auto p = rp::plan_paths(0.0, 0.3, kTrack, kCfg);
    EXPECT_EQ(p.status, rp::PathStatus::Stopped);
    EXPECT_FALSE(rp::arc_length(p, rp::Wheel::Left, 5.0, 0.8, kTire));
    EXPECT_EQ(rp::plan_paths(0.0, 0.0, kTrack, kCfg).status, rp::PathStatus::Stopped);
}

TEST(Path, NonFiniteMotionIsRejected) {
    EXPECT_THROW(rp::plan_paths(std::nan(""), 0.0, kTrack, kCfg), std::invalid_argument);
    EXPECT_THROW(rp::plan_paths(5.0, std::numeric_limits<double>::infinity(), kTrack, kCfg), std::invalid_argument);
}

TEST(Path, StraightCorridorAndArcLength) {
    const auto p = rp::plan_paths(5.0, 0.0, kTrack, kCfg);
    EXPECT_DOUBLE_EQ(*rp::arc_length(p, rp::Wheel::Left, 12.5, 0.8, kTire), 12.5);
    EXPECT_TRUE(rp::arc_length(p, rp::Wheel::Left, 3.0, 0.8 + 0.149, kTire));
    EXPECT_FALSE(rp::arc_length(p, rp::Wheel::Left, 3.0, 0.8 + 0.151, kTire));
    EXPECT_FALSE(rp::arc_length(p, rp::Wheel::Right, 3.0, 0.8, kTire));
    EXPECT_DOUBLE_EQ(*rp::arc_length(p, rp::Wheel::Right, 3.0, -0.8, kTire), 3.0);
    EXPECT_FALSE(rp::arc_length(p, rp::Wheel::Left, -3.0, 0.8, kTire));  // behind
}

TEST(Path, ReversingLooksBehind) {
    const auto p = rp::plan_paths(-2.0, 0.0, kTrack, kCfg);
    EXPECT_DOUBLE_EQ(*rp::arc_length(p, rp::Wheel::Left, -4.0, 0.8, kTire), 4.0);
    EXPECT_FALSE(rp::arc_length(p, rp::Wheel::Left, 4.0, 0.8, kTire));
}

// A point on a wheel's circle at swept angle φ from the wheel lies at arc length φ·r_wheel.
void expect_on_circle(double v, double w, rp::Wheel wheel, double phi) {
    const auto p = rp::plan_paths(v, w, kTrack, kCfg);
    const double r = p.radius(wheel), y_w = p.wheel_y(wheel);
    const double start = std::atan2(y_w - p.icr_y, 0.0);  // angle of the wheel seen from the ICR
    const double a = start + p.rotation * phi;
    const double x = r * std::cos(a), y = p.icr_y + r * std::sin(a);
    const auto s = rp::arc_length(p, wheel, x, y, kTire);
    ASSERT_TRUE(s) << "v=" << v << " w=" << w << " phi=" << phi;
    EXPECT_NEAR(*s, phi * r, 1e-9);
    EXPECT_EQ(v > 0 ? x > 0 : x < 0, true) << "a point the wheel reaches lies in the direction of travel";
    // Just outside the tire's half width, radially.
    const double xo = (r + 0.16) * std::cos(a), yo = p.icr_y + (r + 0.16) * std::sin(a);
    EXPECT_FALSE(rp::arc_length(p, wheel, xo, yo, kTire));
}

TEST(Path, PointsOnTheWheelCircleHaveArcLengthAngleTimesRadius) {
    for (double v : {8.0, -3.0})
        for (double w : {0.4, -0.25})
            for (rp::Wheel wheel : {rp::Wheel::Left, rp::Wheel::Right})
                for (double phi : {0.05, 0.5, 1.2}) expect_on_circle(v, w, wheel, phi);
}
