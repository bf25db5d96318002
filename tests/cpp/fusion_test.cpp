// Temporal fusion (docs/method.md §7): the rolling map, ego-motion, the fusion rules and their robustness.
#include <gtest/gtest.h>

#include <Eigen/QR>

#include <cmath>
#include <random>

#include "scenes.hpp"

namespace rp = roadpreview;

namespace {

// The road of the static scenes: a 5 m swell across the whole width, in the odometry frame.
double road_height(double x) { return 0.03 * std::sin(2.0 * M_PI * x / 5.0); }

// One frame of noisy points on that road seen from `pose` (base frame points), |y| ≤ 3 m, 1 ≤ x ≤ 40 m; like a
// LiDAR's, their density falls with range (x log-uniform: density ∝ 1/x).
scenes::Cloud road_frame(const rp::Pose2& pose, int n, double noise_m, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> log_x(0.0, std::log(40.0)), uy(-3.0, 3.0);
    std::normal_distribution<double> gauss(0.0, noise_m);
    scenes::Cloud pts(n, 3);
    const double c = std::cos(pose.yaw_rad), s = std::sin(pose.yaw_rad);
    for (int i = 0; i < n; ++i) {
        const double x = std::exp(log_x(rng)), y = uy(rng);
        pts.row(i) << float(x), float(y), float(road_height(pose.x_m + c * x - s * y) + gauss(rng));
    }
    return pts;
}

rp::Config fusion_config(rp::FusionMethod method, double alpha = 0.5) {
    rp::Config cfg;
    cfg.fusion.method = method;
    cfg.fusion.alpha = alpha;
    cfg.profile.level = false;  // the swell tilts the plane fit a little; these tests check the fusion alone
    cfg.obstacles.enabled = false;
    return cfg;
}

// RMSE of a straight-ahead profile against the road, over the bins 0 ≤ s < length that have a height.
double profile_rmse(const rp::Profile& p, double x0, double length) {
    double squares = 0.0;
    int n = 0;
    for (std::size_t k = 0; k < p.z.size(); ++k)
        if (p.s[k] >= 0.0 && p.s[k] < length && std::isfinite(p.z[k]))
            squares += std::pow(p.z[k] - road_height(x0 + p.s[k]), 2), ++n;
    return n ? std::sqrt(squares / n) : NAN;
}

double backed_fraction(const rp::Profile& p, double length) {
    int backed = 0, bins = 0;
    for (std::size_t k = 0; k < p.z.size(); ++k)
        if (p.s[k] >= 0.0 && p.s[k] < length) ++bins, backed += p.count[k] > 0;
    return double(backed) / bins;
}

// Drives straight at `speed` for `frames` frames of 10 Hz; returns the last result.
rp::Result drive(rp::Estimator& est, double speed, int frames, int points, double noise, double t0 = 0.0) {
    rp::Result r;
    rp::Pose2 pose;
    for (int f = 0; f < frames; ++f) {
        pose.x_m = speed * 0.1 * f;
        const auto cloud = road_frame(pose, points, noise, 100u + unsigned(f));
        r = est.process(cloud, speed, 0.0, "", rp::FrameMotion{t0 + 0.1 * f, std::nullopt});
    }
    return r;
}

// Fuses `cloud` (base frame, already levelled, every point ground) at `pose` into `fusion`.
void fuse_at(rp::TemporalFusion& fusion, const scenes::Cloud& cloud, const rp::Pose2& pose, double t) {
    rp::FusionStatus status;
    fusion.advance(1.0, 0.0, {t, pose}, status);
    fusion.fuse(rp::points_view(cloud.data(), cloud.rows(), 3), std::vector<std::uint8_t>(cloud.rows(), 1),
                rp::levelling_for(nullptr));
}

// Points on the flat ground z = `z`, four per 0.1 m cell, over x in [x0, x1), |y| < y_abs, with Gaussian noise.
scenes::Cloud flat_patch(double x0, double x1, double y_abs, double z, double noise_m, unsigned seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> gauss(0.0, 1.0);
    std::vector<Eigen::Vector3d> pts;
    for (double x = x0 + 0.025; x < x1; x += 0.05)
        for (double y = -y_abs + 0.025; y < y_abs; y += 0.05) pts.emplace_back(x, y, z + noise_m * gauss(rng));
    scenes::Cloud cloud(static_cast<Eigen::Index>(pts.size()), 3);
    for (std::size_t i = 0; i < pts.size(); ++i) cloud.row(static_cast<Eigen::Index>(i)) = pts[i].cast<float>().transpose();
    return cloud;
}

}  // namespace

