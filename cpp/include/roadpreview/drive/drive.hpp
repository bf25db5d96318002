// SPDX-License-Identifier: BSD-3-Clause
// Drives, not frames: the policy that turns a recording into per-frame results — each frame's time, motion and
// pose, the sensor's mounting, fusion resets at sequence breaks — in one place, used by the CLI (`roadpreview
// run`, `roadpreview calibrate`), the Python `rp.run` and batch runs alike (docs/method.md, "Drives").
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "roadpreview/core/config.hpp"
#include "roadpreview/fusion/fusion.hpp"
#include "roadpreview/io/frame_source.hpp"
#include "roadpreview/paths/motion.hpp"
#include "roadpreview/pipeline/pipeline.hpp"

namespace roadpreview {

/// Where a drive's frames get their motion and time from. The motion table (a file or one in memory, not both)
/// wins over a constant yaw rate, which wins over the frames' IMU, which wins over 0 (driving straight).
struct DriveOptions {
    std::optional<double> speed_mps;     ///< constant speed (m/s, negative reversing); needed without motion_file
    std::optional<double> yaw_rate_rps;  ///< constant yaw rate (rad/s, positive left)
    std::string motion_file;             ///< CSV t,speed,yaw_rate looked up at each frame's time
    std::optional<MotionTable> motion;   ///< the same in memory (a bag's odometry topic, LiDAR odometry)
    /// KITTI poses, one per frame of the recording: each frame's pose (DriveFrame::at), moving the fusion map
    /// (DriveRunner refuses them without fusion)
    std::string poses_file;
    /// The same in memory (x, y, yaw per frame); without fusion they only place the frames (a batch's segments)
    std::optional<std::vector<Pose2>> poses;
    double frame_rate_hz = 0.0;          ///< frames without a timestamp get index / rate (0: no timestamp)
    std::int64_t first_frame = 0;        ///< the frames [first_frame, last_frame) of the recording are processed
    std::int64_t last_frame = std::numeric_limits<std::int64_t>::max();
    /// Notes for the user (warning = true: the mounting could not be estimated, or disagrees with the ground;
    /// false: the mounting was estimated); unset: dropped.
    std::function<void(bool warning, const std::string& text)> on_note;
};

/// One frame of a drive with what the drive's policy gives it.
struct DriveFrame {
    Frame frame;
    std::int64_t index = 0;       ///< 0-based position in the recording (skipped frames count)
    FrameMotion at;               ///< timestamp (the frame's own, else index / frame rate) and pose (poses file)
    Motion motion;                ///< speed and yaw rate
    std::string yaw_rate_source;  ///< "motion", "option", "imu" or "default"
    bool new_sequence = false;    ///< a frame file that does not continue the previous one's sequence
    bool mounting_estimated = false;  ///< this frame's ground gave the mounting (DriveFrames::config() has it now)
};

/// A recording's frames in order with their time, motion and pose. When the config has neither sensor_height nor
/// extrinsics, the first processed frame whose ground gives a plausible mounting gives it (estimate_mounting;
/// the frames before it stay base-frame points). Throws
/// std::invalid_argument for options that contradict each other, std::runtime_error naming the file for bad input.
class DriveFrames {
public:
    DriveFrames(std::unique_ptr<FrameSource> source, Config cfg, DriveOptions options);

    /// The next frame in [first_frame, last_frame), or nullopt at the end.
    std::optional<DriveFrame> next();

    /// The config with the mounting a frame's ground gave (before it: the one given).
    const Config& config() const { return cfg_; }
    /// "estimated" once a frame's ground gave the mounting, else empty.
    const std::string& mounting_source() const { return mounting_source_; }
    /// The frame (its label, as in notes) whose ground gave the mounting; empty before one did.
    const std::string& mounting_frame() const { return mounting_frame_; }
    SourceInfo info() const { return source_->info(); }
    /// Frames read from the recording so far, skipped ones included.
    std::int64_t frames_read() const { return read_; }

private:
    bool estimate_mounting_from(const Frame& f);
    void check_pose_step(const DriveFrame& d);
    void note(bool warning, const std::string& text) const;

    std::unique_ptr<FrameSource> source_;
    Config cfg_;
    DriveOptions options_;
    std::optional<MotionTable> table_;
    std::optional<std::vector<Pose2>> poses_;
    std::string poses_name_;  // for messages: the poses file, or "poses"
    std::string mounting_source_, mounting_frame_;
    std::int64_t read_ = 0;
    bool started_ = false;
    bool mounting_settled_ = false;  // estimated, or the cloud is in a base frame already
    bool mounting_warned_ = false;   // a frame without a plausible mounting was noted
    struct Place {  // of the last frame with a pose
        std::int64_t index;
        std::optional<double> timestamp_s;
        Pose2 pose;
        double speed_mps;
    };
    std::optional<Place> previous_;
    bool pose_step_noted_ = false;  // poses that disagree with the speed were noted
};

/// One processed frame of a drive.
struct DriveStep {
    DriveFrame input;
    Result result;
};

/// DriveFrames through one Estimator: the result of every frame, the fusion map reset at sequence breaks, each
/// result saying where its yaw rate and mounting came from (docs/output.md).
class DriveRunner {
public:
    DriveRunner(std::unique_ptr<FrameSource> source, Config cfg, DriveOptions options);

    /// The next frame's result, or nullopt at the end of the recording.
    std::optional<DriveStep> next();

    const Config& config() const { return frames_.config(); }
    SourceInfo info() const { return frames_.info(); }
    std::int64_t frames_read() const { return frames_.frames_read(); }
    /// Frames whose fitted ground disagreed with the mounting, given, estimated or none (the first one is noted).
    std::int64_t mounting_disagreements() const { return disagreeing_; }

private:
    void check_mounting_of(const Result& r, const Frame& f);
    void check_beams_of(const Frame& f);
    void check_body_of(const Result& r, const Frame& f);
    void check_heights_of(const Frame& f);

    std::function<void(bool, const std::string&)> on_note_;
    bool has_poses_file_;
    DriveFrames frames_;
    std::optional<Estimator> estimator_;  // made at the first frame, again when a later one gives the mounting
    std::int64_t disagreeing_ = 0;
    bool beamless_noted_ = false;
    bool body_noted_ = false;  // an obstacle across both paths at the region's start was noted
    bool heights_checked_ = false;  // the first frame's points were checked for heights at all
    std::int64_t processed_ = 0;
};

/// A short name of a frame for messages: its file, and its frame id in a pcap.
std::string frame_label(const Frame& f);

}  // namespace roadpreview
