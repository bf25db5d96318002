// SPDX-License-Identifier: BSD-3-Clause
// Mounting from the ground (docs/method.md §1): height, roll and pitch back from a plane seen by a tilted sensor.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <roadpreview/core/frames.hpp>
#include <roadpreview/ground/mounting.hpp>

namespace rp = roadpreview;

TEST(Mounting, FromThePlaneATiltedSensorSees) {
    const rp::Extrinsics e{0.0, 0.0, 1.9, 0.03, -0.06, 0.0};
    const rp::RigidTransform T = rp::to_rigid_transform(e);
    // The base ground z = 0 in the sensor frame: normal Rᵀẑ (R's third row), d = h.
    const rp::Plane sensor_plane{T.R[2][0], T.R[2][1], T.R[2][2], e.z_m};
    const rp::Mounting m = rp::mounting_from_plane(sensor_plane);
    EXPECT_NEAR(m.height_m, 1.9, 1e-12);
    EXPECT_NEAR(m.roll_rad, 0.03, 1e-12);
    EXPECT_NEAR(m.pitch_rad, -0.06, 1e-12);
}

TEST(Mounting, EstimatedFromSensorFramePoints) {
    const rp::RigidTransform T = rp::to_rigid_transform(rp::Extrinsics{0.0, 0.0, 1.5, -0.02, 0.04, 0.0});
    std::vector<float> xyz;
    for (int i = 0; i < 60; ++i)
        for (int j = 0; j < 30; ++j) {
            const double b[3] = {2.0 + 0.5 * i, -7.0 + 0.5 * j, 0.0};
            // p_sensor = Rᵀ(p_base − t)
            const double d[3] = {b[0] - T.t[0], b[1] - T.t[1], b[2] - T.t[2]};
            for (int r = 0; r < 3; ++r)
                xyz.push_back(static_cast<float>(T.R[0][r] * d[0] + T.R[1][r] * d[1] + T.R[2][r] * d[2]));
        }
    const auto m = rp::estimate_mounting(rp::points_view(xyz.data(), static_cast<Eigen::Index>(xyz.size() / 3), 3),
                                         rp::GroundConfig{});
    ASSERT_TRUE(m.has_value());
    EXPECT_NEAR(m->height_m, 1.5, 1e-5);
    EXPECT_NEAR(m->roll_rad, -0.02, 1e-5);
    EXPECT_NEAR(m->pitch_rad, 0.04, 1e-5);
    EXPECT_GT(m->ground_points, 1000);
}

TEST(Mounting, CheckFlagsAGroundFarFromTheBaseOrigin) {
    EXPECT_FALSE(rp::check_mounting({0.0, 0.0, 1.0, 0.05}).disagrees);
    const rp::MountingCheck off = rp::check_mounting({0.0, 0.0, 1.0, -2.0});
    EXPECT_TRUE(off.disagrees);
    EXPECT_DOUBLE_EQ(off.offset_m, -2.0);
    const double tilt = 0.2;  // rad, about 11.5°
    const rp::MountingCheck tilted = rp::check_mounting({std::sin(tilt), 0.0, std::cos(tilt), 0.0});
    EXPECT_TRUE(tilted.disagrees);
    EXPECT_NEAR(tilted.tilt_deg, tilt * 180.0 / M_PI, 1e-9);
}
