// SPDX-License-Identifier: BSD-3-Clause
// The real-time API: process(..., Result& out) allocates nothing per frame once warm, and try_process reports
// errors as a Status with the throwing variant's message. Its own executable: it replaces the global allocator.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <roadpreview/roadpreview.hpp>

#include "roughness/roughness_scratch.hpp"
#include "scenes.hpp"

#include "counting_allocator.hpp"

namespace rp = roadpreview;

namespace {

const std::string kData = ROADPREVIEW_TEST_DATA;

// The three consecutive KITTI frames, driven again and again: frame k is frame k mod 3, 0.5 m further on.
std::vector<rp::Frame> kitti_frames() {
    std::vector<rp::Frame> frames;
    for (const char* name : {"000000.bin", "000001.bin", "000002.bin"})
        frames.push_back(rp::read_frame(kData + "/semantickitti/" + name));
    return frames;
}

rp::Config kitti_config(rp::FusionMethod fusion) {
    rp::Config cfg;
    cfg.sensor_height = 1.73;
    cfg.fusion.method = fusion;
    return cfg;
}

rp::FrameMotion motion_at(int k) {
    rp::FrameMotion m;
    m.timestamp_s = 0.1 * k;
    return m;
}

// Allocations of each of frames [first, last) after `first` warm-up frames, the same Result reused throughout.
std::vector<long> frame_allocations(const std::vector<rp::Frame>& frames, const rp::Config& cfg, int first, int last) {
    rp::Estimator est(cfg);
    rp::Result out;
    std::vector<long> counts;
    for (int k = 0; k < last; ++k) {
        const rp::Frame& f = frames[static_cast<std::size_t>(k) % frames.size()];
        const rp::FrameMotion motion = motion_at(k);
        on_frame(k);
        const long n = allocations_in([&] { est.process(f, 5.0, 0.02, motion, out); });
        if (k >= first) counts.push_back(n);
    }
    return counts;
}

void expect_no_allocations(const std::vector<long>& counts, int first) {
    for (std::size_t k = 0; k < counts.size(); ++k) EXPECT_EQ(counts[k], 0) << "frame " << k + first;
}

// A simulated road 1.73 m below the sensor: waves, a box on the left wheel's path, some NaN rows.
rp::Frame simulated_frame() {
    scenes::Cloud road = scenes::plane(0.0, 0.0, -1.73, 60000, 0.5, 45.0, 11.0);
    for (Eigen::Index i = 0; i < road.rows(); ++i) road(i, 2) += 0.02f * std::sin(1.5f * road(i, 0));
    const scenes::Cloud pts = scenes::concat(road, scenes::box(20.0, 0.8, 1.0, 1.0, 0.5, -1.73));
    rp::Frame f;
    f.source = "simulated";
    f.points.resize(pts.rows(), 4);
    f.points << pts, Eigen::MatrixXf::Zero(pts.rows(), 1);
    for (Eigen::Index i = 0; i < pts.rows(); i += 997) f.points(i, 1) = std::numeric_limits<float>::quiet_NaN();
    return f;
}

}  // namespace

// The counter sees what it must: operator new, and malloc as Eigen's aligned_allocator (PCL's clouds) calls it.
TEST(Realtime, TheCounterSeesOperatorNewAndMalloc) {
    EXPECT_EQ(allocations_in([] { std::vector<int> v(8); asm volatile("" : : "r"(v.data()) : "memory"); }), 1);
    if (!kCountsMalloc) GTEST_SKIP() << "malloc is AddressSanitizer's to count";
    EXPECT_EQ(allocations_in([] {
                  std::vector<float, Eigen::aligned_allocator<float>> v(100);
                  asm volatile("" : : "r"(v.data()) : "memory");
              }),
              1);
    void* (*volatile allocate_bytes)(std::size_t) = std::malloc;  // called through a pointer: not elided
    void* p = nullptr;
    EXPECT_EQ(allocations_in([&] { p = allocate_bytes(64); }), 1);
    std::free(p);
}