TEST(ElevationMap, MovingKeepsCellsAtTheirPlaceAndForgetsThoseThatLeave) {
    rp::ElevationMap map(0.1, 20.0);
    ASSERT_EQ(map.side(), 200);
    map.at(3.05, -2.05)->height = 1.5f;
    map.at(3.05, -2.05)->observations = 1;
    map.move_to(7.3, 4.1);  // the cell is still inside the window: same place, same value
    ASSERT_NE(map.at(3.05, -2.05), nullptr);
    EXPECT_EQ(map.at(3.05, -2.05)->height, 1.5f);
    EXPECT_EQ(map.at(3.05, -2.05)->observations, 1);
    EXPECT_EQ(map.at(-7.0, 0.0), nullptr);  // left the window
    map.move_to(16.0, 0.0);                 // the cell leaves the window...
    EXPECT_EQ(map.at(3.05, -2.05), nullptr);
    map.move_to(0.0, 0.0);  // ...and comes back empty
    EXPECT_EQ(map.at(3.05, -2.05)->observations, 0);
}

TEST(ElevationMap, DefaultsCoverThePreviewAndDocumentTheirMemory) {
    const rp::Config cfg;
    rp::ElevationMap map(cfg.fusion.cell_m, cfg.fusion.map_length_m);
    EXPECT_EQ(map.side(), 1000);
    EXPECT_EQ(map.bytes(), 1000u * 1000u * sizeof(rp::MapCell));
    EXPECT_EQ(sizeof(rp::MapCell), 28u);  // docs/method.md §7 quotes 28 MB
}

TEST(Motion, IntegratesArcsAndLines) {
    const rp::Pose2 line = rp::integrate_motion({1.0, 2.0, M_PI / 2}, 5.0, 0.0, 0.5);
    EXPECT_NEAR(line.x_m, 1.0, 1e-12);
    EXPECT_NEAR(line.y_m, 4.5, 1e-12);
    rp::Pose2 p;  // a full circle of radius 10 m in 40 steps comes back to the start
    const double w = 0.5, v = 5.0, dt = 2.0 * M_PI / w / 40.0;
    for (int i = 0; i < 40; ++i) p = rp::integrate_motion(p, v, w, dt);
    EXPECT_NEAR(p.x_m, 0.0, 1e-9);
    EXPECT_NEAR(p.y_m, 0.0, 1e-9);
    const rp::Pose2 quarter = rp::integrate_motion({}, v, w, M_PI / 2 / w);
    EXPECT_NEAR(quarter.x_m, 10.0, 1e-9);  // a left quarter turn of radius 10 m
    EXPECT_NEAR(quarter.y_m, 10.0, 1e-9);
    const double kitti[12] = {0, -1, 0, 3, 1, 0, 0, 4, 0, 0, 1, 0};
    const rp::Pose2 from_matrix = rp::pose_from_matrix(kitti);
    EXPECT_DOUBLE_EQ(from_matrix.x_m, 3.0);
    EXPECT_DOUBLE_EQ(from_matrix.y_m, 4.0);
    EXPECT_DOUBLE_EQ(from_matrix.yaw_rad, M_PI / 2);
}

TEST(Fusion, EmaWithAlphaOneEqualsTheSingleFrameMap) {
    rp::Config cfg = fusion_config(rp::FusionMethod::Ema, 1.0);
    cfg.fusion.align = false;  // with it, the frame would first be moved onto the map by a plane
    rp::TemporalFusion fused(cfg), single(cfg);
    rp::FusionStatus status;
    const rp::Levelling L = rp::levelling_for(nullptr);
    const auto first = road_frame({}, 20000, 0.02, 1), second = road_frame({0.8, 0.0, 0.0}, 20000, 0.02, 2);
    const std::vector<std::uint8_t> all(20000, 1);
    fused.advance(8.0, 0.0, {0.0, std::nullopt}, status);
    fused.fuse(rp::points_view(first.data(), first.rows(), 3), all, L);
    fused.advance(8.0, 0.0, {0.1, std::nullopt}, status);
    fused.fuse(rp::points_view(second.data(), second.rows(), 3), all, L);
    single.advance(0.0, 0.0, {0.0, rp::Pose2{0.8, 0.0, 0.0}}, status);
    single.fuse(rp::points_view(second.data(), second.rows(), 3), all, L);
    int compared = 0;
    for (double x = 2.0; x < 40.0; x += 0.1)
        for (double y = -2.95; y < 3.0; y += 0.1) {
            const rp::MapCell* one = single.map().at(x, y);
            if (!one || one->observations == 0) continue;
            EXPECT_EQ(fused.map().at(x, y)->height, one->height);
            ++compared;
        }
    EXPECT_GT(compared, 10000);
}

