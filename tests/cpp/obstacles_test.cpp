#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <nlohmann/json.hpp>
#include <roadpreview/roadpreview.hpp>

#include "scenes.hpp"

namespace rp = roadpreview;

namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();

// Flat ground z = 0 in the base frame (no sensor pose), about 40 points per m².
scenes::Cloud flat_ground(unsigned seed = 3) { return scenes::plane(0.0, 0.0, 0.0, 40000, 0.5, 45.0, 11.0, seed); }

scenes::Cloud with(scenes::Cloud scene, const scenes::Cloud& more) { return scenes::concat(scene, more); }

// These scenes put boxes with dense faces (0.05 m apart) on flat ground ten times sparser and were written for
// the one-plane ground: the zone ground's small patches can take part of such a face as a patch's ground
// (README "Ground"). The obstacle stage is tested here on the one plane.
rp::Result run(const scenes::Cloud& pts, double v, double w, rp::Config cfg = {}) {
    cfg.ground.method = rp::GroundMethod::Pca;
    rp::Estimator est(cfg);
    return est.process(pts, v, w);
}

void expect_obstacle(const std::vector<rp::PathObstacle>& found, double s_start, double s_end, double height) {
    // The acceptance: the s-interval within 0.2 m and the height within 5 cm.
    const auto hit = std::find_if(found.begin(), found.end(), [&](const rp::PathObstacle& o) {
        return std::abs(o.s_start - s_start) <= 0.2 && std::abs(o.s_end - s_end) <= 0.2;
    });
    ASSERT_NE(hit, found.end()) << "no obstacle at s ∈ [" << s_start << ", " << s_end << "]";
    EXPECT_NEAR(hit->height, height, 0.05);
}

bool all_nan(const std::vector<double>& z, std::size_t first, std::size_t last) {
    return std::all_of(z.begin() + first, z.begin() + last + 1, [](double v) { return std::isnan(v); });
}

}  // namespace

TEST(Obstacles, BoxesInTheWheelPathsAreReportedWithTheirStretchAndHeight) {
    scenes::Cloud scene = flat_ground();
    scene = with(scene, scenes::box(12.5, 0.8, 1.0, 0.6, 0.30));   // a rock on the left wheel path
    scene = with(scene, scenes::box(20.2, -0.8, 0.4, 0.4, 0.25));  // a small one on the right
    scene = with(scene, scenes::box(15.0, 3.0, 1.0, 1.0, 1.00));   // beside the road
    scene = with(scene, scenes::box(30.0, 0.0, 4.0, 1.8, 1.50));   // a car across both paths
    const rp::Result r = run(scene, 5.0, 0.0);
    ASSERT_TRUE(r.obstacles);
    ASSERT_EQ(r.obstacles->size(), 4u);
    const double nearest[] = {12.0, 14.5, 20.0, 28.0};  // ids rank the clusters by their nearest x
    for (int id = 0; id < 4; ++id) {
        EXPECT_EQ((*r.obstacles)[id].id, id);
        EXPECT_NEAR((*r.obstacles)[id].aabb_min[0], nearest[id], 1e-4);
    }
    ASSERT_TRUE(r.left.obstacles && r.right.obstacles);
    ASSERT_EQ(r.left.obstacles->size(), 2u);
    ASSERT_EQ(r.right.obstacles->size(), 2u);
    expect_obstacle(*r.left.obstacles, 12.0, 13.0, 0.30);
    expect_obstacle(*r.left.obstacles, 28.0, 32.0, 1.50);
    expect_obstacle(*r.right.obstacles, 20.0, 20.4, 0.25);
    expect_obstacle(*r.right.obstacles, 28.0, 32.0, 1.50);
    EXPECT_EQ(r.left.obstacles->front().id, 0);  // ordered by s_start
    EXPECT_EQ(r.right.obstacles->front().id, 2);
}