// Planned ahead (twiddles, factors, buffers), the FFT of every stretch length allocates nothing at its first
// transform either — prime lengths included, whose transforms use the generic butterfly's buffer.
TEST(Realtime, PlannedFftsTransformEveryLengthWithoutAllocating) {
    constexpr std::size_t kBins = 450;
    rp::RoughnessScratch s;
    s.plan_ffts(kBins);
    rp::Spectrum sp;
    sp.n.reserve(kBins / 2 + 1);
    sp.psd.reserve(kBins / 2 + 1);
    std::vector<double> z(kBins);
    for (std::size_t j = 0; j < kBins; ++j) z[j] = std::sin(0.3 * static_cast<double>(j)) + 0.01 * static_cast<double>(j);
    for (std::size_t n = 2; n <= kBins; ++n)
        EXPECT_EQ(allocations_in([&] { rp::displacement_psd(z.data(), n, 0.1, s, sp); }), 0) << n << " bins";
}

TEST(Realtime, KittiFramesAllocateNothingOnceWarmWithKalmanFusionAndObstacles) {
    expect_no_allocations(frame_allocations(kitti_frames(), kitti_config(rp::FusionMethod::Kalman), 5, 20), 5);
}

TEST(Realtime, KittiFramesAllocateNothingOnceWarmWithTheDefaultPipeline) {  // zones, obstacles on, no fusion
    expect_no_allocations(frame_allocations(kitti_frames(), kitti_config(rp::FusionMethod::None), 5, 20), 5);
}

TEST(Realtime, KittiFramesAllocateNothingOnceWarmOnTwoThreads) {  // the zones' buffers, one set per thread
    rp::Config cfg = kitti_config(rp::FusionMethod::Kalman);
    cfg.threads = 2;
    expect_no_allocations(frame_allocations(kitti_frames(), cfg, 5, 20), 5);
}

// A frame on several threads gives the answer of one, bit for bit: the crop's runs of rows, the zones' azimuth
// groups and the obstacles beside the profiles (or the map) only share out work whose results do not depend on
// its order.
TEST(Realtime, ThreadsDoNotChangeTheResult) {
    const std::vector<rp::Frame> frames = kitti_frames();
    for (const rp::FusionMethod fusion : {rp::FusionMethod::None, rp::FusionMethod::Kalman}) {
        std::vector<rp::Estimator> estimators;
        for (const int threads : {1, 2, 3}) {
            rp::Config cfg = kitti_config(fusion);
            cfg.threads = threads;
            estimators.emplace_back(cfg);
        }
        for (int k = 0; k < 6; ++k) {
            const rp::Frame& f = frames[static_cast<std::size_t>(k) % frames.size()];
            std::vector<rp::Result> results;
            for (rp::Estimator& est : estimators) results.push_back(est.process(f, 5.0, 0.1, motion_at(k)));
            const rp::Result& one = results[0];
            ASSERT_TRUE(one.plane);
            ASSERT_TRUE(one.obstacles && !one.obstacles->empty());
            ASSERT_GT(one.left.count.size(), 0u);
            for (std::size_t t = 1; t < results.size(); ++t) {
                const rp::Result& r = results[t];
                SCOPED_TRACE("frame " + std::to_string(k) + ", " + std::to_string(t + 1) + " threads, fusion " +
                             rp::to_string(fusion));
                EXPECT_EQ(r.points.roi, one.points.roi);
                EXPECT_EQ(r.points.ground, one.points.ground);
                EXPECT_EQ(*r.plane, *one.plane);
                EXPECT_EQ(r.ground_mask, one.ground_mask);
                EXPECT_EQ(r.cluster_labels, one.cluster_labels);
                EXPECT_EQ(r.obstacles->size(), one.obstacles->size());
                for (auto [p, q] : {std::pair{&r.left, &one.left}, std::pair{&r.right, &one.right}}) {
                    EXPECT_EQ(p->count, q->count);
                    EXPECT_EQ(p->blocked, q->blocked);
                    const auto same = [](double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); };
                    for (std::size_t b = 0; b < q->z.size(); ++b) {
                        EXPECT_TRUE(same(p->z[b], q->z[b])) << "bin " << b;
                        EXPECT_TRUE(same(p->spread[b], q->spread[b])) << "bin " << b;
                    }
                    EXPECT_EQ(p->roughness.iso_class, q->roughness.iso_class);
                    EXPECT_EQ(p->roughness.gd_n0, q->roughness.gd_n0);
                    EXPECT_EQ(p->roughness.iri.value, q->roughness.iri.value);
                }
            }
        }
    }
}