TEST(Fusion, StaticSceneWithExactMotionConvergesToTheTruth) {
    for (const auto method : {rp::FusionMethod::Ema, rp::FusionMethod::Kalman}) {
        rp::Estimator single(fusion_config(rp::FusionMethod::None)), est(fusion_config(method, 0.3));
        const double speed = 8.0, noise = 0.02;
        const rp::Result fused = drive(est, speed, 10, 15000, noise);
        const double x0 = speed * 0.9;
        const auto cloud = road_frame({x0, 0.0, 0.0}, 15000, noise, 109u);
        const rp::Result one = single.process(cloud, speed, 0.0);
        ASSERT_TRUE(fused.fusion);
        EXPECT_EQ(fused.fusion->frames, 10);
        EXPECT_NEAR(fused.fusion->pose.x_m, x0, 1e-9);
        EXPECT_GT(backed_fraction(fused.left, 30.0), 0.99);
        EXPECT_LT(backed_fraction(one.left, 30.0), 0.9);
        EXPECT_GT(fused.fusion->coverage, 0.95);
        EXPECT_LT(fused.fusion->frame_coverage, fused.fusion->coverage);
        const double rmse_fused = profile_rmse(fused.left, x0, 30.0), rmse_single = profile_rmse(one.left, x0, 30.0);
        std::printf("%s: coverage %.3f (frame %.3f, single %.3f), RMSE fused %.4f single %.4f m\n", rp::to_string(method),
                    fused.fusion->coverage, fused.fusion->frame_coverage, backed_fraction(one.left, 30.0), rmse_fused,
                    rmse_single);
        EXPECT_LE(rmse_fused, 0.01) << rp::to_string(method);  // the target
        EXPECT_LT(rmse_fused, 0.6 * rmse_single) << rp::to_string(method);
    }
}

TEST(Fusion, ProfilesBehindTheWheelsReadTheDrivenRoad) {
    rp::Config cfg = fusion_config(rp::FusionMethod::Kalman);
    cfg.fusion.behind_m = 5.0;
    rp::Estimator est(cfg);
    const rp::Result r = drive(est, 8.0, 10, 60000, 0.02);
    ASSERT_EQ(r.left.z.size(), 450u);
    EXPECT_NEAR(r.left.s0, -4.95, 1e-12);
    double squares = 0.0;
    for (std::size_t k = 0; k < 50; ++k) {
        ASSERT_TRUE(std::isfinite(r.left.z[k]));
        squares += std::pow(r.left.z[k] - road_height(7.2 + r.left.s[k]), 2);
    }
    EXPECT_LT(std::sqrt(squares / 50), 0.01);
}

TEST(Fusion, ALargeTimeGapResetsTheMapAndSaysSo) {
    rp::Estimator est(fusion_config(rp::FusionMethod::Ema));
    drive(est, 8.0, 5, 20000, 0.02);
    const auto cloud = road_frame({}, 20000, 0.02, 7);
    const rp::Result gap = est.process(cloud, 8.0, 0.0, "", rp::FrameMotion{5.0, std::nullopt});
    ASSERT_TRUE(gap.fusion);
    EXPECT_EQ(gap.fusion->reset, "time gap of 4.600 s");
    EXPECT_EQ(gap.fusion->frames, 1);  // only this frame
    const rp::Result back = est.process(cloud, 8.0, 0.0, "", rp::FrameMotion{4.0, std::nullopt});
    EXPECT_EQ(back.fusion->reset, "time went back by 1.000 s");
    const rp::Result next = est.process(cloud, 0.0, 0.0, "", rp::FrameMotion{4.1, std::nullopt});
    EXPECT_EQ(next.fusion->reset, "");
    est.reset();
    const rp::Result after_reset = est.process(cloud, 8.0, 0.0, "", rp::FrameMotion{100.0, std::nullopt});
    EXPECT_EQ(after_reset.fusion->reset, "");  // reset() forgot the clock: no gap to report
    EXPECT_EQ(after_reset.fusion->frames, 1);
}

// A given pose 150 m from the last (another origin, a GNSS jump) leaves the 100 m map behind: it was cleared
// silently and `frames` went on counting.
TEST(Fusion, APoseThatJumpsPastTheMapClearsItAndSaysSo) {
    rp::Estimator est(fusion_config(rp::FusionMethod::Ema));
    const auto cloud = road_frame({}, 20000, 0.02, 7);
    const auto at = [&](double x) {
        return *est.process(cloud, 5.0, 0.0, "", rp::FrameMotion{std::nullopt, rp::Pose2{x, 0.0, 0.0}}).fusion;
    };
    EXPECT_EQ(at(0.0).frames, 1);
    const rp::FusionStatus near = at(0.5);
    EXPECT_EQ(near.frames, 2);
    EXPECT_EQ(near.reset, "");
    const rp::FusionStatus far = at(150.0);
    EXPECT_EQ(far.reset, "moved beyond the map");
    EXPECT_EQ(far.frames, 1);  // this frame only
    EXPECT_EQ(at(150.5).frames, 2);
}

// dt is the difference of consecutive frames' timestamps, 1/frame_rate_hz when one is missing: a frame without one
// between two with them moved the vehicle by the timestamps' whole step again (0.75 m for 0.5 at 2.5 m/s, 10 Hz).
TEST(Fusion, AFrameWithoutATimestampMovesTheVehicleByOneFrameInterval) {
    rp::Estimator est(fusion_config(rp::FusionMethod::Ema));
    const auto cloud = road_frame({}, 20000, 0.02, 7);
    const auto pose_x = [&](std::optional<double> t) {
        return est.process(cloud, 2.5, 0.0, "", rp::FrameMotion{t, std::nullopt}).fusion->pose.x_m;
    };
    EXPECT_EQ(pose_x(10.0), 0.0);
    EXPECT_NEAR(pose_x(std::nullopt), 0.25, 1e-12);
    EXPECT_NEAR(pose_x(10.2), 0.5, 1e-12);   // 1/frame_rate_hz again: the previous frame had no timestamp
    EXPECT_NEAR(pose_x(10.4), 1.0, 1e-12);   // both timestamped: 0.2 s
}

