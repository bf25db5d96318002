// DriveFrames / DriveRunner: each frame's time, motion and pose, the mounting from the first frame, fusion resets
// at sequence breaks, and the errors of contradicting options (docs/method.md, "Drives").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include <roadpreview/drive/drive.hpp>

namespace rp = roadpreview;

namespace {

constexpr double kSensorHeightM = 1.8;

// A flat road seen from a level sensor 1.8 m up: a grid of points 2–30 m ahead, ±5 m to the sides.
rp::Frame road_frame(const std::string& source, std::string sequence_break = {}) {
    std::vector<std::array<float, 4>> rows;
    for (float x = 2.0f; x <= 30.0f; x += 0.2f)
        for (float y = -5.0f; y <= 5.0f; y += 0.2f) rows.push_back({x, y, static_cast<float>(-kSensorHeightM), 1.0f});
    rp::Frame f;
    f.points.resize(static_cast<Eigen::Index>(rows.size()), 4);
    for (std::size_t i = 0; i < rows.size(); ++i)
        for (int c = 0; c < 4; ++c) f.points(static_cast<Eigen::Index>(i), c) = rows[i][static_cast<std::size_t>(c)];
    f.source = source;
    f.sequence_break = std::move(sequence_break);
    return f;
}

class VectorSource : public rp::FrameSource {
public:
    explicit VectorSource(std::vector<rp::Frame> frames) : frames_(std::move(frames)) {}
    std::optional<rp::Frame> next() override {
        if (next_ == frames_.size()) return std::nullopt;
        return frames_[next_++];
    }
    rp::SourceInfo info() const override {
        rp::SourceInfo i;
        i.format = "files";
        return i;
    }

private:
    std::vector<rp::Frame> frames_;
    std::size_t next_ = 0;
};

std::unique_ptr<rp::FrameSource> frames(int n) {
    std::vector<rp::Frame> v;
    for (int i = 0; i < n; ++i) v.push_back(road_frame("f" + std::to_string(i) + ".bin"));
    return std::make_unique<VectorSource>(std::move(v));
}

rp::Config mounted() {
    rp::Config cfg;
    cfg.sensor_height = kSensorHeightM;
    return cfg;
}

std::string write(const std::string& name, const std::string& text) {
    const std::string path = testing::TempDir() + name;
    std::ofstream(path) << text;
    return path;
}

}  // namespace

TEST(Drive, TheMotionTableWinsOverAGivenYawRateWhichWinsOverDrivingStraight) {
    rp::DriveOptions o;
    o.speed_mps = 5.0;
    o.frame_rate_hz = 10.0;
    o.motion_file = write("drive_motion.csv", "t,speed,yaw_rate\n0,2,0.1\n1,4,0.3\n");
    o.yaw_rate_rps = -0.2;
    rp::DriveFrames table(frames(3), mounted(), o);
    std::optional<rp::DriveFrame> f = table.next();
    f = table.next();  // t = 0.1 s
    ASSERT_TRUE(f && f->at.timestamp_s);
    EXPECT_DOUBLE_EQ(*f->at.timestamp_s, 0.1);
    EXPECT_NEAR(f->motion.speed_mps, 2.2, 1e-12);
    EXPECT_NEAR(f->motion.yaw_rate_rps, 0.12, 1e-12);
    EXPECT_EQ(f->yaw_rate_source, "motion");

    o.motion_file.clear();
    rp::DriveFrames option(frames(1), mounted(), o);
    f = option.next();
    EXPECT_EQ(f->yaw_rate_source, "option");
    EXPECT_DOUBLE_EQ(f->motion.yaw_rate_rps, -0.2);
    EXPECT_DOUBLE_EQ(f->motion.speed_mps, 5.0);

    o.yaw_rate_rps.reset();
    rp::DriveFrames straight(frames(1), mounted(), o);
    f = straight.next();
    EXPECT_EQ(f->yaw_rate_source, "default");
    EXPECT_DOUBLE_EQ(f->motion.yaw_rate_rps, 0.0);
}