TEST(Realtime, TheReadoutAllocatesNothingOnceWarm) {  // a controller's array, fed every frame's result
    const std::vector<rp::Frame> frames = kitti_frames();
    const rp::Config cfg = kitti_config(rp::FusionMethod::Kalman);
    rp::Estimator est(cfg);
    rp::ProfileReadout readout(cfg, 6.0);
    rp::Result out;
    for (int k = 0; k < 20; ++k) {
        est.process(frames[static_cast<std::size_t>(k) % frames.size()], 5.0, 0.02, motion_at(k), out);
        const long n = allocations_in([&] { readout.add(out); });
        if (k >= 5) {
            EXPECT_EQ(n, 0) << "frame " << k;
        }
    }
    const std::vector<double>& z = readout.left().z;
    EXPECT_EQ(z.size(), 60u);
    EXPECT_GT(std::count_if(z.begin(), z.end(), [](double v) { return std::isfinite(v); }), 50);
}

TEST(Realtime, SimulatedFrameAllocatesNothingOnceWarmWithEmaFusion) {
    expect_no_allocations(frame_allocations({simulated_frame()}, kitti_config(rp::FusionMethod::Ema), 5, 12), 5);
}

// Frames that state their points' errors, as stereo frames do (range variances, error groups of 16 points): the
// ROI's copies of them, the bins' and the cells' group counts reuse their buffers too.
TEST(Realtime, FramesWithPointErrorsAllocateNothingOnceWarmWithKalmanFusion) {
    std::vector<rp::Frame> frames = kitti_frames();
    for (rp::Frame& f : frames) {
        const auto n = static_cast<std::size_t>(f.points.rows());
        f.range_variances.assign(n, 1e-4f);
        for (std::size_t i = 0; i < n; ++i) f.error_groups.push_back(static_cast<std::int32_t>(i / 16));
    }
    expect_no_allocations(frame_allocations(frames, kitti_config(rp::FusionMethod::Kalman), 5, 20), 5);
}

// LiDAR frames whose beams' errors are counted (profile.beam_sigma_deg): the beams are the error groups, and each
// point's height variance is its beam's — the same buffers again.
TEST(Realtime, FramesWithCountedBeamsAllocateNothingOnceWarm) {
    std::vector<rp::Frame> frames = kitti_frames();
    for (rp::Frame& f : frames)
        for (Eigen::Index i = 0; i < f.points.rows(); ++i) f.beams.push_back(static_cast<std::int32_t>(i % 64));
    for (const auto fusion : {rp::FusionMethod::None, rp::FusionMethod::Kalman}) {
        rp::Config cfg = kitti_config(fusion);
        cfg.profile.beam_sigma_deg = 0.01;
        expect_no_allocations(frame_allocations(frames, cfg, 5, 20), 5);
    }
}

// Range-sensor samples fused into the map between frames (a preview sensor's window, README "Range sensors"):
// once its per-slot lists have grown, a batch of samples allocates nothing either.
TEST(Realtime, RangeSamplesEnterTheMapWithoutAllocatingOnceWarm) {
    rp::Estimator est(kitti_config(rp::FusionMethod::Kalman));
    rp::Result out;
    est.process(kitti_frames()[0], 5.0, 0.0, motion_at(0), out);
    std::vector<rp::MapSample> samples;
    for (int i = 0; i < 2000; ++i) samples.push_back({1.0 + 0.005 * i, 0.8, 0.01 * std::sin(0.1 * i), 1e-6});
    EXPECT_EQ(est.fuse_samples(samples), 100u);  // 10 m at 5 mm: 100 cells of 0.1 m
    long n = -1;
    std::size_t cells = 0;
    for (int pass = 0; pass < 3; ++pass) n = allocations_in([&] { cells = est.fuse_samples(samples); });
    EXPECT_EQ(cells, 100u);
    EXPECT_EQ(n, 0);
}

