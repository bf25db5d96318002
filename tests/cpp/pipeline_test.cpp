#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <nlohmann/json.hpp>
#include <roadpreview/roadpreview.hpp>

#include "scenes.hpp"

namespace rp = roadpreview;

namespace {

// A road seen from a sensor 1.8 m up: gentle waves, plus a 1 m high box on the left wheel path.
scenes::Cloud road_scene() {
    scenes::Cloud road = scenes::plane(0.0, 0.0, -1.8, 60000, 0.5, 45.0, 11.0);
    for (Eigen::Index i = 0; i < road.rows(); ++i) road(i, 2) += 0.01f * std::sin(2.0f * road(i, 0));
    return scenes::concat(road, scenes::plane(0.0, 0.0, -0.8, 2000, 20.0, 21.0, 1.0, 5));
}

rp::Config kitti_like() {
    rp::Config cfg;
    cfg.sensor_height = 1.8;
    return cfg;
}

}  // namespace

TEST(Pipeline, SceneGivesGroundProfilesAndClasses) {
    const scenes::Cloud pts = road_scene();
    rp::Estimator est(kitti_like());
    const rp::Result r = est.process(pts, 5.0, 0.0, "scene");
    EXPECT_EQ(r.points.input, pts.rows());
    EXPECT_EQ(r.points.finite, pts.rows());
    ASSERT_TRUE(r.plane);
    EXPECT_NEAR((*r.plane)[2], 1.0, 1e-6);
    EXPECT_NEAR((*r.plane)[3], 0.0, 1e-3);  // the ground is at z = 0 of the base frame
    for (Eigen::Index i = 60000; i < pts.rows(); ++i) ASSERT_EQ(r.ground_mask[i], 0) << "box point " << i;
    EXPECT_EQ(r.left.z.size(), 400u);
    EXPECT_TRUE(r.left.roughness.iso_class) << r.left.roughness.reason;
    EXPECT_TRUE(r.vehicle.iso_class) << r.vehicle.reason;
    EXPECT_TRUE(r.reason.empty());
    EXPECT_GT(r.timing_ms.total, 0.0);
}

TEST(Pipeline, ExtraColumnsAreIgnoredAndReadInPlace) {
    const scenes::Cloud xyz = road_scene();
    rp::PointMatrix xyzi(xyz.rows(), 4);
    xyzi << xyz, Eigen::MatrixXf::Constant(xyz.rows(), 1, 7.0f);
    rp::Estimator a(kitti_like()), b(kitti_like());
    const rp::Result r3 = a.process(xyz, 5.0, 0.2), r4 = b.process(xyzi, 5.0, 0.2);
    EXPECT_EQ(r3.ground_mask, r4.ground_mask);
    EXPECT_EQ(rp::result_to_json(r3).substr(0, 2000), rp::result_to_json(r4).substr(0, 2000));
    EXPECT_EQ(r3.left.count, r4.left.count);
}

TEST(Pipeline, NonFinitePointsAreDroppedAndCounted) {
    scenes::Cloud pts = road_scene();
    const float nan = std::numeric_limits<float>::quiet_NaN();
    for (Eigen::Index i = 0; i < pts.rows(); i += 10) pts(i, i % 3) = (i % 20 == 0) ? nan : INFINITY;
    rp::Estimator est(kitti_like());
    const rp::Result r = est.process(pts, 5.0, 0.0);
    EXPECT_EQ(r.points.finite, pts.rows() - (pts.rows() + 9) / 10);
    for (Eigen::Index i = 0; i < pts.rows(); i += 10) EXPECT_EQ(r.ground_mask[i], 0);
    EXPECT_TRUE(r.plane);
}

TEST(Pipeline, EmptyAndAllNanCloudsGiveReasonsNotCrashes) {
    rp::Estimator est(kitti_like());
    const rp::Result empty = est.process(scenes::Cloud(0, 3), 5.0, 0.0);
    EXPECT_EQ(empty.reason, "no finite points");
    EXPECT_FALSE(empty.plane);
    EXPECT_TRUE(empty.left.z.empty());
    EXPECT_EQ(empty.vehicle.reason, "no finite points");
    const scenes::Cloud nans = scenes::Cloud::Constant(100, 3, std::numeric_limits<float>::quiet_NaN());
    EXPECT_EQ(est.process(nans, 5.0, 0.0).reason, "no finite points");
    const scenes::Cloud far = scenes::plane(0, 0, -1.8, 500, 60.0, 80.0);  // nothing in the ROI
    EXPECT_EQ(est.process(far, 5.0, 0.0).reason, "no ground");
}

TEST(Pipeline, StoppedVehicleKeepsTheGroundButHasNoProfiles) {
    rp::Estimator est(kitti_like());
    const rp::Result r = est.process(road_scene(), 0.0, 0.1);
    EXPECT_TRUE(r.plane);
    EXPECT_GT(r.points.ground, 0);
    EXPECT_EQ(r.reason, "vehicle stopped");
    EXPECT_TRUE(r.left.z.empty());
    EXPECT_EQ(r.left.roughness.reason, "vehicle stopped");
}

TEST(Pipeline, BadMotionOrConfigThrows) {
    rp::Estimator est(kitti_like());
    EXPECT_THROW(est.process(road_scene(), std::nan(""), 0.0), std::invalid_argument);
    rp::Config bad;
    bad.tire_width = 0.0;
    EXPECT_THROW(rp::Estimator{bad}, std::invalid_argument);
}

TEST(Pipeline, EmptyCorridorsAreMissingNotZero) {
    // Ground only to the right of the vehicle: the left wheel's corridor holds no points.
    scenes::Cloud right = scenes::plane(0.0, 0.0, -1.8, 20000, 1.0, 40.0, 3.0);
    for (Eigen::Index i = 0; i < right.rows(); ++i) right(i, 1) = -std::abs(right(i, 1)) - 0.2f;
    rp::Estimator est(kitti_like());
    const rp::Result r = est.process(right, 5.0, 0.0);
    ASSERT_TRUE(r.plane);
    EXPECT_EQ(std::count(r.left.count.begin(), r.left.count.end(), 0), 400);
    EXPECT_TRUE(std::all_of(r.left.z.begin(), r.left.z.end(), [](double z) { return std::isnan(z); }));
    EXPECT_EQ(r.left.roughness.reason, "no valid profile");
    EXPECT_TRUE(r.right.roughness.iso_class);
    EXPECT_FALSE(r.vehicle.iso_class);
}

TEST(Pipeline, JsonLineHasTheDocumentedFields) {
    rp::Estimator est(kitti_like());
    est.process(road_scene(), 5.0, 0.3);
    const auto j = nlohmann::json::parse(rp::result_to_json(est.process(road_scene(), 5.0, 0.3, "f.bin")));
    EXPECT_EQ(j["frame"], 1);
    EXPECT_EQ(j["source"], "f.bin");
    for (const char* key : {"points", "ground", "path", "profiles", "roughness", "timing_ms"}) EXPECT_TRUE(j.contains(key)) << key;
    EXPECT_NEAR(j["path"]["icr_y"].get<double>(), 5.0 / 0.3, 1e-12);
    EXPECT_EQ(j["ground"]["method"], "zones");
    EXPECT_EQ(j["profiles"]["left"]["z"].size(), 400u);
    for (const char* key : {"class", "gd_n0", "waviness", "band", "n", "psd", "octave_bands", "reason"})
        EXPECT_TRUE(j["roughness"]["vehicle"].contains(key)) << key;
    for (const char* key : {"ground", "path", "profile", "roughness", "total"}) EXPECT_TRUE(j["timing_ms"].contains(key));
}