TEST(Drive, TheFrameRangeSkipsFramesButKeepsTheirIndicesAndTimes) {
    rp::DriveOptions o;
    o.speed_mps = 5.0;
    o.frame_rate_hz = 10.0;
    o.first_frame = 2;
    o.last_frame = 4;
    rp::DriveFrames drive(frames(6), mounted(), o);
    std::vector<std::int64_t> indices;
    while (auto f = drive.next()) {
        indices.push_back(f->index);
        EXPECT_DOUBLE_EQ(*f->at.timestamp_s, 0.1 * static_cast<double>(f->index));
    }
    EXPECT_EQ(indices, (std::vector<std::int64_t>{2, 3}));
    EXPECT_EQ(drive.frames_read(), 4);  // stops at the range's end, not the recording's
}

TEST(Drive, WithoutAMountingTheFirstFrameGivesItAndEveryResultSaysSo) {
    rp::DriveOptions o;
    o.speed_mps = 5.0;
    std::vector<std::pair<bool, std::string>> notes;
    o.on_note = [&](bool warning, const std::string& text) { notes.emplace_back(warning, text); };
    rp::DriveRunner runner(frames(2), rp::Config{}, o);
    int n = 0;
    while (auto step = runner.next()) {
        ++n;
        EXPECT_EQ(step->result.mounting_source, "estimated");
        EXPECT_NEAR(step->result.extrinsics.z_m, kSensorHeightM, 0.01);
        EXPECT_EQ(step->result.yaw_rate_source, "default");
    }
    EXPECT_EQ(n, 2);
    ASSERT_TRUE(runner.config().extrinsics);
    ASSERT_EQ(notes.size(), 1u);
    EXPECT_FALSE(notes[0].first);
    EXPECT_NE(notes[0].second.find("mounting estimated from the ground in f0.bin"), std::string::npos);
}

// A recording or a live stream may start with part of a rotation that sees no road ahead.
TEST(Drive, AFrameWithoutGroundLeavesTheMountingToTheFirstFrameThatHasIt) {
    rp::Frame sky = road_frame("f0.bin");
    sky.points.col(2).setConstant(3.0f);  // every point above the sensor: no ground below it
    std::vector<rp::Frame> v{sky, road_frame("f1.bin"), road_frame("f2.bin")};
    rp::Config cfg;
    cfg.fusion.method = rp::FusionMethod::Kalman;
    rp::DriveOptions o;
    o.speed_mps = 5.0;
    std::vector<std::pair<bool, std::string>> notes;
    o.on_note = [&](bool warning, const std::string& text) { notes.emplace_back(warning, text); };
    rp::DriveRunner runner(std::make_unique<VectorSource>(std::move(v)), cfg, o);
    std::vector<rp::Result> results;
    std::vector<bool> estimated_here;
    while (auto step = runner.next()) {
        estimated_here.push_back(step->input.mounting_estimated);
        results.push_back(std::move(step->result));
    }
    ASSERT_EQ(results.size(), 3u);
    EXPECT_EQ(estimated_here, (std::vector<bool>{false, true, false}));
    EXPECT_EQ(results[0].mounting_source, "none");
    for (int k : {1, 2}) {
        EXPECT_EQ(results[static_cast<std::size_t>(k)].mounting_source, "estimated");
        EXPECT_NEAR(results[static_cast<std::size_t>(k)].extrinsics.z_m, kSensorHeightM, 0.01);
    }
    // The map made of base-frame points is dropped; the frame count goes on.
    ASSERT_TRUE(results[1].fusion && results[2].fusion);
    EXPECT_EQ(results[1].fusion->reset, "mounting estimated");
    EXPECT_EQ(results[2].fusion->frames, 2);
    for (std::size_t k = 0; k < results.size(); ++k) EXPECT_EQ(results[k].frame, static_cast<std::int64_t>(k));
    ASSERT_EQ(notes.size(), 3u);
    EXPECT_TRUE(notes[0].first);
    EXPECT_NE(notes[0].second.find("no ground in f0.bin"), std::string::npos) << notes[0].second;
    // Taken as base-frame points, the sky frame's "ground" lies 3 m up: the run says they are not.
    EXPECT_TRUE(notes[1].first);
    EXPECT_NE(notes[1].second.find("f0.bin: the fitted ground is 3.00 m above the base origin and tilted 0.0°: the "
                                   "points are not base-frame points"), std::string::npos) << notes[1].second;
    EXPECT_EQ(runner.mounting_disagreements(), 1);
    EXPECT_FALSE(notes[2].first);
    EXPECT_NE(notes[2].second.find("mounting estimated from the ground in f1.bin"), std::string::npos);
    EXPECT_NE(notes[2].second.find("the frames before it were taken as base-frame points"), std::string::npos);
}