// A Result reused across frames (and across frames that have no profiles) holds exactly what a fresh one would.
TEST(Realtime, AReusedResultEqualsAFreshOne) {
    const std::vector<rp::Frame> kitti = kitti_frames();
    for (const auto fusion : {rp::FusionMethod::None, rp::FusionMethod::Kalman}) {
        rp::Estimator reusing(kitti_config(fusion)), fresh(kitti_config(fusion));
        rp::Result out;
        const rp::Frame empty;  // no points: no profiles, then profiles again into the same Result
        const rp::Frame* sequence[] = {&kitti[0], &kitti[1], &empty, &kitti[2], &kitti[0]};
        double speed_mps = 5.0;
        for (int k = 0; k < 5; ++k) {
            if (k == 3) speed_mps = 0.0;  // stopped: the other kind of frame without profiles
            if (k == 4) speed_mps = 5.0;
            reusing.process(*sequence[k], speed_mps, 0.02, motion_at(k), out);
            const rp::Result expected = fresh.process(*sequence[k], speed_mps, 0.02, motion_at(k));
            out.timing_ms = expected.timing_ms;  // the clock differs
            EXPECT_EQ(rp::result_to_json(out), rp::result_to_json(expected)) << "frame " << k;
            EXPECT_EQ(out.cluster_labels, expected.cluster_labels) << "frame " << k;
        }
    }
}

// A Result reused by an estimator with obstacles off after one with them on says "off" (null), as a fresh one does.
TEST(Realtime, AResultReusedWithObstaclesOffHasNoObstacleLists) {
    const rp::Frame f = kitti_frames()[0];
    rp::Config off = kitti_config(rp::FusionMethod::None);
    off.obstacles.enabled = false;
    rp::Estimator with(kitti_config(rp::FusionMethod::None)), without(off);
    rp::Result out;
    with.process(f, 5.0, 0.0, {}, out);
    ASSERT_TRUE(out.left.obstacles && out.right.obstacles);
    without.process(f, 5.0, 0.0, {}, out);
    EXPECT_FALSE(out.left.obstacles || out.right.obstacles || out.obstacles);
    rp::Result expected = without.process(f, 5.0, 0.0);
    out.timing_ms = expected.timing_ms;
    out.frame = expected.frame;
    EXPECT_EQ(rp::result_to_json(out), rp::result_to_json(expected));
}

// A Frame's own timestamp spaces the fused frames unless the motion gives one: 0.25 s apart at 4 m/s is 1 m.
TEST(Realtime, AFramesTimestampIsUsedUnlessTheMotionGivesOne) {
    rp::Frame f = kitti_frames()[0];
    rp::Estimator est(kitti_config(rp::FusionMethod::Ema));
    rp::Result out;
    f.timestamp = 100.0;
    est.process(f, 4.0, 0.0, {}, out);
    EXPECT_EQ(out.timestamp, std::optional<double>(100.0));
    f.timestamp = 100.25;
    const rp::Result r = est.process(f, 4.0, 0.0);
    EXPECT_EQ(r.timestamp, std::optional<double>(100.25));
    ASSERT_TRUE(r.fusion);
    EXPECT_NEAR(r.fusion->pose.x_m, 1.0, 1e-9);
    rp::FrameMotion given;
    given.timestamp_s = 200.0;
    EXPECT_EQ(est.process(f, 4.0, 0.0, given).timestamp, std::optional<double>(200.0));
}

// A view made by hand that no buffer can hold (rows overlapping, read backwards, a negative count) is refused,
// not read out of bounds.
TEST(Realtime, AViewNoBufferHoldsIsRefused) {
    rp::Estimator est(kitti_config(rp::FusionMethod::None));
    const scenes::Cloud road = scenes::plane(0.0, 0.0, -1.73, 2000);
    rp::Result out;
    for (const Eigen::Index stride : {2, 0, -4}) {
        const rp::Status s = est.try_process(rp::points_view(road.data(), road.rows(), stride), 5.0, 0.0, out);
        EXPECT_EQ(s.code(), rp::StatusCode::InvalidArgument) << stride;
        EXPECT_EQ(std::string(s.message()), "points: each row must hold x, y, z, so its stride must be at least 3 "
                                            "floats (got " + std::to_string(stride) + ")");
    }
#ifdef NDEBUG  // with assertions on (the sanitizer build), Eigen itself refuses to make a view of negative rows
    const rp::Status s = est.try_process(rp::points_view(road.data(), -1, 3), 5.0, 0.0, out);
    EXPECT_EQ(s.code(), rp::StatusCode::InvalidArgument);
    EXPECT_STREQ(s.message(), "points: a negative row count (-1)");
#endif
    EXPECT_THROW(est.process(rp::points_view(road.data(), road.rows(), 2), 5.0, 0.0, out), std::invalid_argument);
    EXPECT_TRUE(est.try_process(rp::points_view(nullptr, 0, 0), 5.0, 0.0, out).ok());  // no rows: nothing to read
}