TEST(Fusion, NoGroundStopsAndReversalsDoNotCorruptTheMap) {
    rp::Estimator est(fusion_config(rp::FusionMethod::Kalman));
    const rp::Result before = drive(est, 8.0, 10, 60000, 0.02);
    const double x0 = 7.2;
    double t = 1.0;
    const scenes::Cloud empty(0, 3);
    const rp::Result no_ground = est.process(empty, 8.0, 0.0, "", rp::FrameMotion{t, std::nullopt});
    EXPECT_EQ(no_ground.status, rp::FrameStatus::Ok);  // the map stands in for the frame: profiles from it, at the moved pose
    EXPECT_EQ(no_ground.fusion->frames, 10);
    EXPECT_EQ(no_ground.fusion->frame_coverage, 0.0);
    EXPECT_FALSE(no_ground.plane);
    EXPECT_LT(profile_rmse(no_ground.left, x0 + 0.8, 30.0), 0.006);
    EXPECT_GT(backed_fraction(no_ground.left, 10.0), 0.9);
    double x = x0 + 0.8;
    for (int i = 0; i < 30; ++i) {  // stopped for 3 s: the map holds
        t += 0.1;
        const rp::Result r = est.process(road_frame({x, 0, 0}, 20000, 0.05, 500u + unsigned(i)), 0.0, 0.0, "",
                                         rp::FrameMotion{t, std::nullopt});
        EXPECT_EQ(r.fusion->frames, 10);
        EXPECT_NEAR(r.fusion->pose.x_m, x, 1e-9);
    }
    for (int i = 0; i < 5; ++i) {  // backing up 2 m: the points land where they belong
        t += 0.1;
        x -= 0.4;
        est.process(road_frame({x, 0, 0}, 60000, 0.02, 600u + unsigned(i)), -4.0, 0.0, "", rp::FrameMotion{t, std::nullopt});
    }
    t += 0.1;
    const rp::Result after = est.process(road_frame({x, 0, 0}, 60000, 0.02, 700u), 0.0001, 0.0, "",
                                         rp::FrameMotion{t, std::nullopt});
    EXPECT_NEAR(after.fusion->pose.x_m, x + 0.00001, 1e-9);
    EXPECT_LT(profile_rmse(after.left, x + 0.00001, 30.0), 0.006);
    EXPECT_LT(profile_rmse(before.left, x0, 30.0), 0.006);
}

TEST(Fusion, AFrameWithoutGroundOnAnEmptyMapHasNoProfiles) {
    rp::Estimator est(fusion_config(rp::FusionMethod::Kalman));
    const scenes::Cloud empty(0, 3);
    EXPECT_EQ(est.process(empty, 8.0, 0.0, "", rp::FrameMotion{0.0, std::nullopt}).status, rp::FrameStatus::NoFinitePoints);
    scenes::Cloud far(10, 3);  // points, but none in the region of interest
    for (int i = 0; i < 10; ++i) far.row(i) << 100.0f, float(i), 0.0f;
    const rp::Result r = est.process(far, 8.0, 0.0, "", rp::FrameMotion{0.1, std::nullopt});
    EXPECT_FALSE(r.plane);
    EXPECT_EQ(r.status, rp::FrameStatus::NoRoiPoints);
    EXPECT_TRUE(r.left.z.empty());
}

TEST(Fusion, NoneKeepsTheSingleFramePipeline) {
    rp::Config cfg = fusion_config(rp::FusionMethod::None);
    rp::Estimator est(cfg);
    const auto cloud = road_frame({}, 20000, 0.02, 3);
    const rp::Result r = est.process(cloud, 8.0, 0.0, "", rp::FrameMotion{1.5, std::nullopt});
    EXPECT_FALSE(r.fusion);
    EXPECT_EQ(r.timestamp, 1.5);
    EXPECT_EQ(rp::result_to_json(r).find("\"fusion\":null") != std::string::npos, true);
}

// A level road that starts rising 3 % at odometry x = 25 m, seen from (x_v, 0, 0): base-frame points every 0.1 m over
// 1 ≤ x < 40, |y| < 3 m.
scenes::Cloud grade_frame(double x_v) {
    std::vector<Eigen::Vector3f> pts;
    for (double x = 1.0; x < 40.0; x += 0.1)
        for (double y = -3.0; y < 3.0; y += 0.1)
            pts.emplace_back(float(x), float(y), float(0.03 * std::max(x_v + x - 25.0, 0.0)));
    scenes::Cloud cloud(static_cast<Eigen::Index>(pts.size()), 3);
    for (std::size_t i = 0; i < pts.size(); ++i) cloud.row(static_cast<Eigen::Index>(i)) = pts[i].transpose();
    return cloud;
}

