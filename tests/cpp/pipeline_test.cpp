#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <tuple>

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
    EXPECT_TRUE(r.left.roughness.iso_class) << rp::to_string(r.left.roughness.reason);
    EXPECT_TRUE(r.vehicle.iso_class) << rp::to_string(r.vehicle.reason);
    EXPECT_EQ(r.status, rp::FrameStatus::Ok);
    EXPECT_GT(r.timing_ms.total, 0.0);
}

TEST(Pipeline, ExtraColumnsAreIgnoredAndReadInPlace) {
    const scenes::Cloud xyz = road_scene();
    rp::PointMatrix xyzi(xyz.rows(), 4);
    xyzi << xyz, Eigen::MatrixXf::Constant(xyz.rows(), 1, 7.0f);
    rp::Estimator a(kitti_like()), b(kitti_like());
    rp::Result r3 = a.process(xyz, 5.0, 0.2);
    const rp::Result r4 = b.process(xyzi, 5.0, 0.2);
    EXPECT_EQ(r3.ground_mask, r4.ground_mask);
    EXPECT_EQ(r3.cluster_labels, r4.cluster_labels);
    ASSERT_TRUE(r3.left.roughness.iso_class);  // the whole line below holds profiles and their roughness
    r3.timing_ms = r4.timing_ms;  // the clock differs
    EXPECT_EQ(rp::result_to_json(r3), rp::result_to_json(r4));
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
    EXPECT_EQ(empty.status, rp::FrameStatus::NoFinitePoints);
    EXPECT_FALSE(empty.plane);
    EXPECT_TRUE(empty.left.z.empty());
    EXPECT_STREQ(rp::to_string(empty.vehicle.reason), "no finite points");
    const scenes::Cloud nans = scenes::Cloud::Constant(100, 3, std::numeric_limits<float>::quiet_NaN());
    EXPECT_EQ(est.process(nans, 5.0, 0.0).status, rp::FrameStatus::NoFinitePoints);
    const scenes::Cloud far = scenes::plane(0, 0, -1.8, 500, 60.0, 80.0);  // nothing in the ROI
    const rp::Result beyond = est.process(far, 5.0, 0.0);
    EXPECT_EQ(beyond.status, rp::FrameStatus::NoRoiPoints);  // said as such, not "no ground"
    EXPECT_STREQ(rp::to_string(beyond.left.roughness.iri.reason), "no points in the region of interest");

}

TEST(Pipeline, StoppedVehicleKeepsTheGroundButHasNoProfiles) {
    rp::Estimator est(kitti_like());
    const rp::Result r = est.process(road_scene(), 0.0, 0.1);
    EXPECT_TRUE(r.plane);
    EXPECT_GT(r.points.ground, 0);
    EXPECT_EQ(r.status, rp::FrameStatus::VehicleStopped);
    EXPECT_TRUE(r.left.z.empty());
    EXPECT_STREQ(rp::to_string(r.left.roughness.reason), "vehicle stopped");
}