// try_process reports bad input as a Status with the text process() throws, and writes nothing then.
TEST(Realtime, TryProcessGivesTheThrowingVariantsMessage) {
    rp::Estimator est(kitti_config(rp::FusionMethod::Kalman));
    const rp::Frame f = kitti_frames()[0];
    const rp::PointsView view = rp::points_view(f.points.data(), f.points.rows(), 4);
    rp::Result out;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    for (const auto& [speed_mps, yaw_rate_rps] : {std::pair{nan, 0.0}, std::pair{5.0, std::numeric_limits<double>::infinity()}}) {
        std::string thrown;
        try {
            est.process(view, speed_mps, yaw_rate_rps, out);
        } catch (const std::invalid_argument& e) {
            thrown = e.what();
        }
        ASSERT_FALSE(thrown.empty());
        const rp::Status status = est.try_process(view, speed_mps, yaw_rate_rps, out);
        EXPECT_FALSE(status.ok());
        EXPECT_EQ(status.code(), rp::StatusCode::InvalidArgument);
        EXPECT_EQ(std::string(status.message()), thrown);
    }
    rp::Frame lying = f;  // range variances for half the points
    lying.range_variances.assign(static_cast<std::size_t>(f.points.rows() / 2), 0.01f);
    std::string thrown;
    try {
        est.process(lying, 5.0, 0.0, {}, out);
    } catch (const std::invalid_argument& e) {
        thrown = e.what();
    }
    const rp::Status status = est.try_process(lying, 5.0, 0.0, {}, out);
    EXPECT_EQ(status.code(), rp::StatusCode::InvalidArgument);
    EXPECT_EQ(std::string(status.message()), thrown);
    EXPECT_NE(thrown.find("range variances for"), std::string::npos) << thrown;
}

// NaN points, an empty cloud and a stopped vehicle are ordinary frames: Ok, with the frame status process() gives.
TEST(Realtime, TryProcessGivesOrdinaryFramesTheirFrameStatus) {
    rp::Estimator throwing(kitti_config(rp::FusionMethod::None)), not_throwing(kitti_config(rp::FusionMethod::None));
    const scenes::Cloud nans = scenes::Cloud::Constant(100, 3, std::numeric_limits<float>::quiet_NaN());
    const scenes::Cloud empty(0, 3);
    const scenes::Cloud road = scenes::plane(0.0, 0.0, -1.73, 20000, 1.0, 40.0, 9.0);
    const auto view = [](const scenes::Cloud& c) { return rp::points_view(c.data(), c.rows(), 3); };
    const std::tuple<const scenes::Cloud*, double, rp::FrameStatus> cases[] = {
        {&nans, 5.0, rp::FrameStatus::NoFinitePoints},
        {&empty, 5.0, rp::FrameStatus::NoFinitePoints},
        {&road, -5.0, rp::FrameStatus::NoRoiPoints},  // reversing: the region behind, where this road is not
        {&road, 0.0, rp::FrameStatus::VehicleStopped},
        {&road, 5.0, rp::FrameStatus::Ok},
    };
    rp::Result out;
    for (const auto& [cloud, speed_mps, expected] : cases) {
        const rp::Status status = not_throwing.try_process(view(*cloud), speed_mps, 0.0, out);
        EXPECT_TRUE(status.ok()) << status.message();
        EXPECT_EQ(status.message(), std::string());
        EXPECT_EQ(out.status, expected) << rp::to_string(expected);
        EXPECT_EQ(throwing.process(view(*cloud), speed_mps, 0.0).status, expected);
    }
    EXPECT_STREQ(rp::to_string(rp::FrameStatus::VehicleStopped), "vehicle stopped");
    EXPECT_STREQ(rp::to_string(rp::FrameStatus::TiltedGround), rp::kTiltedGround);
}