// A cloud whose origin sits on its ground is in a base frame already: later frames are not asked again.
TEST(Drive, AGroundAtTheCloudsOriginSettlesTheMountingAsABaseFrame) {
    std::vector<rp::Frame> v;
    for (int i = 0; i < 3; ++i) {
        v.push_back(road_frame("f" + std::to_string(i) + ".bin"));
        v.back().points.col(2).setConstant(-0.03f);  // the road 3 cm under the origin
    }
    rp::DriveOptions o;
    o.speed_mps = 5.0;
    std::vector<std::pair<bool, std::string>> notes;
    o.on_note = [&](bool warning, const std::string& text) { notes.emplace_back(warning, text); };
    rp::DriveRunner runner(std::make_unique<VectorSource>(std::move(v)), rp::Config{}, o);
    while (auto step = runner.next()) {
        EXPECT_EQ(step->result.mounting_source, "none");
        EXPECT_FALSE(step->input.mounting_estimated);
    }
    ASSERT_EQ(notes.size(), 1u);
    EXPECT_NE(notes[0].second.find("the ground in f0.bin lies at the cloud's origin"), std::string::npos)
        << notes[0].second;
}

// A ground through the origin but tilted is neither a base frame's nor a mounting (the bundled Ouster bag's desk,
// 11.8°): said so, not "taken as base-frame points" and then "not base-frame points" of the same frame.
TEST(Drive, ATiltedGroundAtTheCloudsOriginIsNoBaseFrame) {
    rp::Frame tilted = road_frame("f0.bin");
    for (Eigen::Index i = 0; i < tilted.points.rows(); ++i)
        tilted.points(i, 2) = -0.2f * tilted.points(i, 0);  // 11.3° down ahead, through the origin
    rp::DriveOptions o;
    o.speed_mps = 5.0;
    std::vector<std::string> notes;
    o.on_note = [&](bool, const std::string& text) { notes.push_back(text); };
    rp::DriveRunner runner(std::make_unique<VectorSource>(std::vector<rp::Frame>{tilted}), rp::Config{}, o);
    while (runner.next()) {}
    ASSERT_FALSE(notes.empty());
    EXPECT_NE(notes[0].find("f0.bin lies at the cloud's origin but tilted 11.3°"), std::string::npos) << notes[0];
    EXPECT_NE(notes[0].find("neither a level base frame nor a mounting"), std::string::npos) << notes[0];
}

// A 2-D scanner's scans made clouds (every z exactly 0) hold no heights: said once, not profiled silently.
TEST(Drive, ATwoDimensionalScanIsNotedOnce) {
    std::vector<rp::Frame> v;
    for (int i = 0; i < 3; ++i) {
        v.push_back(road_frame("scan" + std::to_string(i) + ".bag"));
        v.back().points.col(2).setZero();
    }
    rp::DriveOptions o;
    o.speed_mps = 1.0;
    std::vector<std::string> notes;
    o.on_note = [&](bool, const std::string& text) { notes.push_back(text); };
    rp::DriveRunner runner(std::make_unique<VectorSource>(std::move(v)), rp::Config{}, o);
    while (runner.next()) {}
    const auto said = std::count_if(notes.begin(), notes.end(), [](const std::string& n) {
        return n.find("scan0.bag: every point has z = 0, as a 2-D scanner's scan") != std::string::npos;
    });
    EXPECT_EQ(said, 1);
    notes.clear();  // a flat road 1.8 m below the sensor has one height too, but is a cloud
    rp::DriveRunner road(frames(2), mounted(), o);
    while (road.next()) {}
    for (const std::string& n : notes) EXPECT_EQ(n.find("z = 0"), std::string::npos) << n;
}

