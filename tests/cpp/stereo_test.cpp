// SPDX-License-Identifier: BSD-3-Clause
// Stereo input: calibration files, disparity → points (known answers on synthetic planes), range variances.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <utility>

#include "roadpreview/roadpreview.hpp"

namespace rp = roadpreview;

namespace {

const std::string kKittiCalib = std::string(ROADPREVIEW_TEST_DATA) + "/stereo/kitti_object_calib.txt";

std::string write_file(const std::string& name, const std::string& text) {
    const auto path = std::filesystem::temp_directory_path() / ("roadpreview_stereo_test_" + name);
    std::ofstream(path) << text;
    return path.string();
}

rp::StereoCalibration simple_calibration() {
    rp::StereoCalibration c;
    c.fx_px = c.fy_px = 400.0;
    c.cx_px = 320.0;
    c.cy_px = 60.0;
    c.baseline_m = 0.5;
    c.source = "test";
    return c;
}

// The pipeline's config for a camera 1.5 m above flat ground (obstacles off).
rp::Config flat_ground_config() {
    rp::Config cfg;
    cfg.sensor_height = 1.5;
    cfg.obstacles.enabled = false;
    return cfg;
}

// The points of simple_calibration()'s camera 1.5 m above flat ground, every `column_step`-th column, each
// disparity plus `noise_px` (σ, seeded) of Gaussian noise.
rp::StereoPoints flat_ground_points(int column_step = 1, float noise_px = 0.0f) {
    const rp::StereoCalibration c = simple_calibration();
    rp::DisparityImage d = rp::DisparityImage::Zero(240, 640);
    std::mt19937 rng(5);
    std::normal_distribution<float> unit(0.0f, 1.0f);
    for (int v = 61; v < 240; ++v)
        for (int u = 0; u < 640; u += column_step)
            d(v, u) = static_cast<float>(c.baseline_m * (v - c.cy_px) / 1.5) + noise_px * unit(rng);
    return rp::disparity_to_points(d, 0, c, flat_ground_config().stereo);
}

template <typename F>
std::string error_of(F f) {
    try {
        f();
    } catch (const std::exception& e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST(StereoCalibration, KittiColourBaselineIsTheDifferenceOfP2AndP3) {
    const rp::StereoCalibration c = rp::read_stereo_calibration(kKittiCalib);
    EXPECT_NEAR(c.fx_px, 721.5377, 1e-9);
    EXPECT_NEAR(c.cx_px, 609.5593, 1e-9);
    EXPECT_NEAR(c.cy_px, 172.854, 1e-9);
    EXPECT_NEAR(c.baseline_m, (44.85728 + 339.5242) / 721.5377, 1e-6);  // 0.5327 m, not −P3[0,3]/fx = 0.4706 m
    EXPECT_NEAR(c.baseline_m, 0.5327, 5e-5);
    EXPECT_FALSE(c.extrinsics);
}

TEST(StereoCalibration, MissingP3ZeroOrNegativeBaselineAreErrorsNamingTheFile) {
    const std::string p2 = "P2: 700 0 600 0 0 700 170 0 0 0 1 0\n";
    const std::string no_p3 = write_file("no_p3.txt", p2);
    EXPECT_NE(error_of([&] { rp::read_stereo_calibration(no_p3); }).find(no_p3 + ": a KITTI stereo calibration needs the P2 and P3"),
              std::string::npos);
    const std::string zero = write_file("zero.txt", p2 + "P3: 700 0 600 0 0 700 170 0 0 0 1 0\n");
    EXPECT_NE(error_of([&] { rp::read_stereo_calibration(zero); }).find(zero + ": the baseline"), std::string::npos);
    const std::string negative = write_file("negative.txt", p2 + "P3: 700 0 600 350 0 700 170 0 0 0 1 0\n");
    EXPECT_NE(error_of([&] { rp::read_stereo_calibration(negative); }).find("must be > 0 m"), std::string::npos);
    const std::string short_row = write_file("short.txt", p2 + "P3: 700 0 600\n");
    EXPECT_NE(error_of([&] { rp::read_stereo_calibration(short_row); }).find(short_row + ":2: P3 needs 12 numbers"),
              std::string::npos);
    EXPECT_NE(error_of([] { rp::read_stereo_calibration("/nonexistent/calib.txt"); }).find("/nonexistent/calib.txt"),
              std::string::npos);
}

TEST(StereoCalibration, YamlWithExtrinsics) {
    const std::string yaml = write_file("calib.yaml", "fx: 700\nfy: 701\ncx: 600\ncy: 170\nbaseline: 0.3\n"
                                                      "extrinsics: {x_m: 1.0, y_m: 0.0, z_m: 1.4, roll_rad: 0, pitch_rad: 0.05, yaw_rad: 0}\n");
    const rp::StereoCalibration c = rp::read_stereo_calibration(yaml);
    EXPECT_EQ(c.fy_px, 701.0);
    EXPECT_EQ(c.baseline_m, 0.3);
    ASSERT_TRUE(c.extrinsics);
    EXPECT_EQ(c.extrinsics->pitch_rad, 0.05);
    rp::Config cfg;
    EXPECT_EQ(rp::stereo_camera_pose(cfg, c).z_m, 1.4);  // the calibration's pose when the config has none
    cfg.sensor_height = 1.2;
    EXPECT_EQ(rp::stereo_camera_pose(cfg, c).z_m, 1.2);  // the config wins
    const std::string bad = write_file("bad.yaml", "fx: 700\nfy: 700\ncx: 600\ncy: 170\nbaseline: -0.3\n");
    EXPECT_NE(error_of([&] { rp::read_stereo_calibration(bad); }).find(bad + ": the baseline must be > 0 m"), std::string::npos);
    const std::string missing = write_file("missing.yaml", "fx: 700\n");
    EXPECT_NE(error_of([&] { rp::read_stereo_calibration(missing); }).find("needs 'fy'"), std::string::npos);
}

TEST(StereoCalibration, NoPoseAnywhereIsAnError) {
    const rp::StereoCalibration c = rp::read_stereo_calibration(kKittiCalib);
    EXPECT_NE(error_of([&] { rp::stereo_camera_pose(rp::Config{}, c); }).find("the camera's pose is unknown"), std::string::npos);
}

// A level camera h above a flat ground: row v sees the ground at depth f·h/(v − cy), disparity B·(v − cy)/h.
TEST(StereoPoints, GroundPlaneDisparityGivesPointsOnTheGround) {
    const rp::StereoCalibration c = simple_calibration();
    const double h = 1.5;
    rp::DisparityImage d = rp::DisparityImage::Zero(240, 640);
    for (int v = 61; v < 240; ++v) d.row(v).setConstant(static_cast<float>(c.baseline_m * (v - c.cy_px) / h));
    rp::StereoConfig cfg;
    cfg.max_depth_m = 1000.0;
    const rp::StereoPoints p = rp::disparity_to_points(d, 0, c, cfg);
    ASSERT_EQ(p.points.rows(), 179 * 640);
    for (Eigen::Index i = 0; i < p.points.rows(); i += 97) {
        const int v = p.pixels[static_cast<std::size_t>(i)] / 640, u = p.pixels[static_cast<std::size_t>(i)] % 640;
        const double z = c.fx_px * h / (v - c.cy_px);
        EXPECT_NEAR(p.points(i, 0), z, 1e-4 * z);
        EXPECT_NEAR(p.points(i, 1), -(u - c.cx_px) * z / c.fx_px, 1e-4 * z);
        EXPECT_NEAR(p.points(i, 2), -h, 1e-5);  // every point on the ground, 1.5 m below the camera
    }
}

TEST(StereoPoints, FrontoParallelPlaneAndRangeVariance) {
    const rp::StereoCalibration c = simple_calibration();
    rp::DisparityImage d = rp::DisparityImage::Constant(100, 640, 20.0f);  // z = 400·0.5/20 = 10 m
    d(50, 320) = std::nanf("");
    d(51, 320) = -1.0f;
    d(52, 320) = 0.0f;
    rp::StereoConfig cfg;
    cfg.disparity_sigma_px = 0.5;
    const rp::StereoPoints p = rp::disparity_to_points(d, 10, c, cfg);
    EXPECT_EQ(p.points.rows(), 90 * 640 - 3);  // rows 10…99, three invalid pixels
    EXPECT_EQ(p.pixels.front(), 10 * 640);
    const double sigma_z = 10.0 * 10.0 * 0.5 / (400.0 * 0.5);  // z²·σ_d/(f·B) = 0.25 m
    for (Eigen::Index i = 0; i < p.points.rows(); i += 301) {
        EXPECT_NEAR(p.points(i, 0), 10.0, 1e-5);
        const double r = std::sqrt(p.points.row(i).head<3>().cast<double>().squaredNorm());
        EXPECT_NEAR(p.range_variances[static_cast<std::size_t>(i)], std::pow(sigma_z * r / 10.0, 2), 1e-6);
    }
    cfg.max_depth_m = 9.0;  // every point is farther
    EXPECT_EQ(rp::disparity_to_points(d, 0, c, cfg).points.rows(), 0);
}

TEST(StereoPoints, ErrorGroupsAreTilesOfTwiceTheCorrelationLengths) {
    const rp::StereoCalibration c = simple_calibration();
    const rp::DisparityImage d = rp::DisparityImage::Constant(100, 640, 20.0f);
    rp::StereoConfig cfg;
    cfg.error_correlation_along_px = 15.0;  // tiles of 30 columns by 4 rows, 22 tiles per row (640 / 30 rounded up)
    cfg.error_correlation_across_px = 2.0;
    const rp::StereoPoints p = rp::disparity_to_points(d, 10, c, cfg);
    ASSERT_EQ(p.error_groups.size(), p.pixels.size());
    for (std::size_t i = 0; i < p.pixels.size(); i += 97) {
        const int v = p.pixels[i] / 640, u = p.pixels[i] % 640;
        EXPECT_EQ(p.error_groups[i], v / 4 * 22 + u / 30) << "pixel " << u << ", " << v;
    }
    cfg.error_correlation_along_px = cfg.error_correlation_across_px = 0.0;  // every pixel its own group
    const rp::StereoPoints own = rp::disparity_to_points(d, 10, c, cfg);
    EXPECT_EQ(own.error_groups, own.pixels);
}

TEST(StereoPoints, FirstRoadRowOfALevelCamera) {
    const rp::StereoCalibration c = simple_calibration();
    rp::StereoConfig cfg;
    cfg.max_depth_m = 40.0;
    cfg.road_rise_m = 0.0;
    rp::Extrinsics camera;
    camera.z_m = 1.5;
    EXPECT_EQ(rp::first_road_row(c, camera, 240, cfg), static_cast<int>(std::floor(60.0 + 400.0 * 1.5 / 40.0)));
    cfg.road_rise_m = 2.0;  // the road may rise above the camera: rows above the horizon are matched too
    EXPECT_LT(rp::first_road_row(c, camera, 240, cfg), 60);
    cfg.road_rise_m = 1e6;
    EXPECT_EQ(rp::first_road_row(c, camera, 240, cfg), 0);
}

TEST(StereoPoints, PipelineTakesRangeVariancesAsAFloorUnderTheBinsSpread) {
    // A flat ground plane 1.5 m below the camera, exactly on the plane: the sample spread is 0, the variance floor
    // is what the bins report.
    const rp::Config cfg = flat_ground_config();
    const rp::StereoPoints p = flat_ground_points();
    rp::Frame f;
    f.points = p.points;
    rp::Estimator plain(cfg);
    const rp::Result without = plain.process(f, 5.0, 0.0);
    f.range_variances = p.range_variances;
    rp::Estimator noisy(cfg);
    const rp::Result with = noisy.process(f, 5.0, 0.0);
    std::size_t compared = 0;
    for (std::size_t k = 0; k < with.left.spread.size(); ++k) {
        if (!(with.left.count[k] >= 2)) continue;
        EXPECT_LT(without.left.spread[k], 1e-4);
        EXPECT_GT(with.left.spread[k], 1e-3);  // σ_h ≈ σ_r·h/r: millimetres to centimetres
        ++compared;
    }
    EXPECT_GT(compared, 20u);
    f.range_variances.pop_back();
    EXPECT_THROW(noisy.process(f, 5.0, 0.0), std::invalid_argument);
}

TEST(StereoPoints, PipelineGivesASinglePointBinItsOwnStatedSigma) {
    // Every 40th column of a flat ground: far bins hold one point. With range variances such a bin states its
    // point's σ (the roughness stage would otherwise give it a pool of the other bins' spreads); without, none.
    const rp::Config cfg = flat_ground_config();
    const rp::StereoPoints p = flat_ground_points(40);
    rp::Frame f;
    f.points = p.points;
    const rp::Result without = rp::Estimator(cfg).process(f, 5.0, 0.0);
    f.range_variances = p.range_variances;
    const rp::Result with = rp::Estimator(cfg).process(f, 5.0, 0.0);
    std::size_t single = 0;
    for (auto [stated, plain] : {std::pair{&with.left, &without.left}, std::pair{&with.right, &without.right}}) {
        for (std::size_t k = 0; k < stated->spread.size(); ++k) {
            if (stated->count[k] != 1) continue;
            EXPECT_TRUE(std::isnan(plain->spread[k]));
            EXPECT_GT(stated->spread[k], 1e-3) << "bin " << k;
            ++single;
        }
    }
    EXPECT_GT(single, 5u);
}

TEST(StereoPoints, PipelineCountsEachErrorGroupOnce) {
    // The same noisy ground with and without error groups: the heights agree; with all points in one group a
    // bin's spread is √count times larger (its median is as uncertain as one point), with a group per point equal.
    const rp::Config cfg = flat_ground_config();
    const rp::StereoPoints p = flat_ground_points(1, 0.2f);
    rp::Frame f;
    f.points = p.points;
    f.range_variances = p.range_variances;
    const rp::Result alone = rp::Estimator(cfg).process(f, 5.0, 0.0);
    f.error_groups.assign(p.pixels.size(), 7);
    const rp::Result one = rp::Estimator(cfg).process(f, 5.0, 0.0);
    f.error_groups = p.pixels;
    const rp::Result each = rp::Estimator(cfg).process(f, 5.0, 0.0);
    std::size_t compared = 0;
    for (std::size_t k = 0; k < alone.left.spread.size(); ++k) {
        if (!(alone.left.count[k] >= 2)) continue;
        EXPECT_DOUBLE_EQ(one.left.z[k], alone.left.z[k]);
        EXPECT_NEAR(one.left.spread[k], alone.left.spread[k] * std::sqrt(alone.left.count[k]), 1e-9);
        EXPECT_DOUBLE_EQ(each.left.spread[k], alone.left.spread[k]);
        ++compared;
    }
    EXPECT_GT(compared, 20u);
    f.error_groups.pop_back();
    try {
        rp::Estimator(cfg).process(f, 5.0, 0.0);
        ADD_FAILURE() << "error groups for all but one point were accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("error groups for"), std::string::npos) << e.what();
    }
}