// The C++ result holds enums; their texts are the output's strings, byte for byte (docs/output.md).
TEST(Pipeline, RoughnessAndIriReasonsGiveTheDocumentedTexts) {
    using R = rp::RoughnessReason;
    using I = rp::IriReason;
    using B = rp::BandLimit;
    const std::pair<R, const char*> roughness[] = {
        {R::None, ""}, {R::NoValidProfile, "no valid profile"}, {R::StretchTooShort, "valid stretch too short"},
        {R::TooFewOrdinates, "too few PSD ordinates in band"}, {R::NoiseUnknown, "noise floor unknown"},
        {R::NoiseDominates, "noise dominates the band"}, {R::FitFailed, "fit failed (G_d(n0) not finite)"},
        {R::BothWheelsDeclined, "both wheels declined"}, {R::NoFinitePoints, "no finite points"},
        {R::NoRoiPoints, "no points in the region of interest"}, {R::NoGround, "no ground"},
        {R::TiltedGround, rp::kTiltedGround}, {R::VehicleStopped, "vehicle stopped"}};
    for (const auto& [reason, text] : roughness) EXPECT_STREQ(rp::to_string(reason), text);
    const std::pair<I, const char*> iri[] = {
        {I::None, ""}, {I::NoValidProfile, "no valid profile"}, {I::StretchTooShort, "valid stretch too short for IRI"},
        {I::TooSparse, "too few bins with points for IRI"}, {I::ClassDeclined, "roughness class declined"},
        {I::SegmentNotCovered, "segment not covered by one valid stretch"}, {I::NoFinitePoints, "no finite points"},
        {I::NoRoiPoints, "no points in the region of interest"}, {I::NoGround, "no ground"},
        {I::TiltedGround, rp::kTiltedGround}, {I::VehicleStopped, "vehicle stopped"}};
    for (const auto& [reason, text] : iri) EXPECT_STREQ(rp::to_string(reason), text);
    const std::pair<B, const char*> limits[] = {{B::None, ""},         {B::Requested, "requested"}, {B::Nyquist, "nyquist"},
                                                {B::Sampling, "sampling"}, {B::Noise, "noise"},         {B::Wheels, "wheels"}};
    for (const auto& [limit, text] : limits) EXPECT_STREQ(rp::to_string(limit), text);
    // A frame without profiles declines roughness and IRI with its status's text.
    rp::Estimator est(kitti_like());
    for (const rp::Result& r : {est.process(scenes::Cloud(0, 3), 5.0, 0.0),
                                est.process(scenes::plane(0, 0, -1.8, 500, 60.0, 80.0), 5.0, 0.0),
                                est.process(road_scene(), 0.0, 0.1)}) {
        ASSERT_NE(r.status, rp::FrameStatus::Ok);
        for (const rp::Roughness* x : {&r.left.roughness, &r.right.roughness, &r.vehicle}) {
            EXPECT_STREQ(rp::to_string(x->reason), rp::to_string(r.status));
            EXPECT_STREQ(rp::to_string(x->iri.reason), rp::to_string(r.status));
            EXPECT_EQ(x->band_limit, B::None);
        }
    }
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
    EXPECT_STREQ(rp::to_string(r.left.roughness.reason), "no valid profile");
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

// A batch's lines restate the recording's frame number and leave the times out, so that they repeat run to run.
TEST(Pipeline, JsonLineWithoutTimingRepeatsAndRestatesTheFrame) {
    rp::Config cfg = kitti_like();
    cfg.fusion.method = rp::FusionMethod::Kalman;
    rp::Estimator a(cfg), b(cfg);
    const rp::Result r = a.process(road_scene(), 5.0, 0.3), q = b.process(road_scene(), 5.0, 0.3);
    const auto j = nlohmann::json::parse(rp::result_to_json(r, rp::LineOptions{41, false}));
    EXPECT_EQ(j["frame"], 41);
    EXPECT_FALSE(j.contains("timing_ms"));
    ASSERT_TRUE(j["fusion"].is_object());
    EXPECT_FALSE(j["fusion"].contains("time_ms"));
    EXPECT_EQ(j["fusion"]["method"], "kalman");
    EXPECT_EQ(rp::result_to_json(r, rp::LineOptions{41, false}), rp::result_to_json(q, rp::LineOptions{41, false}));
    auto timed = nlohmann::json::parse(rp::result_to_json(r));  // the full line: the same but for those
    EXPECT_EQ(timed["frame"], 0);
    timed.erase("timing_ms");
    timed["fusion"].erase("time_ms");
    timed["frame"] = 41;
    EXPECT_EQ(timed, j);
}

// The line is written as a stream: numbers must read back as the same doubles (NaN and ±Inf as null), and text
// that is not UTF-8 (a file name in another encoding) is an error naming the field, not a broken line.
TEST(Pipeline, JsonLineNumbersReadBackExactlyAndBadTextIsAnError) {
    rp::Estimator est(kitti_like());
    rp::Result r = est.process(road_scene(), 5.0, 0.3, "f.bin");
    r.speed_mps = 0.1 + 0.2;  // 0.30000000000000004: needs all 17 digits
    r.yaw_rate_rps = std::numeric_limits<double>::infinity();
    r.left.s0 = 1e-300;
    r.left.ds = -0.0;
    const auto j = nlohmann::json::parse(rp::result_to_json(r));
    EXPECT_EQ(j["motion"]["speed"].get<double>(), 0.1 + 0.2);
    EXPECT_TRUE(j["motion"]["yaw_rate"].is_null());
    EXPECT_EQ(j["profiles"]["left"]["s0"].get<double>(), 1e-300);
    EXPECT_TRUE(std::signbit(j["profiles"]["left"]["ds"].get<double>()));
    ASSERT_EQ(j["profiles"]["left"]["z"].size(), r.left.z.size());
    for (std::size_t i = 0; i < r.left.z.size(); ++i) {
        if (std::isfinite(r.left.z[i]))
            EXPECT_EQ(j["profiles"]["left"]["z"][i].get<double>(), r.left.z[i]) << i;
        else
            EXPECT_TRUE(j["profiles"]["left"]["z"][i].is_null()) << i;
    }
    r.source = "road\xff.bin";
    try {
        rp::result_to_json(r);
        ADD_FAILURE() << "no error for a source name that is not UTF-8";
    } catch (const std::runtime_error& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find("source is not UTF-8 text: road\\xff.bin"), std::string::npos) << message;
    }
}