// A slope of 31° (z = 0.6 x): no ground within the 15° tilt limit, said by the ground stage's status enum; such
// frames allocate nothing once warm either.
TEST(Realtime, TiltedGroundFramesSaySoWithoutAllocating) {
    const scenes::Cloud slope = scenes::plane(0.6, 0.0, -1.73, 20000, 1.0, 30.0, 9.0);
    const rp::PointsView view = rp::points_view(slope.data(), slope.rows(), 3);
    rp::Config cfg = kitti_config(rp::FusionMethod::None);
    cfg.ground.method = rp::GroundMethod::Pca;
    rp::Estimator est(cfg);
    rp::Result out;
    for (int k = 0; k < 3; ++k) ASSERT_TRUE(est.try_process(view, 5.0, 0.0, out).ok());
    EXPECT_EQ(out.status, rp::FrameStatus::TiltedGround);
    EXPECT_EQ(allocations_in([&] { est.try_process(view, 5.0, 0.0, out); }), 0);
    for (const rp::GroundMethod method : {rp::GroundMethod::Zones, rp::GroundMethod::Pca}) {  // the stage itself
        cfg.ground.method = method;
        EXPECT_EQ(rp::fit_ground(view, cfg.ground).status, rp::GroundStatus::TiltedGround) << rp::to_string(method);
    }
    const scenes::Cloud road = scenes::plane(0.0, 0.0, -1.73, 20000, 1.0, 30.0, 9.0);
    EXPECT_EQ(rp::fit_ground(rp::points_view(road.data(), road.rows(), 3), rp::GroundConfig{}).status,
              rp::GroundStatus::Found);
}

// The error path itself allocates nothing: the message goes into the Status's own buffer.
TEST(Realtime, TryProcessRefusesBadMotionWithoutAllocating) {
    rp::Estimator est(kitti_config(rp::FusionMethod::None));
    const scenes::Cloud road = scenes::plane(0.0, 0.0, -1.73, 2000);
    rp::Result out;
    rp::Status status;
    const long n = allocations_in([&] {
        status = est.try_process(rp::points_view(road.data(), road.rows(), 3), std::nan(""), 0.0, out);
    });
    EXPECT_EQ(n, 0);
    EXPECT_STREQ(status.message(), "speed must be finite, got nan");
}

// A speed, time or pose no drive has would place the fused map beyond what its cell indices hold (once the pose
// reached 10^299 m: an integer conversion out of range, undefined behaviour): refused, process() and try_process().
TEST(Realtime, MotionNoDriveHasIsRefused) {
    rp::Estimator est(kitti_config(rp::FusionMethod::Kalman));
    const scenes::Cloud road = scenes::plane(0.0, 0.0, -1.73, 2000);
    const rp::PointsView view = rp::points_view(road.data(), road.rows(), 3);
    rp::Result out;
    const auto refused = [&](double speed, const rp::FrameMotion& motion, const char* start) {
        const rp::Status status = est.try_process(view, speed, 0.0, "a.bin", motion, out);
        EXPECT_EQ(status.code(), rp::StatusCode::InvalidArgument);
        EXPECT_EQ(std::string(status.message()).rfind(start, 0), 0u) << status.message();
        EXPECT_THROW(est.process(view, speed, 0.0, "a.bin", motion, out), std::invalid_argument);
    };
    refused(1e300, {}, "speed must be within ±1000 m/s (no ground vehicle drives faster: a unit mixed up?), got "
                       "1e+300");
    refused(-1001.0, {}, "speed must be within ±1000 m/s");
    refused(5.0, {std::numeric_limits<double>::quiet_NaN(), std::nullopt}, "timestamp must be finite, got nan");
    refused(5.0, {std::nullopt, rp::Pose2{1e300, 0.0, 0.0}}, "pose (1e+300 m, 0 m, 0 rad) must be finite and within");
    refused(5.0, {std::nullopt, rp::Pose2{0.0, 0.0, std::numeric_limits<double>::infinity()}}, "pose (0 m, 0 m, inf");
    est.process(view, 999.0, 0.0, "a.bin", {0.0, rp::Pose2{-1e8, 1e8, 0.0}}, out);  // the bounds themselves pass
    ASSERT_TRUE(out.fusion.has_value());
    EXPECT_EQ(out.fusion->pose.x_m, -1e8);
}