TEST(Obstacles, AnObstacleOnACurveIsAtItsArcLength) {
    const double v = 5.0, w = 0.25;  // left turn, ICR at y = 20 m: the left wheel runs on a circle of 19.2 m
    const auto paths = rp::plan_paths(v, w, 1.6, rp::PathConfig{});
    const double s_c = 15.0, phi = s_c / paths.left_radius;
    const double cx = paths.left_radius * std::sin(phi), cy = paths.icr_y - paths.left_radius * std::cos(phi);
    const rp::Result r = run(with(flat_ground(), scenes::box(cx, cy, 0.4, 0.4, 0.4, 0.0, phi)), v, w);
    ASSERT_TRUE(r.left.obstacles);
    ASSERT_EQ(r.left.obstacles->size(), 1u);
    expect_obstacle(*r.left.obstacles, s_c - 0.2, s_c + 0.2, 0.4);
    EXPECT_TRUE(r.right.obstacles->empty());  // 1.6 m to the right of the box
}

TEST(Obstacles, ProfilesStopAtObstaclesAndTheRoughnessOnlySeesTheRoad) {
    // An ISO 8608 class C road along x; a 0.3 m box on both wheel paths at 18.03–19.03 m (off the bin edges).
    const std::vector<double> road = scenes::iso_profile(256e-6, 500, 0.1, 11);
    scenes::Cloud ground = flat_ground();
    for (Eigen::Index i = 0; i < ground.rows(); ++i)
        ground(i, 2) = float(road[std::min<std::size_t>(static_cast<std::size_t>(std::max(0.0f, ground(i, 0)) / 0.1), 499)]);
    const scenes::Cloud with_box = with(ground, scenes::box(18.53, 0.0, 1.0, 2.4, 0.3));
    rp::Config cfg;
    cfg.profile.level = false;  // compare raw heights
    const rp::Result clean = run(ground, 5.0, 0.0, cfg);
    const rp::Result on = run(with_box, 5.0, 0.0, cfg);
    cfg.obstacles.enabled = false;
    const rp::Result off = run(with_box, 5.0, 0.0, cfg);

    const std::size_t first = 179, last = 191;  // bins overlapping [18.03 − 0.1, 19.03 + 0.1]
    for (std::size_t k = 0; k < on.left.blocked.size(); ++k) EXPECT_EQ(on.left.blocked[k], k >= first && k <= last) << k;
    EXPECT_TRUE(all_nan(on.left.z, first, last));  // never interpolated across
    std::vector<double> expected = clean.left.z;
    for (std::size_t k = first; k <= last; ++k) expected[k] = kNaN;
    for (std::size_t k = 0; k < expected.size(); ++k)
        if (!std::isnan(expected[k])) {
            EXPECT_DOUBLE_EQ(on.left.z[k], expected[k]) << k;
        }
    rp::Profile road_only = clean.left;  // the clean road's profile with the obstacle's bins cut out
    road_only.z = expected;
    for (std::size_t k = first; k <= last; ++k) road_only.spread[k] = kNaN;
    const rp::Roughness want = rp::analyze_roughness(road_only, cfg.roughness);
    ASSERT_TRUE(on.left.roughness.iso_class && want.iso_class);
    EXPECT_DOUBLE_EQ(on.left.roughness.gd_n0, want.gd_n0);  // the longest clean stretch, 19.2–40 m
    // Without clustering the box's low faces (ground by the 0.2 m threshold) enter the profile.
    EXPECT_GT(*std::max_element(off.left.z.begin() + first, off.left.z.begin() + last), 0.1);
    EXPECT_FALSE(off.left.obstacles);
}

TEST(Obstacles, BlockedBinsCoverTheObstacleAndTheMargin) {
    const std::vector<rp::PathObstacle> obstacles = {{0, 12.34, 12.8, 0.3}, {1, 0.05, 0.07, 0.2}, {2, 39.95, 39.99, 1.0}};
    const std::vector<std::uint8_t> blocked = rp::blocked_bins(obstacles, 400, 0.1, 0.1);
    for (std::size_t k = 0; k < 400; ++k) {
        const bool expected = k <= 1 || (k >= 122 && k <= 129) || k >= 398;  // clipped to the profile at both ends
        EXPECT_EQ(blocked[k], expected) << k;
    }
}