// The ROI is ordered by cell inside the pipeline, whatever the order of the rows: a reversed cloud gives the
// same ground, clusters and profiles, row for row.
TEST(Pipeline, RowOrderDoesNotChangeTheResult) {
    const scenes::Cloud pts = scenes::concat(road_scene(), scenes::box(12.0, -3.0, 1.0, 1.0, 1.0, -1.8));
    const scenes::Cloud reversed = pts.colwise().reverse();
    rp::Estimator a(kitti_like()), b(kitti_like());
    const rp::Result r = a.process(pts, 5.0, 0.1), q = b.process(reversed, 5.0, 0.1);
    const auto n = static_cast<std::size_t>(pts.rows());
    ASSERT_TRUE(r.plane && q.plane);
    for (int k = 0; k < 4; ++k) EXPECT_NEAR((*r.plane)[k], (*q.plane)[k], 1e-12);
    ASSERT_TRUE(r.obstacles && q.obstacles);
    EXPECT_EQ(r.obstacles->size(), 2u);
    EXPECT_EQ(q.obstacles->size(), r.obstacles->size());
    for (std::size_t i = 0; i < n; ++i) {
        ASSERT_EQ(r.ground_mask[i], q.ground_mask[n - 1 - i]) << "row " << i;
        ASSERT_EQ(r.cluster_labels[i], q.cluster_labels[n - 1 - i]) << "row " << i;
    }
    EXPECT_EQ(r.left.count, q.left.count);
    EXPECT_EQ(r.right.count, q.right.count);
    for (std::size_t k = 0; k < r.left.z.size(); ++k)
        if (!std::isnan(r.left.z[k])) {
            EXPECT_NEAR(r.left.z[k], q.left.z[k], 1e-12) << "bin " << k;
        }
}

// Clusters level in x are ranked by their lowest input row, not by their place in the ROI (ordered by cell,
// y ascending within an x column: the box on the right comes first there).
TEST(Pipeline, ClusterTiesGoToTheLowestInputRow) {
    const scenes::Cloud left = scenes::box(15.0, 3.0, 1.0, 1.0, 1.0, -1.8);
    const scenes::Cloud right = scenes::box(15.0, -3.0, 1.0, 1.0, 1.0, -1.8);
    const scenes::Cloud pts = scenes::concat(scenes::concat(road_scene(), left), right);
    rp::Estimator est(kitti_like());
    const rp::Result r = est.process(pts, 5.0, 0.0);
    const Eigen::Index first_left = pts.rows() - right.rows() - left.rows(), first_right = pts.rows() - right.rows();
    ASSERT_TRUE(r.obstacles);
    const auto& boxes = *r.obstacles;
    const std::int32_t left_id = r.cluster_labels[first_left], right_id = r.cluster_labels[first_right];
    ASSERT_GE(left_id, 0);
    ASSERT_GE(right_id, 0);
    EXPECT_EQ(boxes[left_id].aabb_min[0], boxes[right_id].aabb_min[0]);
    EXPECT_LT(left_id, right_id);
}