TEST(Fusion, ProfilesAreReadAboveTheLocalGroundSoAGradeChangeIsNotRelief) {
    // As a single frame's (method.md §3): the kink, 15.5 m ahead in the last frame, lies mid-band, and the band's plane
    // leaves ±Δg·L/8 = ±3.75 cm of it; one plane, decimetres. Behind the wheels, on the road driven (seen by the
    // earlier frames), the nearest band's plane alone: the band beyond it lies ahead, over the kink.
    for (const bool local : {true, false}) {
        rp::Config cfg;
        cfg.fusion.method = rp::FusionMethod::Kalman;
        cfg.fusion.behind_m = 8.0;
        cfg.obstacles.enabled = false;
        cfg.profile.level_local = local;
        rp::Estimator est(cfg);
        rp::Result r;
        for (int f = 0; f < 20; ++f)
            r = est.process(grade_frame(0.5 * f), 5.0, 0.0, "", rp::FrameMotion{0.1 * f, std::nullopt});
        double lo = INFINITY, hi = -INFINITY, behind = 0.0;
        int behind_bins = 0;
        for (std::size_t k = 0; k < r.left.z.size(); ++k) {
            if (!std::isfinite(r.left.z[k])) continue;
            if (r.left.s[k] < 0.0) behind = std::max(behind, std::abs(r.left.z[k])), ++behind_bins;
            else lo = std::min(lo, r.left.z[k]), hi = std::max(hi, r.left.z[k]);
        }
        ASSERT_LT(lo, hi);
        ASSERT_EQ(behind_bins, 80);
        if (local) {
            EXPECT_LT(hi - lo, 0.03 * 10.0 / 4 + 0.005);
            EXPECT_LT(behind, 0.002);  // the road behind is level, as is the nearest band
        } else {
            EXPECT_GT(hi - lo, 0.2);
        }
    }
}

TEST(Fusion, AlignmentRemovesEachFramesHeaveAndTilt) {
    // Every frame carries its own height offset and pitch (what a per-frame plane fit leaves on long waves).
    for (const bool align : {true, false}) {
        rp::Config cfg = fusion_config(rp::FusionMethod::Kalman);
        cfg.fusion.align = align;
        rp::Estimator est(cfg);
        rp::Result r;
        for (int f = 0; f < 10; ++f) {
            const rp::Pose2 pose{0.8 * f, 0.0, 0.0};
            scenes::Cloud cloud = road_frame(pose, 15000, 0.01, 300u + unsigned(f));
            const double heave = 0.02 * std::sin(1.3 * f), pitch = 0.002 * std::cos(0.9 * f);
            for (Eigen::Index i = 0; i < cloud.rows(); ++i) cloud(i, 2) += float(heave + pitch * cloud(i, 0));
            r = est.process(cloud, 8.0, 0.0, "", rp::FrameMotion{0.1 * f, std::nullopt});
        }
        // The map follows the first frame's offset and tilt (heave 0, pitch 0.002); the last frame's view of
        // the road differs from that by a plane, so compare shapes: the RMSE about the best line.
        const rp::Profile& p = r.left;
        std::vector<double> s, e;
        for (std::size_t k = 0; k < p.z.size(); ++k)
            if (p.s[k] < 30.0 && std::isfinite(p.z[k])) s.push_back(p.s[k]), e.push_back(p.z[k] - road_height(7.2 + p.s[k]));
        Eigen::MatrixXd A(s.size(), 2);
        Eigen::VectorXd b(s.size());
        for (std::size_t k = 0; k < s.size(); ++k) A(k, 0) = 1.0, A(k, 1) = s[k], b(k) = e[k];
        const Eigen::VectorXd line = A.colPivHouseholderQr().solve(b);
        const double rms = std::sqrt((b - A * line).squaredNorm() / double(s.size()));
        std::printf("align %d: detrended RMSE %.4f m\n", align, rms);
        if (align) EXPECT_LT(rms, 0.005);
        else EXPECT_GT(rms, 0.006);
    }
}