TEST(Obstacles, GapFillingDoesNotInterpolateAcrossABlockedBin) {
    std::vector<double> z = {0.0, kNaN, 2.0, kNaN, kNaN, 5.0, 9.0, 7.0};
    const std::vector<std::uint8_t> blocked = {0, 0, 0, 0, 1, 0, 1, 0};
    rp::fill_gaps(z, 0.1, 1.0, &blocked);
    EXPECT_DOUBLE_EQ(z[1], 1.0);  // an ordinary gap
    EXPECT_TRUE(std::isnan(z[3]) && std::isnan(z[4]));
    EXPECT_DOUBLE_EQ(z[6], 9.0);  // a blocked bin is left as it is, and is no end of an interpolation
    const std::vector<std::uint8_t> too_short(3, 0);
    EXPECT_THROW(rp::fill_gaps(z, 0.1, 1.0, &too_short), std::invalid_argument);
}

TEST(Obstacles, ToleranceSizeLimitsAndVoxels) {
    const auto view = [](const scenes::Cloud& c) { return rp::points_view(c.data(), c.rows(), 3); };
    const auto count = [](const std::vector<std::int32_t>& labels) { return *std::max_element(labels.begin(), labels.end()) + 1; };
    rp::ObstaclesConfig cfg;
    cfg.voxel_m = 0.0;  // every point
    const scenes::Cloud close = with(scenes::box(10.0, 0.0, 0.5, 0.5, 0.5), scenes::box(10.65, 0.0, 0.5, 0.5, 0.5));
    EXPECT_EQ(count(rp::cluster_labels(view(close), cfg)), 1);  // 0.15 m apart
    cfg.cluster_tolerance_m = 0.1;
    EXPECT_EQ(count(rp::cluster_labels(view(close), cfg)), 2);

    const scenes::Cloud apart = with(scenes::box(10.0, 0.0, 0.5, 0.5, 0.5), scenes::box(11.5, 0.0, 0.5, 0.5, 0.5));
    rp::ObstaclesConfig every_point;
    every_point.voxel_m = 0.0;
    const std::vector<std::int32_t> exact = rp::cluster_labels(view(apart), every_point);
    EXPECT_EQ(count(exact), 2);
    EXPECT_EQ(rp::cluster_labels(view(apart), rp::ObstaclesConfig{}), exact);  // voxels: the same clusters

    scenes::Cloud blob(13, 3);  // 10 points in a row, then 3 points far away
    for (int i = 0; i < 13; ++i) blob.row(i) << float(i < 10 ? 5.0 + 0.1 * i : 20.0 + 0.1 * i), 0.0f, 1.0f;
    cfg = rp::ObstaclesConfig{};
    const std::vector<std::int32_t> labels = rp::cluster_labels(view(blob), cfg);
    for (int i = 0; i < 13; ++i) EXPECT_EQ(labels[i], i < 10 ? 0 : -1) << i;  // 3 < min_cluster_points
    cfg.max_cluster_points = 9;
    cfg.min_cluster_points = 2;
    const std::vector<std::int32_t> capped = rp::cluster_labels(view(blob), cfg);
    for (int i = 0; i < 13; ++i) EXPECT_EQ(capped[i], i < 10 ? -1 : 0) << i;  // 10 > max_cluster_points
}