// A huge ROI is ordered by wider cells (a bounded count array): the same points give the same answer as in a
// ROI that just holds them.
TEST(Pipeline, HugeRoiGivesTheAnswerOfATightOne) {
    const scenes::Cloud pts = scenes::concat(road_scene(), scenes::box(12.0, -3.0, 1.0, 1.0, 1.0, -1.8));
    rp::Config tight = kitti_like(), huge = kitti_like();
    tight.ground.roi_x_max_m = 46.0, tight.ground.roi_y_abs_max_m = 12.0;
    huge.ground.roi_x_max_m = 5000.0, huge.ground.roi_y_abs_max_m = 3000.0;
    const rp::Result a = rp::Estimator(tight).process(pts, 5.0, 0.1), b = rp::Estimator(huge).process(pts, 5.0, 0.1);
    EXPECT_EQ(a.points.roi, b.points.roi);
    EXPECT_EQ(a.ground_mask, b.ground_mask);
    EXPECT_EQ(a.cluster_labels, b.cluster_labels);
    ASSERT_TRUE(a.plane && b.plane);
    for (int k = 0; k < 4; ++k) EXPECT_NEAR((*a.plane)[k], (*b.plane)[k], 1e-12);
}

// The pipeline levels only the points in a wheel's corridor, by the local ground model: its profiles are those the
// stage functions give from every ground point's local height — on a grade change, with a track wider than the
// levelling corridor, and with no corridor points beyond 25 m (bands there keep the frame plane).
TEST(Pipeline, LocallyLevelledProfilesAreThoseOfTheStageFunctions) {
    scenes::Cloud road = scenes::plane(0.0, 0.0, 0.0, 120000, 0.5, 45.0, 10.0);
    Eigen::Index kept = 0;
    for (Eigen::Index i = 0; i < road.rows(); ++i) {
        const float x = road(i, 0), y = road(i, 1);
        if (x > 25.0f && std::abs(y) < 1.5f) continue;
        road.row(kept++) << x, y, float(0.04 * std::max(0.0, x - 15.0) + 0.01 * std::sin(2.0 * x) - 1.8);
    }
    road.conservativeResize(kept, 3);
    rp::Config cfg = kitti_like();
    cfg.track_width = 3.4;
    cfg.obstacles.enabled = false;
    for (const double yaw_rate : {0.0, 0.08}) {
        const rp::Result r = rp::Estimator(cfg).process(road, 5.0, yaw_rate);
        ASSERT_TRUE(r.plane);
        scenes::Cloud base = road;
        base.col(2).array() += 1.8f;
        const auto view = rp::points_view(base.data(), base.rows(), 3);
        const std::vector<double> local_z =
            rp::local_ground_heights(view, r.ground_mask, *r.plane, cfg.profile.level_band_m, r.path);
        const rp::WheelProfiles expected = rp::build_profiles(view, r.ground_mask, rp::levelling_for(&*r.plane), r.path,
                                                              cfg.tire_width, cfg.profile, nullptr, &local_z);
        const double wheel_y = 0.5 * cfg.track_width;
        for (const auto& [got, want, y] : {std::tuple{&r.left, &expected.left, wheel_y},
                                           std::tuple{&r.right, &expected.right, -wheel_y}}) {
            ASSERT_EQ(got->count, want->count);
            EXPECT_GT(std::count_if(got->count.begin() + 260, got->count.end(), [](auto c) { return c > 0; }), 20)
                << "bins beyond 26 m hold points";
            if (yaw_rate == 0.0)  // beyond 35 m, a band past the last corridor point: heights above the frame plane
                for (std::size_t k = 360; k < got->z.size(); ++k) {
                    const double x = (static_cast<double>(k) + 0.5) * cfg.profile.ds_m;
                    const double z = 0.04 * (x - 15.0) + 0.01 * std::sin(2.0 * x);
                    EXPECT_NEAR(got->z[k], rp::height_above(*r.plane, x, y, z), 0.01) << k;
                }
            for (std::size_t k = 0; k < got->z.size(); ++k) {
                if (std::isnan(want->z[k])) EXPECT_TRUE(std::isnan(got->z[k])) << k;
                else EXPECT_NEAR(got->z[k], want->z[k], 1e-6) << k;  // the ROI's points are rounded to float in
                                                                      // the base frame, these in the sensor's
            }
        }
    }
}