TEST(Drive, AGivenMountingThatDisagreesWithTheGroundIsNotedOnceAndCounted) {
    rp::DriveOptions o;
    o.speed_mps = 5.0;
    std::vector<std::string> warnings;
    o.on_note = [&](bool warning, const std::string& text) { if (warning) warnings.push_back(text); };
    rp::Config cfg;
    cfg.sensor_height = 1.2;  // the road lies 1.8 m below the sensor
    rp::DriveRunner runner(frames(3), cfg, o);
    while (runner.next()) {}
    EXPECT_EQ(runner.mounting_disagreements(), 3);
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("f0.bin: the fitted ground is 0.60 m below"), std::string::npos) << warnings[0];
}

TEST(Drive, ASequenceBreakStartsTheFusionMapAfreshAndTheResultSaysWhy) {
    std::vector<rp::Frame> v{road_frame("a/0.bin"), road_frame("a/1.bin"), road_frame("b/0.bin", "another folder")};
    rp::Config cfg = mounted();
    cfg.fusion.method = rp::FusionMethod::Kalman;
    rp::DriveOptions o;
    o.speed_mps = 5.0;
    rp::DriveRunner runner(std::make_unique<VectorSource>(std::move(v)), cfg, o);
    std::vector<rp::Result> results;
    while (auto step = runner.next()) results.push_back(std::move(step->result));
    ASSERT_EQ(results.size(), 3u);
    ASSERT_TRUE(results[1].fusion && results[2].fusion);
    EXPECT_EQ(results[1].fusion->frames, 2);
    EXPECT_EQ(results[2].fusion->frames, 1);
    EXPECT_EQ(results[2].fusion->reset, "new sequence: another folder");
}

TEST(Drive, ContradictingOrMissingOptionsAreErrorsNamingWhatIsWrong) {
    rp::DriveOptions none;
    EXPECT_THROW(rp::DriveFrames(frames(1), mounted(), none), std::invalid_argument);  // no motion at all

    rp::DriveOptions poses;
    poses.speed_mps = 5.0;
    poses.poses_file = write("drive_poses.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n");
    try {
        rp::DriveRunner runner(frames(1), mounted(), poses);  // fusion off: the poses would be ignored
        FAIL() << "poses without fusion accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("fusion"), std::string::npos);
    }
    rp::DriveOptions both = poses;
    both.poses = std::vector<rp::Pose2>{{0.0, 0.0, 0.0}};
    EXPECT_THROW(rp::DriveFrames(frames(1), mounted(), both), std::invalid_argument);  // a file and poses in memory
    both = rp::DriveOptions{};
    both.motion_file = write("drive_motion_both.csv", "t,speed,yaw_rate\n0,2,0\n1,2,0\n");
    both.motion = rp::MotionTable::from_samples({0.0, 1.0}, {2.0, 2.0}, {0.0, 0.0}, "odometry");
    EXPECT_THROW(rp::DriveFrames(frames(1), mounted(), both), std::invalid_argument);
    rp::Config fused = mounted();
    fused.fusion.method = rp::FusionMethod::Ema;
    rp::DriveRunner short_poses(frames(2), fused, poses);
    EXPECT_TRUE(short_poses.next());
    try {
        short_poses.next();
        FAIL() << "a frame without a pose accepted";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("drive_poses.txt: no pose for frame 1 (it has 1)"), std::string::npos);
    }

    rp::DriveOptions untimed;
    untimed.motion_file = write("drive_motion2.csv", "t,speed,yaw_rate\n0,2,0\n1,2,0\n");
    rp::DriveFrames no_time(frames(1), mounted(), untimed);  // file frames without --frame-rate have no time
    try {
        no_time.next();
        FAIL() << "a frame without a timestamp looked up in the motion table";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("f0.bin: frame has no timestamp"), std::string::npos);
    }
    rp::DriveOptions range;
    range.speed_mps = 1.0;
    range.first_frame = 3;
    range.last_frame = 3;
    EXPECT_THROW(rp::DriveFrames(frames(1), mounted(), range), std::invalid_argument);
}