TEST(Fusion, AFewSharedCellsAlongOneRingFixTheOffsetButDoNotTiltTheFrame) {
    // The map knows the flat road up to 12 m. The next frame sees it 4 cm higher (its plane fit's offset), but
    // shares with the map only the cells of one ring 10 m ahead — like a VLP-16's — and brings new cells
    // 20–30 m ahead. The ring fixes the offset; its slope along x (the ring's curvature only) is noise.
    for (const double tilt_sigma : {1e-4, 1e3}) {
        rp::Config cfg = fusion_config(rp::FusionMethod::Kalman);
        cfg.fusion.align_tilt_sigma = tilt_sigma;
        rp::TemporalFusion fusion(cfg);
        fuse_at(fusion, flat_patch(1.0, 12.0, 3.0, 0.0, 0.005, 1), {}, 0.0);
        std::mt19937 rng(2);
        std::normal_distribution<double> gauss(0.0, 0.005);
        std::vector<Eigen::Vector3d> pts;
        for (double y = -3.0; y < 3.0; y += 0.02) pts.emplace_back(std::sqrt(100.0 - y * y), y, 0.04 + gauss(rng));
        const scenes::Cloud far = flat_patch(20.0, 30.0, 1.0, 0.04, 0.005, 3);
        scenes::Cloud frame(static_cast<Eigen::Index>(pts.size()) + far.rows(), 3);
        for (std::size_t i = 0; i < pts.size(); ++i) frame.row(static_cast<Eigen::Index>(i)) = pts[i].cast<float>().transpose();
        frame.bottomRows(far.rows()) = far;
        fuse_at(fusion, frame, {}, 0.1);
        double sum = 0.0;  // mean height of the far cells: their noise averages out, the frame's plane does not
        int cells = 0;
        for (double x = 20.05; x < 30.0; x += 0.1)
            for (double y = -0.95; y < 1.0; y += 0.1) sum += fusion.map().at(x, y)->height, ++cells;
        const double mean = sum / cells;
        std::printf("align_tilt_sigma %g: mean height 20-30 m ahead %.4f m\n", tilt_sigma, mean);
        if (tilt_sigma < 1.0) EXPECT_LT(std::abs(mean), 0.002);  // the offset is gone and nothing tilted
        else EXPECT_GT(std::abs(mean), 0.01);                     // a free fit tilts the far road by centimetres
    }
}

// A frame whose exact cells alternate ±1 cm in a checkerboard: disagreement with the map that no plane removes and
// no cell's spread shows (per-beam offsets, seams between frames).
scenes::Cloud checkerboard_patch(double x0, double x1, double y_abs, unsigned seed) {
    scenes::Cloud frame = flat_patch(x0, x1, y_abs, 0.0, 0.0, seed);
    for (Eigen::Index i = 0; i < frame.rows(); ++i) {
        const auto ix = static_cast<long>(std::floor(frame(i, 0) / 0.1));
        const auto iy = static_cast<long>(std::floor(frame(i, 1) / 0.1));
        frame(i, 2) = (ix + iy) % 2 ? 0.01f : -0.01f;
    }
    return frame;
}

TEST(Fusion, DisagreementBeyondTheVariancesIsTheSameAtEveryRangeAndHalfOfItIsTheFirstFramesToo) {
    // The map holds an exact flat road (one frame, never compared). The next frame disagrees with it by ±1 cm in
    // every cell at every range: 1e-4 m² beyond the variances, which the two frames share. Each frame's cells
    // get half of it, at every range: the frame's new cells 12 and 14 m ahead alike (growing with range, as
    // a·d², they got 4-6 times that before), and the map's cells the next frame did not see again.
    rp::TemporalFusion fusion(fusion_config(rp::FusionMethod::Kalman));
    fuse_at(fusion, flat_patch(1.0, 10.0, 2.0, 0.0, 0.0, 1), {}, 0.0);
    fuse_at(fusion, checkerboard_patch(1.0, 15.0, 1.0, 2), {}, 0.1);
    const double half = 0.5e-4;
    for (const double x : {12.05, 14.05}) {
        const rp::MapCell* fresh = fusion.map().at(x, 0.05);
        ASSERT_NE(fresh, nullptr);
        EXPECT_EQ(fresh->observations, 1);
        EXPECT_NEAR(fresh->variance, half, 0.02 * half) << x;
    }
    EXPECT_NEAR(fusion.map().at(5.05, 1.55)->variance, half, 0.02 * half);        // the first frame's alone
    EXPECT_NEAR(fusion.map().at(5.05, 0.05)->variance, half / 2, 0.02 * half);    // both frames, fused
}

TEST(Fusion, OnceTheMapCarriesItsShareTheWholeExcessIsTheNewFrames) {
    // A second exact frame agrees with the first (no excess, but the map has now been compared); the third
    // disagrees by ±1 cm: all of its 1e-4 m² is the third frame's.
    rp::TemporalFusion fusion(fusion_config(rp::FusionMethod::Kalman));
    fuse_at(fusion, flat_patch(1.0, 10.0, 2.0, 0.0, 0.0, 1), {}, 0.0);
    fuse_at(fusion, flat_patch(1.0, 10.0, 2.0, 0.0, 0.0, 2), {}, 0.1);
    EXPECT_LT(fusion.map().at(5.05, 0.05)->variance, 1e-9);
    fuse_at(fusion, checkerboard_patch(1.0, 15.0, 1.0, 3), {}, 0.2);
    EXPECT_NEAR(fusion.map().at(12.05, 0.05)->variance, 1e-4, 2e-6);
    EXPECT_LT(fusion.map().at(5.05, 1.55)->variance, 1e-9);  // the map's own cells keep their variance
}

