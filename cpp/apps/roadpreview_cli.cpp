// SPDX-License-Identifier: BSD-3-Clause
// roadpreview — command-line front end: `roadpreview run INPUT... [options]` writes one JSON line per frame;
// `roadpreview info INPUT...` describes a recording.
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <optional>

#include <CLI/CLI.hpp>

#include "roadpreview/roadpreview.hpp"

namespace rp = roadpreview;

namespace {

struct RunOptions {
    std::vector<std::string> inputs;
    double speed = 0.0;
    double yaw_rate = 0.0;
    double sensor_height = 0.0;
    std::vector<double> extrinsics;
    double track_width = 0.0;
    double tire_width = 0.0;
    std::string ground;
    std::string clusters;
    double cluster_tolerance = 0.0;
    double frame_rate = 0.0;
    std::string config_file;
    std::string output;
    bool quiet = false;
    std::string motion_file;
    std::string frames;  // "A:B"
    rp::SourceOptions source;
    std::string fusion;
    double alpha = 0.0;
    std::string poses_file;
    std::vector<std::string> stereo;  // LEFT RIGHT: image files or directories of them
    std::string calib;
    std::string disparity;
};

// Config file first, then the flags that were given on the command line.
rp::Config build_config(const RunOptions& o, const CLI::App& run) {
    rp::Config cfg = o.config_file.empty() ? rp::Config{} : rp::config_from_file(o.config_file);
    if (run.count("--sensor-height")) {
        cfg.sensor_height = o.sensor_height;
        cfg.extrinsics.reset();
    }
    if (run.count("--extrinsics")) {
        const auto& e = o.extrinsics;
        cfg.extrinsics = rp::Extrinsics{e[0], e[1], e[2], e[3], e[4], e[5]};
        cfg.sensor_height.reset();
    }
    if (run.count("--track-width")) cfg.track_width = o.track_width;
    if (run.count("--tire-width")) cfg.tire_width = o.tire_width;
    if (run.count("--ground")) cfg.ground.method = o.ground == "ransac" ? rp::GroundMethod::Ransac : rp::GroundMethod::Pca;
    if (run.count("--clusters")) cfg.obstacles.enabled = o.clusters == "on";
    if (run.count("--cluster-tolerance")) cfg.obstacles.cluster_tolerance_m = o.cluster_tolerance;
    if (run.count("--fusion"))
        cfg.fusion.method = o.fusion == "ema" ? rp::FusionMethod::Ema
                            : o.fusion == "kalman" ? rp::FusionMethod::Kalman : rp::FusionMethod::None;
    if (run.count("--alpha")) cfg.fusion.alpha = o.alpha;
    if (run.count("--frame-rate")) cfg.fusion.frame_rate_hz = o.frame_rate;
    rp::validate(cfg);
    return cfg;
}

std::string class_of(const rp::Roughness& r) { return r.iso_class ? std::string(1, *r.iso_class) : "-"; }

// ", 12 clusters (L 1, R 0 in the paths)" when clustering is on.
std::string obstacles_of(const rp::Result& r) {
    if (!r.obstacles) return "";
    const auto in_path = [](const rp::Profile& p) { return p.obstacles ? p.obstacles->size() : 0; };
    return ", " + std::to_string(r.obstacles->size()) + " clusters (L " + std::to_string(in_path(r.left)) + ", R " +
           std::to_string(in_path(r.right)) + " in the paths)";
}

// Half-open range of frame indices [first, last) from "A:B", "A:" or ":B".
std::pair<std::int64_t, std::int64_t> parse_frame_range(const std::string& text) {
    constexpr auto kAll = std::numeric_limits<std::int64_t>::max();
    if (text.empty()) return {0, kAll};
    const auto colon = text.find(':');
    const auto number = [&](const std::string& part, std::int64_t fallback) -> std::int64_t {
        if (part.empty()) return fallback;
        std::size_t used = 0;
        long long v = -1;
        try {
            v = std::stoll(part, &used);
        } catch (const std::exception&) {
        }
        if (used != part.size() || v < 0) throw std::invalid_argument("--frames " + text + ": expected A:B with A, B >= 0");
        return v;
    };
    if (colon == std::string::npos) throw std::invalid_argument("--frames " + text + ": expected A:B, A: or :B");
    const auto range = std::make_pair(number(text.substr(0, colon), 0), number(text.substr(colon + 1), kAll));
    if (range.first >= range.second) throw std::invalid_argument("--frames " + text + ": A must be smaller than B");
    return range;
}

std::string frame_label(const rp::Frame& f) {
    return f.source + (f.frame_id >= 0 && rp::is_pcap_path(f.source) ? " #" + std::to_string(f.frame_id) : "");
}

void report_frame(std::size_t i, std::size_t total, const rp::Frame& f, const rp::Result& r) {
    const std::string counter = total ? std::to_string(i + 1) + "/" + std::to_string(total) : std::to_string(i + 1);
    std::string decode;
    if (f.diagnostics.missing_columns) decode += ", " + std::to_string(f.diagnostics.missing_columns) + " columns missing";
    if (f.diagnostics.skipped_packets) decode += ", " + std::to_string(f.diagnostics.skipped_packets) + " bad packets skipped";
    if (!f.diagnostics.complete && decode.empty()) decode = ", partial sweep";
    std::fprintf(stderr, "[%s] %s: %lld points, %lld ground%s, class L=%s R=%s vehicle=%s%s%s, %.2f ms%s\n",
                 counter.c_str(), frame_label(f).c_str(), static_cast<long long>(r.points.input),
                 static_cast<long long>(r.points.ground), obstacles_of(r).c_str(), class_of(r.left.roughness).c_str(),
                 class_of(r.right.roughness).c_str(), class_of(r.vehicle).c_str(), r.reason.empty() ? "" : " — ",
                 r.reason.c_str(), r.timing_ms.total, decode.c_str());
}

void report_source(const rp::SourceInfo& s) {
    if (s.format == "files") return;
    if (s.lidar_port == 0) {  // stereo: no packets
        std::fprintf(stderr, "roadpreview: %s, %s, %s, %s\n", s.format.c_str(), s.sensor_model.c_str(), s.profile.c_str(),
                     s.metadata.c_str());
        return;
    }
    std::fprintf(stderr, "roadpreview: %s, %s, %s, lidar UDP port %d (%s)%s%s\n", s.format.c_str(),
                 s.sensor_model.c_str(), s.profile.c_str(), s.lidar_port, s.lidar_port_origin.c_str(),
                 s.metadata.empty() ? "" : ", ", s.metadata.c_str());
    for (const auto& note : s.notes) std::fprintf(stderr, "roadpreview: %s\n", note.c_str());
}

// Speed and yaw rate of one frame, and where the yaw rate came from.
struct FrameMotion {
    rp::Motion motion;
    std::string yaw_rate_source;
};

FrameMotion motion_for(const RunOptions& o, const CLI::App& run, const std::optional<rp::MotionTable>& table,
                       const rp::Frame& f, const rp::Config& cfg) {
    if (table) {
        if (!f.timestamp) throw std::runtime_error(f.source + ": frame has no timestamp to look up in " + table->source() +
                                                   " (use --frame-rate for file inputs)");
        return {table->at(*f.timestamp), "motion"};
    }
    if (run.count("--yaw-rate")) return {{o.speed, o.yaw_rate}, "option"};
    if (const auto imu = rp::imu_yaw_rate(f.imu, rp::effective_extrinsics(cfg))) return {{o.speed, *imu}, "imu"};
    return {{o.speed, 0.0}, "default"};
}

bool is_stereo(const RunOptions& o) { return !o.stereo.empty() || !o.disparity.empty(); }

// The frames of the run: stereo pairs / disparity images, or the INPUT files and recordings.
std::unique_ptr<rp::FrameSource> open_source(const RunOptions& o, const rp::Config& cfg) {
    if (!is_stereo(o)) return rp::open_frames(o.inputs, o.source);
    rp::StereoInputs in;
    if (!o.stereo.empty()) in.left = {o.stereo[0]}, in.right = {o.stereo[1]};
    if (!o.disparity.empty()) in.disparity = {o.disparity};
    in.calibration = o.calib;
    return std::make_unique<rp::StereoSource>(in, cfg);
}

// The config's camera pose, else the stereo calibration's (a YAML with extrinsics).
rp::Config with_camera_pose(rp::Config cfg, const RunOptions& o) {
    if (!is_stereo(o) || cfg.extrinsics || cfg.sensor_height) return cfg;
    const rp::StereoCalibration calib = rp::read_stereo_calibration(o.calib);
    cfg.extrinsics = rp::stereo_camera_pose(cfg, calib);
    return cfg;
}

void check_inputs(const RunOptions& o) {
    if (is_stereo(o) && !o.inputs.empty())
        throw std::invalid_argument("give INPUT files or --stereo/--disparity, not both");
    if (!is_stereo(o) && o.inputs.empty())
        throw std::invalid_argument("give INPUT files, or --stereo LEFT RIGHT / --disparity DISP with --calib");
    if (is_stereo(o) && o.calib.empty()) throw std::invalid_argument("--stereo and --disparity need --calib FILE");
}

int run(const RunOptions& o, const CLI::App& app) {
    if (!app.count("--speed") && o.motion_file.empty())
        throw std::invalid_argument("give the vehicle's motion: --speed (and --yaw-rate), or --motion FILE");
    check_inputs(o);
    const rp::Config cfg = with_camera_pose(build_config(o, app), o);
    rp::Estimator est(cfg);
    const auto [first, last] = parse_frame_range(o.frames);
    std::optional<rp::MotionTable> table;
    if (!o.motion_file.empty()) table = rp::MotionTable::read_csv(o.motion_file);
    const auto source = open_source(o, cfg);
    const std::size_t total = source->info().format == "files" ? rp::expand_inputs(o.inputs).size() : 0;
    if (!o.poses_file.empty() && cfg.fusion.method == rp::FusionMethod::None)
        throw std::invalid_argument("--poses moves the fusion map: give --fusion ema or kalman too");
    std::vector<rp::Pose2> poses;
    if (!o.poses_file.empty()) poses = rp::read_kitti_poses(o.poses_file);
    std::ofstream file;
    if (!o.output.empty()) {
        file.open(o.output);
        if (!file) throw std::runtime_error(o.output + ": cannot open output file for writing");
    }
    std::ostream& out = o.output.empty() ? std::cout : file;

    std::map<std::string, int> classes;
    std::vector<double> ms;
    std::int64_t index = 0;
    for (; index < last; ++index) {
        std::optional<rp::Frame> frame = source->next();
        if (!frame) break;
        if (index == 0 && !o.quiet) report_source(source->info());
        if (index < first) continue;
        const FrameMotion m = motion_for(o, app, table, *frame, cfg);
        rp::FrameMotion at{frame->timestamp, std::nullopt};
        if (!at.timestamp_s && o.frame_rate > 0.0) at.timestamp_s = static_cast<double>(index) / o.frame_rate;
        if (!o.poses_file.empty()) {
            if (index >= static_cast<std::int64_t>(poses.size()))
                throw std::runtime_error(o.poses_file + ": no pose for frame " + std::to_string(index) + " (it has " +
                                         std::to_string(poses.size()) + ")");
            at.pose = poses[static_cast<std::size_t>(index)];
        }
        rp::Result r = est.process(*frame, m.motion.speed_mps, m.motion.yaw_rate_rps, at);
        r.yaw_rate_source = m.yaw_rate_source;
        out << rp::result_to_json(r) << '\n';
        if (!out) throw std::runtime_error((o.output.empty() ? "stdout" : o.output) + ": write failed");
        ++classes[class_of(r.vehicle)];
        ms.push_back(r.timing_ms.total);
        if (!o.quiet) report_frame(static_cast<std::size_t>(index), total, *frame, r);
    }
    if (ms.empty())
        throw std::runtime_error((o.inputs.empty() ? o.calib : o.inputs[0]) + ": no frames" +
                                 (first > 0 ? " from index " + std::to_string(first) + " on (it has " +
                                                  std::to_string(index) + ")"
                                            : std::string()));
    std::sort(ms.begin(), ms.end());
    std::fprintf(stderr, "roadpreview: %zu frame(s), pipeline median %.2f ms, max %.2f ms; vehicle classes:", ms.size(),
                 ms[ms.size() / 2], ms.back());
    for (const auto& [cls, n] : classes) std::fprintf(stderr, " %s×%d", cls.c_str(), n);
    std::fprintf(stderr, "\n");
    return 0;
}

// Decodes every frame and prints what the recording holds.
int info(const std::vector<std::string>& inputs, const rp::SourceOptions& options) {
    const auto source = rp::open_frames(inputs, options);
    std::int64_t frames = 0, complete = 0, imu = 0, missing = 0, skipped = 0, first_id = -1, last_id = -1;
    std::vector<Eigen::Index> points;
    std::optional<double> t0, t1;
    while (std::optional<rp::Frame> f = source->next()) {
        ++frames;
        complete += f->diagnostics.complete;
        imu += static_cast<std::int64_t>(f->imu.size());
        missing += f->diagnostics.missing_columns;
        skipped += f->diagnostics.skipped_packets;
        points.push_back(f->points.rows());
        if (first_id < 0) first_id = f->frame_id;
        last_id = f->frame_id;
        if (f->timestamp) {
            if (!t0) t0 = f->timestamp;
            t1 = f->timestamp;
        }
    }
    const rp::SourceInfo s = source->info();
    std::printf("input: %s\nformat: %s\n", inputs[0].c_str(), s.format.c_str());
    if (!s.sensor_model.empty()) std::printf("sensor model: %s\n", s.sensor_model.c_str());
    if (!s.profile.empty()) std::printf("packet profile: %s\n", s.profile.c_str());
    if (!s.metadata.empty()) std::printf("metadata: %s\n", s.metadata.c_str());
    if (s.lidar_port) std::printf("lidar UDP port: %d (%s)\n", s.lidar_port, s.lidar_port_origin.c_str());
    if (s.frame_rate_hz > 0) std::printf("frame rate: %g Hz (nominal)\n", s.frame_rate_hz);
    std::printf("frames: %lld (%lld complete), frame ids %lld..%lld\n", static_cast<long long>(frames),
                static_cast<long long>(complete), static_cast<long long>(first_id), static_cast<long long>(last_id));
    if (!points.empty()) {
        std::sort(points.begin(), points.end());
        std::printf("points per frame: min %lld, median %lld, max %lld\n", static_cast<long long>(points.front()),
                    static_cast<long long>(points[points.size() / 2]), static_cast<long long>(points.back()));
    }
    if (t0) {
        const double period = s.frame_rate_hz > 0 ? 1.0 / s.frame_rate_hz : 0.0;
        std::printf("duration: %.3f s (first frame at %.6f s, UNIX time)\n", *t1 - *t0 + period, *t0);
    }
    if (missing) std::printf("missing columns: %lld\n", static_cast<long long>(missing));
    if (skipped) std::printf("skipped packets: %lld\n", static_cast<long long>(skipped));
    if (imu) std::printf("IMU samples: %lld\n", static_cast<long long>(imu));
    for (const auto& note : s.notes) std::printf("note: %s\n", note.c_str());
    return 0;
}

void add_source_options(CLI::App* cmd, rp::SourceOptions& s) {
    cmd->add_option("--meta", s.meta, "Ouster metadata JSON (default: found next to the pcap by name)");
    cmd->add_option("--sensor-model", s.sensor_model, "Velodyne model: VLP-16, VLP-32C, HDL-32E, HDL-64E (default: from the packets)");
    cmd->add_option("--calibration", s.calibration, "Velodyne calibration YAML (ROS velodyne_pointcloud format; HDL-64E needs one)");
    cmd->add_option("--cut-angle", s.cut_angle_deg, "Velodyne: azimuth (deg, 0 = ahead) where one sweep ends and the next begins")
        ->check(CLI::Range(0.0, 359.999));
    cmd->add_option("--lidar-port", s.lidar_port, "UDP port of the lidar packets (default: metadata, else detected)")
        ->check(CLI::Range(1, 65535));
    cmd->add_flag("--skip-bad-packets", s.skip_bad_packets, "Skip and count lidar packets that do not decode instead of stopping");
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"roadpreview: road height profiles and ISO 8608 roughness ahead of the wheels, from LiDAR"};
    app.set_version_flag("--version", std::string("roadpreview ") + rp::kVersion);
    app.require_subcommand(1);