namespace {

// A flat road seen by a sensor 1.7 m up whose beams are off: 31 rings from 5.05 to 20.05 m ahead, 0.5 m apart,
// each one beam, points 2 cm apart across the road with heights off by up to 1 mm, and each ring x·δθ_b higher
// for its beam's elevation error δθ_b, drawn uniformly from ±0.1°.
rp::Frame ringed_road() {
    rp::Frame f;
    const int rings = 31, across = 301;
    f.points.resize(rings * across, 4);
    for (int b = 0; b < rings; ++b) {
        const double u = std::sin(12.9898 * b + 1.0) * 43758.5453;
        const double offset_rad = (2.0 * (std::abs(u) - std::floor(std::abs(u))) - 1.0) * 0.1 * M_PI / 180.0;
        const float x = 5.05f + 0.5f * static_cast<float>(b);
        for (int j = 0; j < across; ++j) {
            const int i = b * across + j;
            const float wiggle = 0.001f * std::sin(12.9898f * static_cast<float>(i));
            f.points.row(i) << x, -3.0f + 0.02f * static_cast<float>(j),
                -1.7f + wiggle + x * static_cast<float>(offset_rad), 0.0f;
            f.beams.push_back(b);
        }
    }
    return f;
}

rp::Config ringed_road_config(double beam_sigma_deg) {
    rp::Config cfg;
    cfg.sensor_height = 1.7;
    cfg.ground.method = rp::GroundMethod::Pca;
    cfg.obstacles.enabled = false;
    cfg.profile.beam_sigma_deg = beam_sigma_deg;
    return cfg;
}

}  // namespace

TEST(Pipeline, ABeamsElevationErrorCountsOncePerBinWhenItsSigmaIsGiven) {
    // A bin's points all come from one ring. Not counted, the beams' offsets read as relief: the flat road is
    // classified rough. With beam_sigma_deg a bin's median is as uncertain as its beam's angle at the bin's
    // distance d (d·σ, whatever the spread of its points) and counts as one measurement (× √count), and the
    // roughness declines; the heights do not change, and without beams nothing does.
    rp::Frame f = ringed_road();
    const rp::Result none = rp::Estimator(ringed_road_config(0.0)).process(f, 5.0, 0.0);
    const double sigma_deg = 0.05, sigma = sigma_deg * M_PI / 180.0;
    const rp::Result counted = rp::Estimator(ringed_road_config(sigma_deg)).process(f, 5.0, 0.0);
    std::vector<std::int32_t> beams;
    beams.swap(f.beams);
    const rp::Result unknown = rp::Estimator(ringed_road_config(sigma_deg)).process(f, 5.0, 0.0);
    std::size_t compared = 0;
    for (std::size_t k = 0; k < none.left.z.size(); ++k) {
        const int count = none.left.count[k];
        if (count < 2) continue;
        EXPECT_EQ(unknown.left.spread[k], none.left.spread[k]) << "bin " << k;
        EXPECT_EQ(counted.left.z[k], none.left.z[k]) << "bin " << k;
        EXPECT_LT(none.left.spread[k], 1e-3);
        const double x = 0.1 * static_cast<double>(k);  // straight: s = x; the corridor's points 0.65–0.95 m aside
        EXPECT_GE(counted.left.spread[k], x * sigma * std::sqrt(count)) << "bin " << k;
        EXPECT_LE(counted.left.spread[k], std::hypot(x + 0.1, 0.95) * sigma * std::sqrt(count)) << "bin " << k;
        ++compared;
    }
    EXPECT_EQ(compared, 31u);
    ASSERT_TRUE(none.left.roughness.iso_class) << rp::to_string(none.left.roughness.reason);
    EXPECT_GE(*none.left.roughness.iso_class, 'C');
    EXPECT_EQ(counted.left.roughness.reason, rp::RoughnessReason::NoiseDominates);
    EXPECT_EQ(unknown.left.roughness.iso_class, none.left.roughness.iso_class);
    f.beams.assign(beams.begin(), beams.end() - 1);
    try {
        rp::Estimator(ringed_road_config(sigma_deg)).process(f, 5.0, 0.0);
        ADD_FAILURE() << "beams for all but one point were accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("beams for"), std::string::npos) << e.what();
    }
}