TEST(Fusion, CellsFarOffTheAlignmentPlaneLeaveItAndKeepTheirDisagreement) {
    // The next frame sees the flat road 3 cm higher, except a strip along y ∈ [1.5, 2) m 15 cm higher (the foot
    // of a wall counts as ground up to 0.2 m). The strip must neither shift nor tilt the rest of the frame,
    // and its cells must enter the map with their disagreement as variance.
    rp::TemporalFusion fusion(fusion_config(rp::FusionMethod::Kalman));
    fuse_at(fusion, flat_patch(1.0, 10.0, 2.0, 0.0, 0.001, 1), {}, 0.0);
    scenes::Cloud frame = flat_patch(1.0, 10.0, 2.0, 0.03, 0.001, 2);
    for (Eigen::Index i = 0; i < frame.rows(); ++i)
        if (frame(i, 1) >= 1.5f) frame(i, 2) += 0.15f;
    fuse_at(fusion, frame, {}, 0.1);
    for (double x : {1.55, 5.05, 9.55})
        for (double y : {-1.95, 0.05, 1.35}) EXPECT_NEAR(fusion.map().at(x, y)->height, 0.0, 0.002) << x << ", " << y;
    // The strip's cells enter with their 15 cm disagreement as variance: the map's confident heights barely move
    // (fused without the outlier variance, they would move by half of it), and stay confident (the map's variance
    // there stays that of its earlier frame: 4e-7 m², road cells 2e-7).
    EXPECT_NEAR(fusion.map().at(5.05, 1.75)->height, 0.0, 0.002);
}

TEST(Fusion, TheFootOfAWallDoesNotInflateTheNoiseOfSinglePoints) {
    // One frame on an empty map: cells of four points spread 1 cm, a strip of cells spread 10 cm (a wall's
    // foot), and a single point in the same 5 m band of range. A single point's variance is the pooled variance
    // of the road cells (~1e-4 m²), not of the strip.
    std::mt19937 rng(7);
    std::normal_distribution<double> road(0.0, 0.01), foot(0.0, 0.1);
    std::vector<Eigen::Vector3d> pts;
    for (double x = 1.025; x < 10.0; x += 0.05)
        for (double y = -1.975; y < 2.0; y += 0.05) pts.emplace_back(x, y, y > 1.5 ? foot(rng) : road(rng));
    pts.emplace_back(7.05, -2.45, 0.0);  // alone in its cell
    scenes::Cloud cloud(static_cast<Eigen::Index>(pts.size()), 3);
    for (std::size_t i = 0; i < pts.size(); ++i) cloud.row(static_cast<Eigen::Index>(i)) = pts[i].cast<float>().transpose();
    rp::TemporalFusion fusion(fusion_config(rp::FusionMethod::Kalman));
    fuse_at(fusion, cloud, {}, 0.0);
    EXPECT_NEAR(fusion.map().at(7.05, -2.45)->variance, 1e-4, 1e-5);
}

// A frame of cells of two points: near (x < 10 m) spread 1 cm, far (20–25 m) spread 2 mm, as range noise along
// rays leaning ever flatter gives them; plus single points near and far.
scenes::Cloud near_and_far_cells() {
    std::mt19937 rng(11);
    std::normal_distribution<double> gauss(0.0, 1.0);
    std::vector<Eigen::Vector3d> pts;
    for (double x = 2.05; x < 25.0; x += 0.1) {
        if (x > 10.0 && x < 20.0) continue;
        const double sigma = x < 10.0 ? 0.01 : 0.002;
        for (double y = -0.95; y < 1.0; y += 0.1)
            for (double dy : {-0.02, 0.02}) pts.emplace_back(x, y + dy, sigma * gauss(rng));
    }
    pts.emplace_back(5.05, 1.55, 0.0);   // alone in their cells
    pts.emplace_back(22.05, 1.55, 0.0);
    pts.emplace_back(15.05, 1.55, 0.0);  // in a band with no cell of two points: the nearest band below lends
    scenes::Cloud cloud(static_cast<Eigen::Index>(pts.size()), 3);
    for (std::size_t i = 0; i < pts.size(); ++i) cloud.row(static_cast<Eigen::Index>(i)) = pts[i].cast<float>().transpose();
    return cloud;
}

TEST(Fusion, ASinglePointTakesThePooledVarianceOfItsOwnRangeBand) {
    rp::TemporalFusion fusion(fusion_config(rp::FusionMethod::Kalman));
    fuse_at(fusion, near_and_far_cells(), {}, 0.0);
    // Pooled over its 5 m band: (1 cm)² near, (2 mm)² far. One pool over the frame would give the far point
    // ~0.5e-4 m², 12× its noise.
    EXPECT_NEAR(fusion.map().at(5.05, 1.55)->variance, 1e-4, 2e-5);
    EXPECT_NEAR(fusion.map().at(22.05, 1.55)->variance, 4e-6, 1e-6);
    EXPECT_NEAR(fusion.map().at(15.05, 1.55)->variance, 1e-4, 2e-5);
}