// Without voxels, copies of one point share one representative: the same clusters, their sizes still in points
// (copies count), and a cloud of 200,000 copies of one point is one cluster (it once took 40 s: every pair met).
TEST(Obstacles, CopiesOfAPointAreClusteredOnceAndCountedEach) {
    const auto view = [](const scenes::Cloud& c) { return rp::points_view(c.data(), c.rows(), 3); };
    rp::ObstaclesConfig cfg;
    cfg.voxel_m = 0.0;
    const scenes::Cloud boxes = with(scenes::box(10.0, 0.0, 0.5, 0.5, 0.5), scenes::box(11.5, 0.0, 0.5, 0.5, 0.5));
    const scenes::Cloud twice = with(boxes, boxes);
    const std::vector<std::int32_t> once = rp::cluster_labels(view(boxes), cfg);
    const std::vector<std::int32_t> doubled = rp::cluster_labels(view(twice), cfg);
    ASSERT_EQ(doubled.size(), 2 * once.size());
    for (std::size_t i = 0; i < once.size(); ++i) EXPECT_EQ(doubled[i], once[i]) << i;
    EXPECT_TRUE(std::equal(once.begin(), once.end(), doubled.begin() + static_cast<std::ptrdiff_t>(once.size())));
    cfg.min_cluster_points = static_cast<int>(once.size());  // each box holds half of `boxes`' points: too few alone
    const std::vector<std::int32_t> small = rp::cluster_labels(view(boxes), cfg);
    EXPECT_EQ(*std::max_element(small.begin(), small.end()), -1);
    const std::vector<std::int32_t> sized = rp::cluster_labels(view(twice), cfg);  // copies count: big enough now
    EXPECT_EQ(*std::max_element(sized.begin(), sized.end()), 1);

    const scenes::Cloud copies = scenes::Cloud::Constant(200000, 3, 2.0f);
    cfg = rp::ObstaclesConfig{};
    cfg.voxel_m = 0.0;
    cfg.max_cluster_points = 1000000;
    const std::vector<std::int32_t> one = rp::cluster_labels(view(copies), cfg);
    EXPECT_TRUE(std::all_of(one.begin(), one.end(), [](std::int32_t l) { return l == 0; }));
}

TEST(Obstacles, BoxesAndHeightAboveTheLocalGround) {
    // A 4 × 2 m car turned by 30°, on a 6 × 6 m patch raised 0.1 m (still ground by the 0.2 m threshold).
    scenes::Cloud ground = flat_ground();
    for (Eigen::Index i = 0; i < ground.rows(); ++i)
        if (std::abs(ground(i, 0) - 20.0f) < 3.0f && std::abs(ground(i, 1) - 5.0f) < 3.0f) ground(i, 2) = 0.1f;
    const double yaw = M_PI / 6;
    const rp::Result r = run(with(ground, scenes::box(20.0, 5.0, 4.0, 2.0, 1.5, 0.1, yaw)), 5.0, 0.0);
    ASSERT_EQ(r.obstacles->size(), 1u);
    const rp::Cluster& car = r.obstacles->front();
    EXPECT_NEAR(car.obb.yaw, yaw, 0.02);
    EXPECT_NEAR(car.obb.size[0], 4.0, 0.01);
    EXPECT_NEAR(car.obb.size[1], 2.0, 0.01);
    EXPECT_NEAR(car.obb.center[0], 20.0, 0.01);
    EXPECT_NEAR(car.obb.center[1], 5.0, 0.01);
    const double half_x = 2.0 * std::cos(yaw) + 1.0 * std::sin(yaw), half_y = 2.0 * std::sin(yaw) + 1.0 * std::cos(yaw);
    EXPECT_NEAR(car.aabb_min[0], 20.0 - half_x, 0.01);
    EXPECT_NEAR(car.aabb_max[1], 5.0 + half_y, 0.01);
    EXPECT_NEAR(car.aabb_max[2], 1.6, 1e-5);
    // The median of the raised patch around it, above the frame's plane (which the patch lifts a little).
    EXPECT_NEAR(car.ground_offset, rp::height_above(*r.plane, 20.0, 5.0, 0.1), 0.005);
    EXPECT_NEAR(car.height, 1.5, 0.01);
    EXPECT_GT(car.count, 500);
    EXPECT_EQ(std::count(r.cluster_labels.begin(), r.cluster_labels.end(), 0), car.count);
}