// What a bag or LiDAR odometry gives in memory drives the frames exactly as the same numbers in files do; poses
// in memory without fusion place the frames and leave the results as they are.
TEST(Drive, MotionAndPosesInMemoryGiveWhatTheirFilesGive) {
    rp::Config fused = mounted();
    fused.fusion.method = rp::FusionMethod::Ema;
    rp::DriveOptions files;
    files.frame_rate_hz = 10.0;
    files.motion_file = write("drive_motion_mem.csv", "t,speed,yaw_rate\n0,4,0.0\n1,6,0.2\n");
    files.poses_file = write("drive_poses_mem.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0.5 0 1 0 0 0 0 1 0\n");
    rp::DriveOptions memory;
    memory.frame_rate_hz = 10.0;
    memory.motion = rp::MotionTable::from_samples({0.0, 1.0}, {4.0, 6.0}, {0.0, 0.2}, "odometry");
    memory.poses = std::vector<rp::Pose2>{{0.0, 0.0, 0.0}, {0.5, 0.0, 0.0}};
    rp::DriveOptions no_poses = memory;
    no_poses.poses.reset();
    rp::DriveRunner a(frames(2), fused, files), b(frames(2), fused, memory);
    rp::DriveRunner placed(frames(2), mounted(), memory), plain(frames(2), mounted(), no_poses);
    for (int k = 0; k < 2; ++k) {
        const auto sa = a.next(), sb = b.next(), sp = placed.next(), sq = plain.next();
        ASSERT_TRUE(sa && sb && sp && sq);
        EXPECT_DOUBLE_EQ(sb->input.motion.speed_mps, 4.0 + 0.2 * k);
        EXPECT_DOUBLE_EQ(sa->input.motion.speed_mps, sb->input.motion.speed_mps);
        EXPECT_DOUBLE_EQ(sa->input.motion.yaw_rate_rps, sb->input.motion.yaw_rate_rps);
        EXPECT_EQ(sb->input.yaw_rate_source, "motion");
        ASSERT_TRUE(sa->result.fusion && sb->result.fusion);
        EXPECT_DOUBLE_EQ(sb->result.fusion->pose.x_m, 0.5 * k);
        EXPECT_DOUBLE_EQ(sa->result.fusion->pose.x_m, sb->result.fusion->pose.x_m);
        EXPECT_FALSE(sb->result.left.count.empty());
        EXPECT_EQ(sa->result.left.count, sb->result.left.count);
        ASSERT_TRUE(sp->input.at.pose);  // fusion off: the poses only place the frames
        EXPECT_DOUBLE_EQ(sp->input.at.pose->x_m, 0.5 * k);
        EXPECT_FALSE(sp->result.fusion);
        EXPECT_EQ(sp->result.left.count, sq->result.left.count);
    }
    rp::DriveOptions short_poses = memory;
    short_poses.poses = std::vector<rp::Pose2>{{0.0, 0.0, 0.0}};
    rp::DriveFrames one_pose(frames(2), mounted(), short_poses);
    EXPECT_TRUE(one_pose.next());
    try {
        one_pose.next();
        FAIL() << "a frame without a pose accepted";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("poses: no pose for frame 1 (it has 1)"), std::string::npos);
    }
}