TEST(Fusion, AWallsFootThatFillsAFarBandDoesNotSetItsPool) {
    // Near (2–10 m): road cells of four points spread 1 cm. Far (20–25 m): the road's cells hold one point each,
    // and the only cells of several points are a wall's foot, spread 10 cm: the band's own median. Its single
    // points take the near road's pool, not the foot's.
    std::mt19937 rng(5);
    std::normal_distribution<double> gauss(0.0, 1.0);
    std::vector<Eigen::Vector3d> pts;
    for (double x = 2.025; x < 10.0; x += 0.05)
        for (double y = -0.975; y < 1.0; y += 0.05) pts.emplace_back(x, y, 0.01 * gauss(rng));
    for (double x = 20.05; x < 25.0; x += 0.1) {
        pts.emplace_back(x, 0.05, 0.0);
        for (double dz : {-0.12, -0.04, 0.04, 0.12}) pts.emplace_back(x, 5.05, dz);  // the foot, 10 cm spread
    }
    scenes::Cloud cloud(static_cast<Eigen::Index>(pts.size()), 3);
    for (std::size_t i = 0; i < pts.size(); ++i) cloud.row(static_cast<Eigen::Index>(i)) = pts[i].cast<float>().transpose();
    rp::TemporalFusion fusion(fusion_config(rp::FusionMethod::Kalman));
    fuse_at(fusion, cloud, {}, 0.0);
    EXPECT_NEAR(fusion.map().at(22.05, 0.05)->variance, 1e-4, 2e-5);
}

TEST(Fusion, TwoPointsThatAgreeWeighNoMoreThanTheirBandAllows) {
    std::vector<Eigen::Vector3d> pts;
    for (double x = 2.05; x < 5.0; x += 0.1)
        for (double y = -0.95; y < 1.0; y += 0.1) pts.emplace_back(x, y - 0.02, 0.01), pts.emplace_back(x, y + 0.02, -0.01);
    pts.emplace_back(3.03, 1.55, 0.004), pts.emplace_back(3.07, 1.55, 0.004);  // spread 0
    scenes::Cloud cloud(static_cast<Eigen::Index>(pts.size()), 3);
    for (std::size_t i = 0; i < pts.size(); ++i) cloud.row(static_cast<Eigen::Index>(i)) = pts[i].cast<float>().transpose();
    rp::TemporalFusion fusion(fusion_config(rp::FusionMethod::Kalman));
    fuse_at(fusion, cloud, {}, 0.0);
    // The band's point variance is 2e-4 m² (pairs ±1 cm): the agreeing pair's median gets half of it, not 1e-12.
    EXPECT_NEAR(fusion.map().at(3.05, 1.55)->variance, 1e-4, 1e-6);
    EXPECT_NEAR(fusion.map().at(3.05, 0.05)->variance, 1e-4, 1e-6);
}

TEST(Fusion, ACellRemembersWhereInItItsPointsLay) {
    // Points at the near quarter of each 0.1 m cell (as a ring crosses it), then at its far quarter: the first
    // frame sets the offset, the second moves it by the Kalman gain, as it moves the height.
    rp::Config cfg = fusion_config(rp::FusionMethod::Kalman);
    cfg.fusion.align = false;
    rp::TemporalFusion fusion(cfg);
    const auto quarter = [](double at, double z) {
        scenes::Cloud cloud(4, 3);
        for (int i = 0; i < 4; ++i) cloud.row(i) << float(5.0 + at + 0.002 * i), float(0.05 + 0.002 * i), float(z);
        return cloud;
    };
    fuse_at(fusion, quarter(0.017, 0.01), {}, 0.0);
    const rp::MapCell* c = fusion.map().at(5.05, 0.05);
    ASSERT_TRUE(c && c->observations == 1);
    EXPECT_NEAR(c->dx, -0.03, 1e-6);  // mean x 5.02 in the cell [5.0, 5.1)
    EXPECT_NEAR(c->dy, 0.003, 1e-6);  // mean y 0.053 in [0.0, 0.1)
    const double p = c->variance;
    fuse_at(fusion, quarter(0.067, 0.03), {}, 0.1);
    ASSERT_EQ(c->observations, 2);
    const double gain = (c->height - 0.01) / (0.03 - 0.01);  // the height's Kalman gain
    EXPECT_GT(gain, 0.0);
    EXPECT_LT(gain, 1.0);
    EXPECT_NEAR(c->dx, -0.03 + gain * 0.05, 1e-6);
    EXPECT_LT(c->variance, p);
}

TEST(Fusion, RangeSamplesPlaceTheirCellByTheirWeightedMean) {
    rp::TemporalFusion fusion(fusion_config(rp::FusionMethod::Kalman));
    rp::FusionStatus status;
    fusion.advance(0.0, 0.0, {0.0, rp::Pose2{}}, status);
    // Two samples in the cell [2.0, 2.1) × [0.8, 0.9), the one at x = 2.01 four times the weight of the other.
    ASSERT_EQ(fusion.fuse_samples({{2.01, 0.85, 0.0, 1e-6}, {2.09, 0.85, 0.0, 4e-6}}), 1u);
    const rp::MapCell* c = fusion.map().at(2.05, 0.85);
    ASSERT_TRUE(c && c->observations == 1);
    EXPECT_NEAR(c->dx, (4 * 2.01 + 2.09) / 5 - 2.05, 1e-6);
    EXPECT_NEAR(c->dy, 0.0, 1e-6);
}