TEST(Obstacles, LowClustersDoNotBlockAWheelPath) {
    rp::Config cfg;
    cfg.obstacles.min_height_m = 0.35;
    const rp::Result r = run(with(flat_ground(), scenes::box(12.5, 0.8, 1.0, 0.6, 0.30)), 5.0, 0.0, cfg);
    EXPECT_EQ(r.obstacles->size(), 1u);  // still a cluster
    EXPECT_TRUE(r.left.obstacles->empty());
    EXPECT_EQ(std::count(r.left.blocked.begin(), r.left.blocked.end(), 1), 0);
}

TEST(Obstacles, OffStoppedAndNoGround) {
    const scenes::Cloud scene = with(flat_ground(), scenes::box(12.5, 0.8, 1.0, 0.6, 0.5));
    rp::Config off;
    off.obstacles.enabled = false;
    const rp::Result r_off = run(scene, 5.0, 0.0, off);
    EXPECT_FALSE(r_off.obstacles);
    EXPECT_FALSE(r_off.left.obstacles);
    EXPECT_EQ(std::count(r_off.left.blocked.begin(), r_off.left.blocked.end(), 1), 0);
    EXPECT_EQ(std::count(r_off.cluster_labels.begin(), r_off.cluster_labels.end(), -1), scene.rows());

    const rp::Result stopped = run(scene, 0.0, 0.0);
    EXPECT_EQ(stopped.status, rp::FrameStatus::VehicleStopped);
    EXPECT_EQ(stopped.obstacles->size(), 1u);  // what is around a stopped vehicle is still reported
    EXPECT_TRUE(stopped.left.obstacles && stopped.left.obstacles->empty());

    const rp::Result nothing = run(scenes::box(80.0, 0.0, 1.0, 1.0, 1.0), 5.0, 0.0);  // outside the ROI
    EXPECT_EQ(nothing.status, rp::FrameStatus::NoRoiPoints);
    EXPECT_TRUE(nothing.obstacles && nothing.obstacles->empty());
}

TEST(Obstacles, JsonLineCarriesClustersBlockedBinsAndTiming) {
    const rp::Result r = run(with(flat_ground(), scenes::box(12.5, 0.8, 1.0, 0.6, 0.3)), 5.0, 0.0);
    const auto j = nlohmann::json::parse(rp::result_to_json(r));
    ASSERT_EQ(j["obstacles"].size(), 1u);
    const auto& c = j["obstacles"][0];
    for (const char* key : {"id", "count", "centroid", "aabb_min", "aabb_max", "obb", "height", "bottom"}) EXPECT_TRUE(c.contains(key)) << key;
    EXPECT_NEAR(c["height"].get<double>(), 0.3, 0.0015);
    EXPECT_EQ(c["obb"]["size"].size(), 3u);
    const auto& left = j["profiles"]["left"];
    ASSERT_EQ(left["blocked"].size(), 400u);
    EXPECT_TRUE(left["blocked"][125].get<bool>());
    EXPECT_TRUE(left["z"][125].is_null());
    ASSERT_EQ(left["obstacles"].size(), 1u);
    EXPECT_NEAR(left["obstacles"][0]["s_start"].get<double>(), 12.0, 1e-3);  // rounded to mm
    EXPECT_TRUE(j["profiles"]["right"]["obstacles"].empty());
    EXPECT_GT(j["timing_ms"]["obstacles"].get<double>(), 0.0);

    rp::Config off;
    off.obstacles.enabled = false;
    const auto j_off = nlohmann::json::parse(rp::result_to_json(run(flat_ground(), 5.0, 0.0, off)));
    EXPECT_TRUE(j_off["obstacles"].is_null());
    EXPECT_TRUE(j_off["profiles"]["left"]["obstacles"].is_null());
}