TEST(Pipeline, EachBeamsOwnSigmaCountsInPlaceOfTheCommonOne) {
    // beam_sigmas_deg gives beam b its own σ. Listing every beam at the common σ is the common σ; listing the even
    // beams at σ and the odd ones at 0 counts the even rings' bins as before and leaves the odd rings' as if nothing
    // were counted (their points no error group either); beams the list does not reach keep beam_sigma_deg.
    const rp::Frame f = ringed_road();
    const double sigma_deg = 0.05;
    const rp::Result none = rp::Estimator(ringed_road_config(0.0)).process(f, 5.0, 0.0);
    const rp::Result common = rp::Estimator(ringed_road_config(sigma_deg)).process(f, 5.0, 0.0);
    rp::Config listed = ringed_road_config(0.0);
    listed.profile.beam_sigmas_deg.assign(31, sigma_deg);
    const rp::Result all = rp::Estimator(listed).process(f, 5.0, 0.0);
    EXPECT_EQ(all.left.roughness.reason, common.left.roughness.reason);
    for (std::size_t b = 1; b < 31; b += 2) listed.profile.beam_sigmas_deg[b] = 0.0;
    const rp::Result even = rp::Estimator(listed).process(f, 5.0, 0.0);
    listed.profile.beam_sigmas_deg.resize(16);  // beams 16–30 take the common σ
    listed.profile.beam_sigma_deg = sigma_deg;
    const rp::Result short_list = rp::Estimator(listed).process(f, 5.0, 0.0);
    std::size_t odd = 0, even_bins = 0;
    for (std::size_t k = 0; k < none.left.z.size(); ++k) {
        if (none.left.count[k] < 2) continue;
        const auto ring = static_cast<int>(std::lround((0.1 * static_cast<double>(k) + 0.05 - 5.05) / 0.5));
        const bool counted = ring % 2 == 0;
        EXPECT_EQ(all.left.spread[k], common.left.spread[k]) << "bin " << k;
        EXPECT_EQ(even.left.spread[k], counted ? common.left.spread[k] : none.left.spread[k]) << "bin " << k;
        EXPECT_EQ(short_list.left.spread[k], counted || ring >= 16 ? common.left.spread[k] : none.left.spread[k])
            << "bin " << k;
        ++(counted ? even_bins : odd);
    }
    EXPECT_GT(odd, 10u);
    EXPECT_GT(even_bins, 10u);
    listed.profile.beam_sigmas_deg = {0.01, -0.01};
    try {
        rp::Estimator{listed};
        ADD_FAILURE() << "a negative σ was accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("profile.beam_sigmas_deg[1]"), std::string::npos) << e.what();
    }
}