    RunOptions o;
    CLI::App* run_cmd = app.add_subcommand("run", "Process KITTI .bin / .pcd frames (files or directories) or a pcap recording");
    run_cmd->add_option("INPUT", o.inputs, "Frame files, or directories of them (sorted by name), or one Ouster/Velodyne .pcap");
    run_cmd->add_option("--stereo", o.stereo, "Rectified stereo pairs: LEFT RIGHT image files, or directories of PNGs "
                                               "(paired in name order); matched with StereoSGBM")
        ->expected(2);
    run_cmd->add_option("--calib", o.calib, "Stereo calibration: KITTI calib.txt (P2/P3) or YAML (fx, fy, cx, cy, "
                                             "baseline, optional extrinsics)");
    run_cmd->add_option("--disparity", o.disparity, "Precomputed disparity: a 16-bit PNG (disparity x 256) or a "
                                                     "directory of them, used instead of matching");
    auto* speed = run_cmd->add_option("--speed", o.speed, "Vehicle speed V in m/s (negative when reversing)");
    auto* yaw = run_cmd->add_option("--yaw-rate", o.yaw_rate,
                                    "Yaw rate ω in rad/s (positive turning left); default: the Ouster IMU's gyro if the pcap has one, else 0");
    auto* motion = run_cmd->add_option("--motion", o.motion_file, "CSV with columns t,speed,yaw_rate, interpolated at each frame's timestamp");
    motion->excludes(speed)->excludes(yaw);
    run_cmd->add_option("--frames", o.frames, "Frames A:B of the input (0-based, B excluded; A: or :B)");
    add_source_options(run_cmd, o.source);
    auto* height = run_cmd->add_option("--sensor-height", o.sensor_height, "Sensor height above the ground, m");
    auto* extr = run_cmd->add_option("--extrinsics", o.extrinsics, "Sensor pose in the base frame: x,y,z,roll,pitch,yaw (m, rad)")
                     ->delimiter(',')
                     ->expected(6);
    height->excludes(extr);
    run_cmd->add_option("--track-width", o.track_width, "Track width, m (default 1.6)");
    run_cmd->add_option("--tire-width", o.tire_width, "Tire width, m (default 0.3)");
    run_cmd->add_option("--ground", o.ground, "Ground method (default pca)")->check(CLI::IsMember({"pca", "ransac"}));
    run_cmd->add_option("--clusters", o.clusters, "Obstacle clustering (default on)")->check(CLI::IsMember({"on", "off"}));
    run_cmd->add_option("--cluster-tolerance", o.cluster_tolerance, "Euclidean cluster tolerance, m (default 0.5)")
        ->check(CLI::PositiveNumber);
    run_cmd->add_option("--frame-rate", o.frame_rate, "File inputs: frames per second; adds timestamps frame/rate")
        ->check(CLI::PositiveNumber);  // pcap frames carry their own timestamps
    run_cmd->add_option("--fusion", o.fusion, "Temporal fusion of the frames into an elevation map (default none)")
        ->check(CLI::IsMember({"none", "ema", "kalman"}));
    run_cmd->add_option("--alpha", o.alpha, "EMA fusion: weight of the newest frame, (0, 1] (default 0.5)")
        ->check(CLI::Range(0.0, 1.0));
    run_cmd->add_option("--poses", o.poses_file, "KITTI poses file (one 3x4 row-major pose per frame of the input): "
                                                  "moves the fusion map instead of integrating the motion");
    run_cmd->add_option("--config", o.config_file, "JSON or YAML config file with the fields of rp.Config; flags override it");
    run_cmd->add_option("-o,--output", o.output, "Output JSON-lines file (default stdout)");
    run_cmd->add_flag("-q,--quiet", o.quiet, "No per-frame progress on stderr");

    std::vector<std::string> info_inputs;
    rp::SourceOptions info_options;
    CLI::App* info_cmd = app.add_subcommand("info", "Describe a recording: sensor model, packet profile, frames, duration");
    info_cmd->add_option("INPUT", info_inputs, "One pcap, or frame files / directories")->required();
    add_source_options(info_cmd, info_options);

    CLI11_PARSE(app, argc, argv);
    try {
        if (info_cmd->parsed()) return info(info_inputs, info_options);
        return run(o, *run_cmd);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "roadpreview: error: %s\n", e.what());
        return 1;
    }
}
