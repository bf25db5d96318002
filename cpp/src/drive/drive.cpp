// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/drive/drive.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <utility>

#include "core/text.hpp"
#include "roadpreview/ground/mounting.hpp"
#include "roadpreview/io/live.hpp"
#include "roadpreview/io/readers.hpp"

namespace roadpreview {

namespace {

constexpr double kRadToDeg = 180.0 / M_PI;
constexpr double kMaxMountingTiltRad = 15.0 / kRadToDeg;  // beyond it the "ground" is more likely a wall
constexpr double kMinSensorHeightM = 0.1;  // below it the cloud's origin sits on its ground: a base frame already

template <class... Numbers>
std::string format(const char* pattern, Numbers... values) {
    char text[160];
    std::snprintf(text, sizeof text, pattern, values...);
    return text;
}

// The frame's own timestamp (pcaps), else index / frame rate for file inputs, else none.
std::optional<double> frame_time(const Frame& f, std::int64_t index, double frame_rate_hz) {
    if (f.timestamp) return f.timestamp;
    if (frame_rate_hz > 0.0) return static_cast<double>(index) / frame_rate_hz;
    return std::nullopt;
}

}  // namespace

std::string frame_label(const Frame& f) {
    const bool packets = is_pcap_path(f.source) || is_udp_url(f.source);
    return f.source + (f.frame_id >= 0 && packets ? " #" + std::to_string(f.frame_id) : "");
}

DriveFrames::DriveFrames(std::unique_ptr<FrameSource> source, Config cfg, DriveOptions options)
    : source_(std::move(source)), cfg_(std::move(cfg)), options_(std::move(options)) {
    if (!source_) throw std::invalid_argument("DriveFrames: no frame source");
    const bool has_motion = !options_.motion_file.empty() || options_.motion;
    if (!options_.speed_mps && !has_motion && options_.poses_file.empty() && !options_.poses)
        throw std::invalid_argument("give the vehicle's motion: a speed (and yaw rate), a motion file or a poses file");
    if (!options_.motion_file.empty() && options_.motion)
        throw std::invalid_argument("give a motion file or a motion table, not both");
    if (!options_.poses_file.empty() && options_.poses)
        throw std::invalid_argument("give a poses file or poses, not both");
    if (options_.speed_mps && !std::isfinite(*options_.speed_mps))
        throw std::invalid_argument("the speed must be finite");
    if (options_.speed_mps && std::abs(*options_.speed_mps) > kMaxSpeedMps)
        throw std::invalid_argument("the speed must be within ±" + number_text(kMaxSpeedMps) +
                                    " m/s (no ground vehicle drives faster: a unit mixed up?), got " +
                                    number_text(*options_.speed_mps) + " m/s");
    if (options_.yaw_rate_rps && !std::isfinite(*options_.yaw_rate_rps))
        throw std::invalid_argument("the yaw rate must be finite");
    if (!(options_.frame_rate_hz >= 0.0) || !std::isfinite(options_.frame_rate_hz))
        throw std::invalid_argument("the frame rate must be >= 0 Hz");
    if (options_.first_frame < 0 || options_.first_frame >= options_.last_frame)
        throw std::invalid_argument("the frame range must have 0 <= first < last");
    table_ = options_.motion_file.empty() ? std::move(options_.motion) : MotionTable::read_csv(options_.motion_file);
    poses_ = options_.poses_file.empty() ? std::move(options_.poses) : read_kitti_poses(options_.poses_file);
    poses_name_ = options_.poses_file.empty() ? "poses" : options_.poses_file;
}

void DriveFrames::note(bool warning, const std::string& text) const {
    if (options_.on_note) options_.on_note(warning, text);
}

// With neither sensor_height nor extrinsics, the first frame whose ground gives a plausible mounting gives it
// (a recording or a live stream may start with part of a rotation that holds no road ahead); until then the
// points are taken as base-frame points, and the first frame without one says so. Returns whether this frame
// gave it. A ground under the cloud's origin settles it: the cloud is in a base frame already.
bool DriveFrames::estimate_mounting_from(const Frame& f) {
    const auto m = estimate_mounting(points_view(f.points.data(), f.points.rows(), f.points.cols()), cfg_.ground);
    const std::string missing = "no sensor height or extrinsics given (--sensor-height, --extrinsics), and ";
    const auto try_later = [&](const std::string& why) {
        if (!mounting_warned_)
            note(true, missing + why + ": the points are taken as base-frame points until a later frame's ground "
                                       "gives the mounting");
        mounting_warned_ = true;
        return false;
    };
    if (!m) return try_later("no ground in " + frame_label(f) + " to estimate the mounting from");
    const std::string figures = format("height %.2f m, roll %.2f°, pitch %.2f°", m->height_m,
                                       m->roll_rad * kRadToDeg, m->pitch_rad * kRadToDeg);
    if (m->height_m < kMinSensorHeightM) {
        // A base frame's ground is level: one tilted as far as check_mounting warns of is no base frame either.
        const double tilt_deg = std::acos(std::cos(m->roll_rad) * std::cos(m->pitch_rad)) * kRadToDeg;
        if (tilt_deg > kMountingMaxTiltDeg)
            return try_later("the ground in " + frame_label(f) + " lies at the cloud's origin but tilted " +
                             format("%.1f°", tilt_deg) + " (" + figures +
                             "): neither a level base frame nor a mounting");
        note(true, missing + "the ground in " + frame_label(f) + " lies at the cloud's origin (" + figures +
             "): the points are taken as base-frame points");
        mounting_settled_ = true;
        return false;
    }
    if (std::abs(m->roll_rad) > kMaxMountingTiltRad || std::abs(m->pitch_rad) > kMaxMountingTiltRad)
        return try_later("the ground in " + frame_label(f) + " gives no plausible mounting (" + figures + ")");
    cfg_.extrinsics = to_extrinsics(*m);
    mounting_source_ = "estimated";
    mounting_frame_ = frame_label(f);
    mounting_settled_ = true;
    note(false, "no sensor height or extrinsics given (--sensor-height, --extrinsics): mounting estimated from the "
                "ground in " + frame_label(f) + ": " + figures + " (mounting.source = \"estimated\" in the output" +
                    (mounting_warned_ ? "; the frames before it were taken as base-frame points)" : ")"));
    return true;
}

std::optional<DriveFrame> DriveFrames::next() {
    std::optional<Frame> frame;
    for (;;) {
        if (read_ >= options_.last_frame) return std::nullopt;
        frame = source_->next();
        if (!frame) return std::nullopt;
        if (read_++ >= options_.first_frame) break;
    }
    DriveFrame d;
    d.index = read_ - 1;
    if (!mounting_settled_ && !cfg_.sensor_height && !cfg_.extrinsics)
        d.mounting_estimated = estimate_mounting_from(*frame);
    d.new_sequence = started_ && !frame->sequence_break.empty();
    started_ = true;
    d.at.timestamp_s = frame_time(*frame, d.index, options_.frame_rate_hz);
    if (table_) {
        if (!d.at.timestamp_s)
            throw std::runtime_error(frame->source + ": frame has no timestamp to look up in " + table_->source() +
                                     " (give --frame-rate, or frame_rate in Python, for file inputs)");
        d.motion = table_->at(*d.at.timestamp_s);
        d.yaw_rate_source = "motion";
    } else {
        d.motion.speed_mps = options_.speed_mps.value_or(0.0);
        const auto imu = imu_yaw_rate(frame->imu, effective_extrinsics(cfg_));
        d.motion.yaw_rate_rps = options_.yaw_rate_rps ? *options_.yaw_rate_rps : imu.value_or(0.0);
        d.yaw_rate_source = options_.yaw_rate_rps ? "option" : imu ? "imu" : "default";
    }
    if (poses_) {
        if (d.index >= static_cast<std::int64_t>(poses_->size()))
            throw std::runtime_error(poses_name_ + ": no pose for frame " + std::to_string(d.index) + " (it has " +
                                     std::to_string(poses_->size()) + ")");
        d.at.pose = (*poses_)[static_cast<std::size_t>(d.index)];
        check_pose_step(d);
    }
    d.frame = std::move(*frame);
    return d;
}

// Notes, once, two consecutive frames whose poses moved less than half or more than twice what the speed drove
// between their timestamps (when that is over 0.1 m): poses of another frame than the sensor's — KITTI's 00.txt is
// the left camera's, whose forward axis is z — read as (t_x, t_y, yaw) hardly move, and the map is built wrong.
void DriveFrames::check_pose_step(const DriveFrame& d) {
    constexpr double kMinDrivenM = 0.1, kMaxRatio = 2.0;
    const Place here{d.index, d.at.timestamp_s, *d.at.pose, d.motion.speed_mps};
    const std::optional<Place> before = std::exchange(previous_, here);
    if (!before || pose_step_noted_ || !here.timestamp_s || !before->timestamp_s || here.index != before->index + 1)
        return;
    const double dt = *here.timestamp_s - *before->timestamp_s;
    const double driven = std::abs(0.5 * (here.speed_mps + before->speed_mps)) * dt;
    const double moved = std::hypot(here.pose.x_m - before->pose.x_m, here.pose.y_m - before->pose.y_m);
    if (!(driven > kMinDrivenM) || (moved * kMaxRatio >= driven && moved <= kMaxRatio * driven)) return;
    pose_step_noted_ = true;
    char text[200];
    std::snprintf(text, sizeof text, ": the poses of frames %lld and %lld lie %.3f m apart where the speed drove %.3f m "
                  "in %.3f s", static_cast<long long>(before->index), static_cast<long long>(here.index), moved, driven,
                  dt);
    note(true, poses_name_ + text + ": are they the sensor's poses in its own axes (x forward, y left)? KITTI's "
                                    "poses are the left camera's (README, \"Fusion on real recordings\")");
}

// A poses file is there to move the fusion map (--poses); poses in memory may also just place the frames
// (DriveStep::input.at.pose: a batch's segments), with or without fusion.
DriveRunner::DriveRunner(std::unique_ptr<FrameSource> source, Config cfg, DriveOptions options)
    : on_note_(options.on_note), has_poses_file_(!options.poses_file.empty()),
      frames_(std::move(source), std::move(cfg), std::move(options)) {
    if (frames_.config().fusion.method == FusionMethod::None && has_poses_file_)
        throw std::invalid_argument("poses move the fusion map: set fusion.method to ema or kalman too");
}

std::optional<DriveStep> DriveRunner::next() {
    std::optional<DriveFrame> input = frames_.next();
    if (!input) return std::nullopt;
    // Made at the first frame, and made again when a later frame gives the mounting: what the estimator (and its
    // fusion map) held was in the wrong frame.
    const bool remounted = estimator_ && input->mounting_estimated;
    if (!estimator_ || remounted) estimator_.emplace(frames_.config());
    if (input->new_sequence) estimator_->reset();
    DriveStep step{std::move(*input), {}};
    const DriveFrame& in = step.input;
    Result& r = step.result;
    try {
        r = estimator_->process(in.frame, in.motion.speed_mps, in.motion.yaw_rate_rps, in.at);
    } catch (const std::invalid_argument& e) {  // the motion or the frame refused: say which frame
        const std::string what = e.what();
        throw std::invalid_argument(what.rfind(in.frame.source, 0) == 0 ? what : in.frame.source + ": " + what);
    }
    r.frame = processed_++;  // the drive's count, whichever estimator processed it
    r.yaw_rate_source = in.yaw_rate_source;
    // A frame file that does not continue the previous one's sequence starts the map afresh; the output says why.
    if (in.new_sequence && r.fusion) r.fusion->reset = "new sequence: " + in.frame.sequence_break;
    if (remounted && r.fusion) r.fusion->reset = "mounting estimated";
    if (!frames_.mounting_source().empty()) r.mounting_source = frames_.mounting_source();
    check_mounting_of(r, in.frame);
    check_beams_of(in.frame);
    check_body_of(r, in.frame);
    check_heights_of(in.frame);
    return step;
}

// Notes a first frame whose points all have z = 0: a 2-D scanner's scan made a cloud (a LaserScan's), which holds no
// road heights. Taken as base-frame points, every point of it within the region would be "ground". (No recorded 3-D
// cloud holds one exact height; a synthetic flat road at z = 0 exactly would be noted too, harmlessly.)
void DriveRunner::check_heights_of(const Frame& f) {
    if (std::exchange(heights_checked_, true) || !on_note_) return;
    float lowest = INFINITY, highest = -INFINITY;
    Eigen::Index finite = 0;
    for (Eigen::Index i = 0; i < f.points.rows(); ++i)
        if (std::isfinite(f.points(i, 0)) && std::isfinite(f.points(i, 1)) && std::isfinite(f.points(i, 2))) {
            lowest = std::min(lowest, f.points(i, 2)), highest = std::max(highest, f.points(i, 2));
            ++finite;
        }
    if (finite < 3 || lowest != 0.0f || highest != 0.0f) return;  // too few points for a plane: the result says so
    on_note_(true, frame_label(f) + ": every point has z = 0, as a 2-D scanner's scan made a point cloud has: it holds "
                                    "no road heights; give a 3-D point cloud (2-D scanners' scans go to "
                                    "`roadpreview roadside`)");
}

// Notes, once, one obstacle in both wheels' paths from the very start of the region of interest: a sensor on the
// roof may see the vehicle's own bonnet there (the bundled OS-0-128 capture: a sheet 1.0–2.1 m ahead across both
// paths), which no profile can pass and every frame would report.
void DriveRunner::check_body_of(const Result& r, const Frame& f) {
    constexpr double kAtStartM = 0.25;  // s of its nearest point within this of the region's start
    if (body_noted_ || !on_note_ || !r.left.obstacles || !r.right.obstacles) return;
    const double start = frames_.config().ground.roi_x_min_m;
    for (const PathObstacle& left : *r.left.obstacles) {
        if (left.s_start > start + kAtStartM) continue;
        for (const PathObstacle& right : *r.right.obstacles) {
            if (right.id != left.id || right.s_start > start + kAtStartM) continue;
            body_noted_ = true;
            char text[200];
            std::snprintf(text, sizeof text, ": an obstacle %.2f m high stands in both wheels' paths from the start of "
                          "the region of interest (%.2f m ahead)", left.height, start);
            on_note_(true, frame_label(f) + text + ": if it is the vehicle's own body, start the region past it "
                                                   "(ground.roi_x_min_m in --config)");
            return;
        }
    }
}

// Notes the first frame whose points carry no beams while the beams' errors are to be counted: they are not.
void DriveRunner::check_beams_of(const Frame& f) {
    if (!beam_errors_counted(frames_.config().profile) || !f.beams.empty() || beamless_noted_ || !on_note_) return;
    beamless_noted_ = true;
    on_note_(true, frame_label(f) + ": its points carry no beam numbers, so the beams' errors (profile.beam_sigma_deg, "
                   "beam_sigmas_deg, --beam-sigma-deg) are not counted; KITTI .bin files get them from a beams file "
                   "with beam_index scan_order (--beam-calibration)");
}

// Notes the first frame whose fitted ground disagrees with the mounting — given, estimated, or none (the points
// taken as base-frame points); counts them all. An estimate the frames' ground does not bear out was read off
// something else (a wall, a car's roof, the vehicle's own bonnet, undergrowth), and every height is off by it.
void DriveRunner::check_mounting_of(const Result& r, const Frame& f) {
    if (!r.plane) return;
    const MountingCheck c = check_mounting(*r.plane);
    if (!c.disagrees || disagreeing_++ > 0 || !on_note_) return;
    char text[240];
    std::snprintf(text, sizeof text, ": the fitted ground is %.2f m %s the base origin and tilted %.1f°: ",
                  std::abs(c.offset_m), c.offset_m >= 0 ? "below" : "above", c.tilt_deg);
    std::string why = text;
    if (r.mounting_source == "none") {
        why += "the points are not base-frame points, as they were taken to be; give --sensor-height / --extrinsics";
    } else {
        std::snprintf(text, sizeof text, "the sensor is about %.2f m up, not %.2f m", r.extrinsics.z_m + c.offset_m,
                      r.extrinsics.z_m);
        why += text;
        // The estimate fitted all the points below the sensor; this frame's ground, those of its region ahead.
        if (r.mounting_source == "estimated")
            why += frames_.mounting_frame() == frame_label(f)
                       ? " as estimated from all of this frame's points below the sensor"
                       : " as estimated from the ground in " + frames_.mounting_frame();
        why += "; check --sensor-height / --extrinsics";
    }
    on_note_(true, frame_label(f) + why);
}

}  // namespace roadpreview
