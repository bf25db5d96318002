// SPDX-License-Identifier: BSD-3-Clause
// roadpreview — command-line front end: `roadpreview run INPUT... [options]` writes one JSON line per frame;
// `roadpreview calibrate INPUT... -o beams.yaml` estimates the beams' offsets from a drive;
// `roadpreview info INPUT...` describes a recording.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <optional>
#include <tuple>
#include <utility>

#include <CLI/CLI.hpp>

#include "bounded_sample.hpp"
#include "cli_checks.hpp"
#include "live_commands.hpp"
#include "output_file.hpp"
#include "python_commands.hpp"
#include "range_commands.hpp"
#include "roadside_commands.hpp"  // roadside perception (its own library)
#include "roadpreview/roadpreview.hpp"

namespace rp = roadpreview;

namespace {

using rp::cli::UsageError;

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
    int threads = 1;
    double frame_rate = 0.0;
    std::string config_file;
    std::string output;
    bool quiet = false;
    std::string motion_file;
    std::string frames;  // "A:B"
    rp::SourceOptions source;
    std::string fusion;
    double alpha = 0.0;
    double beam_sigma_deg = 0.0;
    bool beam_sigmas_from_calibration = false;  // each calibrated beam's σ from the --beam-calibration file
    std::string poses_file;
    int beams = 64;       // calibrate: beams of a sensor whose files do not number them (KITTI: HDL-64E)
    double cell = 0.2;    // calibrate: road cell, m
    double max_sigma = 0.0;   // calibrate: deg (0: the method's default)
    std::string calibration_method = "motion";  // calibrate: motion | surface
    std::vector<double> segment_lengths_m;  // --segments
    std::string segments_file;              // --segments-csv
    std::string profile_dir;                // --export-profile
    double read_ahead_m = 0.0;              // --read-ahead-m: each line's readout (0: none)
    std::vector<std::string> stereo;  // LEFT RIGHT: image files or directories of them
    std::string calib;
    std::string disparity;
    LiveRunOptions live;                    // udp:// input
    bool roi_columns = false;               // frames end once the region of interest has been scanned
};

// True when the subcommand has this option and it was given.
bool given(const CLI::App& cmd, const std::string& name) {
    const CLI::Option* option = cmd.get_option_no_throw(name);
    return option && option->count() > 0;
}

// Config file first, then the flags that were given on the command line.
rp::Config build_config(const RunOptions& o, const CLI::App& run) {
    rp::Config cfg = o.config_file.empty() ? rp::Config{} : rp::config_from_file(o.config_file);
    if (given(run, "--sensor-height")) {
        cfg.sensor_height = o.sensor_height;
        cfg.extrinsics.reset();
    }
    if (given(run, "--extrinsics")) {
        const auto& e = o.extrinsics;
        cfg.extrinsics = rp::Extrinsics{e[0], e[1], e[2], e[3], e[4], e[5]};
        cfg.sensor_height.reset();
    }
    if (given(run, "--track-width")) cfg.track_width = o.track_width;
    if (given(run, "--tire-width")) cfg.tire_width = o.tire_width;
    if (given(run, "--ground"))
        cfg.ground.method = o.ground == "ransac" ? rp::GroundMethod::Ransac
                            : o.ground == "pca"  ? rp::GroundMethod::Pca : rp::GroundMethod::Zones;
    if (given(run, "--clusters")) cfg.obstacles.enabled = o.clusters == "on";
    if (given(run, "--cluster-tolerance")) cfg.obstacles.cluster_tolerance_m = o.cluster_tolerance;
    if (given(run, "--fusion"))
        cfg.fusion.method = o.fusion == "ema" ? rp::FusionMethod::Ema
                            : o.fusion == "kalman" ? rp::FusionMethod::Kalman : rp::FusionMethod::None;
    if (given(run, "--alpha")) cfg.fusion.alpha = o.alpha;
    if (given(run, "--beam-sigma-deg")) cfg.profile.beam_sigma_deg = o.beam_sigma_deg;
    if (o.beam_sigmas_from_calibration)
        cfg.profile.beam_sigmas_deg = rp::calibrated_beam_sigmas_deg(
            rp::read_beam_calibration(o.source.beam_calibration), cfg.profile.beam_sigma_deg);
    if (given(run, "--threads")) cfg.threads = o.threads;
    if (given(run, "--frame-rate")) cfg.fusion.frame_rate_hz = o.frame_rate;
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
        if (used != part.size() || v < 0)
            throw std::invalid_argument("--frames " + text + ": expected A, A:B, A: or :B with A, B >= 0");
        return v;
    };
    if (colon == std::string::npos) {  // "A": that one frame
        const std::int64_t a = number(text, -1);
        if (a == kAll) throw std::invalid_argument("--frames " + text + ": frame index too large");
        return {a, a + 1};
    }
    const auto range = std::make_pair(number(text.substr(0, colon), 0), number(text.substr(colon + 1), kAll));
    if (range.first >= range.second) throw std::invalid_argument("--frames " + text + ": A must be smaller than B");
    return range;
}

void report_frame(std::size_t i, std::size_t total, const rp::Frame& f, const rp::Result& r) {
    const std::string counter = total ? std::to_string(i + 1) + "/" + std::to_string(total) : std::to_string(i + 1);
    std::string decode;
    if (f.diagnostics.missing_columns) decode += ", " + std::to_string(f.diagnostics.missing_columns) + " columns missing";
    if (f.diagnostics.cut_columns)
        decode += " (" + std::to_string(f.diagnostics.cut_columns) +
                  " where the input began or ended within the frame)";
    if (f.diagnostics.skipped_packets) decode += ", " + std::to_string(f.diagnostics.skipped_packets) + " bad packets skipped";
    decode += LiveStats::describe(f.diagnostics);
    if (!f.diagnostics.complete && decode.empty()) decode = ", partial sweep";
    if (!f.sequence_break.empty() && i > 0) decode += ", new sequence (" + f.sequence_break + ")";
    std::fprintf(stderr, "[%s] %s: %lld points, %lld ground%s, class L=%s R=%s vehicle=%s%s%s, %.2f ms%s\n",
                 counter.c_str(), rp::frame_label(f).c_str(), static_cast<long long>(r.points.input),
                 static_cast<long long>(r.points.ground), obstacles_of(r).c_str(), class_of(r.left.roughness).c_str(),
                 class_of(r.right.roughness).c_str(), class_of(r.vehicle).c_str(), r.status == rp::FrameStatus::Ok ? "" : " — ",
                 rp::to_string(r.status), r.timing_ms.total, decode.c_str());
}

void report_source(const rp::SourceInfo& s) {
    const bool packets = s.format != "files" && s.lidar_port != 0;  // pcaps; stereo pairs have no packets
    if (s.format != "files" && !packets) {
        std::fprintf(stderr, "roadpreview: %s, %s, %s, %s\n", s.format.c_str(), s.sensor_model.c_str(),
                     s.profile.c_str(), s.metadata.c_str());
    } else if (packets) {
        std::fprintf(stderr, "roadpreview: %s, %s, %s, lidar UDP port %d (%s)%s%s\n", s.format.c_str(),
                     s.sensor_model.c_str(), s.profile.c_str(), s.lidar_port, s.lidar_port_origin.c_str(),
                     s.metadata.empty() ? "" : ", ", s.metadata.c_str());
    }
    for (const auto& note : s.notes) std::fprintf(stderr, "roadpreview: %s\n", note.c_str());
}

// What the summary line at the end of a run counts: classes, why classes were declined, the vehicle's IRI.
struct RunSummary {
    std::map<std::string, int> classes, declined;
    BoundedSample ms, iri_m_per_km, iri_noise_m_per_km;

    void add(const rp::Result& r) {
        ++classes[class_of(r.vehicle)];
        for (const rp::Roughness* x : {&r.left.roughness, &r.right.roughness, &r.vehicle})
            if (!x->iso_class)
                ++declined[x->reason == rp::RoughnessReason::None ? "no reason given" : rp::to_string(x->reason)];
        if (r.vehicle.iri.value) iri_m_per_km.add(*r.vehicle.iri.value);
        if (r.vehicle.iri.value && r.vehicle.iri.noise) iri_noise_m_per_km.add(*r.vehicle.iri.noise);
        ms.add(r.timing_ms.total);
    }

    // "; the bins' errors alone 2.41": the median of iri.noise over the frames with an IRI, when known.
    std::string noise_text() const {
        if (iri_noise_m_per_km.empty()) return "";
        char text[64];
        std::snprintf(text, sizeof text, "; the bins' errors alone %.2f", iri_noise_m_per_km.median());
        return text;
    }

    void print() const {
        std::fprintf(stderr, "roadpreview: %llu frame(s), pipeline median %.2f ms, max %.2f ms; vehicle classes:",
                     static_cast<unsigned long long>(ms.count()), ms.median(), ms.max());
        for (const auto& [cls, n] : classes) std::fprintf(stderr, " %s×%d", cls.c_str(), n);
        if (iri_m_per_km.empty()) std::fprintf(stderr, "; vehicle IRI: none");
        else
            std::fprintf(stderr, "; vehicle IRI median %.2f m/km (%llu of %llu frames%s)", iri_m_per_km.median(),
                         static_cast<unsigned long long>(iri_m_per_km.count()),
                         static_cast<unsigned long long>(ms.count()), noise_text().c_str());
        if (!declined.empty()) std::fprintf(stderr, "; declined classes (L, R, vehicle):");
        const char* separator = " ";
        for (const auto& [reason, n] : declined)
            std::fprintf(stderr, "%s%s ×%d", std::exchange(separator, ", "), reason.c_str(), n);
        std::fprintf(stderr, "\n");
    }
};

// The input named in messages: the first INPUT, else the stereo pair's left images or the disparity.
std::string input_label(const RunOptions& o) {
    if (!o.inputs.empty()) return o.inputs[0];
    return o.stereo.empty() ? o.disparity : o.stereo[0];
}

// A run that writes nothing fails (and its OutputFile leaves no empty file behind).
[[noreturn]] void nothing_written(const RunOptions& o, std::int64_t first, std::int64_t frames_seen) {
    std::string where = first > 0 ? " from index " + std::to_string(first) + " on (the input has " +
                                        std::to_string(frames_seen) + ")"
                                  : " in the input";
    throw std::runtime_error(input_label(o) + (o.inputs.size() > 1 ? " ..." : "") + ": no frames" + where +
                             "; nothing was written");
}

// Options that only a pcap recording reads are an error with frame files, not silently ignored.
void check_source_options(const CLI::App& run, const rp::SourceInfo& info) {
    if (info.format != "files") return;
    for (const char* name :
         {"--meta", "--sensor-model", "--calibration", "--cut-angle", "--lidar-port", "--skip-bad-packets"})
        if (run.count(name))
            throw UsageError(std::string(name) + " applies to pcap recordings only; the input is frame files");
}

// Route outputs (--segments, --export-profile): the frames' profiles stitched along the drive.
bool wants_route(const RunOptions& o) { return !o.segment_lengths_m.empty() || !o.profile_dir.empty(); }

std::string segments_path(const RunOptions& o) {
    if (!o.segments_file.empty()) return o.segments_file;
    if (o.output.empty()) return "segments.csv";
    return std::filesystem::path(o.output).replace_extension(".segments.csv").string();
}

std::ofstream open_for_writing(const std::string& path) {
    std::ofstream f(path);
    if (!f) throw std::runtime_error(path + ": cannot open output file for writing");
    return f;
}

// A full disk shows when the buffer is written out, not in the destructor, which would let it pass unsaid.
void finish_writing(std::ofstream& f, const std::string& path) {
    f.flush();
    if (!f) throw std::runtime_error(path + ": write failed");
}

void write_segments(const RunOptions& o, const rp::RouteBuilder& route) {
    std::vector<rp::RouteSegment> segments;
    for (double length_m : o.segment_lengths_m) {
        const auto some = route.segments(length_m);
        segments.insert(segments.end(), some.begin(), some.end());
    }
    const std::string path = segments_path(o);
    std::ofstream f = open_for_writing(path);
    rp::write_segments_csv(f, segments);
    finish_writing(f, path);
    if (!o.quiet)
        std::fprintf(stderr, "roadpreview: %zu segment rows over %.1f m of stitched road -> %s\n", segments.size(),
                     segments.empty() ? 0.0 : segments.back().end_m, path.c_str());
}

// The --export-profile directory made before the run, so that a path that cannot be one stops it at once.
void prepare_profile_dir(const RunOptions& o) {
    if (o.profile_dir.empty()) return;
    std::error_code ec;
    std::filesystem::create_directories(o.profile_dir, ec);
    if (ec || !std::filesystem::is_directory(o.profile_dir, ec))
        throw UsageError("--export-profile " + o.profile_dir + ": cannot be made a directory (" +
                         (ec ? ec.message() : std::string("a file of that name exists")) + ")");
}

void export_profiles(const RunOptions& o, const rp::RouteBuilder& route) {
    std::filesystem::path input(input_label(o));
    if (!input.has_filename()) input = input.parent_path();  // a folder given as "drive/"
    const std::string title = "roadpreview " + input.filename().string();
    for (const auto& [wheel, profile] : {std::pair{"left", route.left()}, std::pair{"right", route.right()}}) {
        const auto base = std::filesystem::path(o.profile_dir) / wheel;
        std::ofstream csv = open_for_writing(base.string() + ".csv");
        rp::write_profile_csv(csv, profile);
        finish_writing(csv, base.string() + ".csv");
        std::ofstream erd = open_for_writing(base.string() + ".erd");
        rp::write_profile_erd(erd, profile, wheel, title);
        finish_writing(erd, base.string() + ".erd");
    }
    if (!o.quiet)
        std::fprintf(stderr, "roadpreview: stitched profiles over %.1f m driven -> %s/{left,right}.{csv,erd}\n",
                     route.distance_m(), o.profile_dir.c_str());
}

void write_route(const RunOptions& o, const rp::RouteBuilder& route) {
    if (!o.segment_lengths_m.empty()) write_segments(o, route);
    if (!o.profile_dir.empty()) export_profiles(o, route);
}

bool is_stereo(const RunOptions& o) { return !o.stereo.empty() || !o.disparity.empty(); }

bool is_live(const RunOptions& o) { return o.inputs.size() == 1 && rp::is_udp_url(o.inputs[0]); }

// The recording options, with --roi-columns' regions: the one the frames are cropped to (ahead, or behind for a
// negative --speed), both with a motion file, whose speed may change sign.
rp::SourceOptions source_options(const RunOptions& o, const CLI::App& app, const rp::Config& cfg) {
    rp::SourceOptions s = o.source;
    if (!o.roi_columns) return s;
    if (!cfg.sensor_height && !cfg.extrinsics)
        throw std::invalid_argument("--roi-columns needs the sensor's mounting: give --sensor-height or --extrinsics");
    if (app.count("--cut-angle"))
        throw std::invalid_argument("give --cut-angle or --roi-columns (which sets the cut angle), not both");
    if (app.count("--speed"))
        s.roi_columns = {rp::sensor_roi(cfg, o.speed)};
    else
        s.roi_columns = {rp::sensor_roi(cfg, 1.0), rp::sensor_roi(cfg, -1.0)};
    return s;
}

// Set by SIGINT or SIGTERM during a live run: the stream ends there, and the run writes its summary and route files
// as at --duration (the default action ended it at once, without them). Lock-free: safe in a signal handler.
std::atomic<bool> g_stop_live{false};
static_assert(std::atomic<bool>::is_always_lock_free);

extern "C" void stop_live(int) { g_stop_live = true; }

// A live sensor on a udp:// address.
std::unique_ptr<rp::FrameSource> open_live_source(const RunOptions& o, const CLI::App& app, const rp::Config& cfg) {
    rp::LiveOptions live;
    live.stop = &g_stop_live;
    std::signal(SIGINT, stop_live);
    std::signal(SIGTERM, stop_live);
    live.source = source_options(o, app, cfg);
    live.timeout_s = o.live.timeout_s;
    live.duration_s = o.live.duration_s;
    live.busy_wait = o.live.busy_wait;
    auto source = rp::open_live(o.inputs[0], live);
    if (!o.quiet) {
        std::fprintf(stderr, "roadpreview: listening on %s (%s)\n", o.inputs[0].c_str(),
                     o.source.meta.empty() ? "Velodyne" : ("Ouster, " + o.source.meta).c_str());
        std::fflush(stderr);
    }
    return source;
}

// The frames of the run: a live sensor (udp://), stereo pairs / disparity images, or the INPUT files and recordings.
std::unique_ptr<rp::FrameSource> open_source(const RunOptions& o, const CLI::App& app, const rp::Config& cfg) {
    if (is_live(o)) return open_live_source(o, app, cfg);
    if (!is_stereo(o)) return rp::open_frames(o.inputs, source_options(o, app, cfg));
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

// What the command line asks of its inputs, checked before any is read: usage errors.
void check_inputs(const RunOptions& o, const CLI::App& app) {
    if (is_stereo(o) && !o.inputs.empty()) throw UsageError("give INPUT files or --stereo/--disparity, not both");
    if (!is_stereo(o) && o.inputs.empty())
        throw UsageError("give INPUT files, or --stereo LEFT RIGHT / --disparity DISP with --calib");
    if (is_stereo(o) && o.calib.empty()) throw UsageError("--stereo and --disparity need --calib FILE");
    if (is_live(o) && o.frames.find_first_not_of('0') == std::string::npos && !o.frames.empty())
        throw UsageError("--frames " + o.frames + ": a live run's --frames N ends it after N ≥ 1 frames");
    if (!is_live(o))
        for (const char* name : {"--duration", "--timeout", "--busy-wait"})
            if (app.count(name)) throw UsageError(std::string(name) + " applies to a udp:// input only");
    if (is_live(o))  // ignored by a live source, silently: the address's port is the lidar's
        for (const char* name : {"--columns", "--poses", "--frame-rate", "--lidar-port"})
            if (app.count(name)) throw UsageError(std::string(name) + " does not apply to a udp:// input");
    if (!is_stereo(o) && !o.calib.empty())
        throw UsageError("--calib is a stereo calibration: it goes with --stereo or --disparity");
    if (is_stereo(o))  // a LiDAR decoder's options would be ignored, silently
        for (const char* name : {"--meta", "--sensor-model", "--calibration", "--cut-angle", "--lidar-port",
                                 "--skip-bad-packets", "--beam-calibration", "--columns", "--roi-columns"})
            if (app.count(name)) throw UsageError(std::string(name) + " applies to LiDAR inputs; the input is stereo");
}

// The drive's policy options from the command line (docs/method.md, "Drives").
rp::DriveOptions drive_options(const RunOptions& o, const CLI::App& app) {
    rp::DriveOptions d;
    if (app.count("--speed")) d.speed_mps = o.speed;
    if (app.count("--yaw-rate")) d.yaw_rate_rps = o.yaw_rate;
    d.motion_file = o.motion_file;
    d.poses_file = o.poses_file;
    d.frame_rate_hz = o.frame_rate;
    // A live run's --frames N: the first N frames.
    const bool count_only = is_live(o) && !o.frames.empty() && o.frames.find(':') == std::string::npos;
    std::tie(d.first_frame, d.last_frame) = parse_frame_range(count_only ? ":" + o.frames : o.frames);
    d.on_note = [quiet = o.quiet](bool warning, const std::string& text) {
        if (warning || !quiet) std::fprintf(stderr, "roadpreview: %s%s\n", warning ? "warning: " : "", text.c_str());
    };
    return d;
}

int run(const RunOptions& o, const CLI::App& app) {
    if (!app.count("--speed") && o.motion_file.empty())
        throw UsageError("give the vehicle's motion: --speed (and --yaw-rate), or --motion FILE");
    check_inputs(o, app);
    const rp::Config cfg = with_camera_pose(build_config(o, app), o);
    if (!o.poses_file.empty() && cfg.fusion.method == rp::FusionMethod::None)
        throw UsageError("--poses moves the fusion map: give --fusion ema or kalman too");
    if (given(app, "--alpha") && cfg.fusion.method != rp::FusionMethod::Ema)
        throw UsageError("--alpha weighs the newest frame of the EMA fusion: give --fusion ema too (fusion.method is " +
                         std::string(rp::to_string(cfg.fusion.method)) + ")");
    prepare_profile_dir(o);
    // Distances the profiles cannot hold: usage errors, said before any input is read.
    const auto as_usage_error = [](const char* flag, auto&& check) {
        try {
            check();
        } catch (const std::invalid_argument& e) {
            throw UsageError(std::string(flag) + ": " + e.what());
        }
    };
    if (o.read_ahead_m > 0.0) as_usage_error("--read-ahead-m", [&] { rp::ProfileReadout(cfg, o.read_ahead_m); });
    for (const double length_m : o.segment_lengths_m)
        as_usage_error("--segments", [&] { rp::RouteBuilder(cfg).check_segment_length(length_m); });
    const rp::DriveOptions drive = [&] {  // --frames: a usage error, said before a live input binds its port
        try {
            return drive_options(o, app);
        } catch (const std::invalid_argument& e) {
            throw UsageError(e.what());
        }
    }();
    auto source = open_source(o, app, cfg);
    check_source_options(app, source->info());
    const std::size_t total = source->info().format == "files" ? rp::expand_inputs(o.inputs).size() : 0;
    rp::DriveRunner runner(std::move(source), cfg, drive);
    rp::cli::OutputFile output(o.output);  // a run that fails before its first frame leaves no empty file
    std::ostream& out = output.stream();
    std::optional<rp::RouteBuilder> route;
    std::optional<rp::ProfileReadout> readout;
    RunSummary summary;
    LiveStats live_stats;
    while (std::optional<rp::DriveStep> step = runner.next()) {
        const rp::DriveFrame& in = step->input;
        const rp::Result& r = step->result;
        const double result_s = rp::steady_now_s();
        if (summary.ms.empty()) {
            if (!o.quiet) report_source(runner.info());
            if (wants_route(o)) route.emplace(runner.config());
            if (o.read_ahead_m > 0.0) readout.emplace(runner.config(), o.read_ahead_m);
            if (route && !in.at.timestamp_s && !in.at.pose && !o.quiet)
                std::fprintf(stderr,
                             "roadpreview: route: frames without timestamps are taken %g s apart "
                             "(fusion.frame_rate_hz); give --frame-rate or --poses\n",
                             1.0 / cfg.fusion.frame_rate_hz);
        }
        if (route) route->add(r, in.at.pose);
        rp::LineOptions line;
        if (readout) {
            readout->add(r, in.at.pose);
            line.readout = &*readout;
        }
        out << rp::result_to_json(r, line) << '\n';
        output.check_written();  // a live consumer reads each line as it comes
        live_stats.add(in.frame, result_s);
        summary.add(r);
        if (!o.quiet) report_frame(static_cast<std::size_t>(in.index), total, in.frame, r);
    }
    if (summary.ms.empty()) nothing_written(o, drive.first_frame, runner.frames_read());
    summary.print();
    if (is_live(o)) live_stats.print(runner.info());
    if (runner.mounting_disagreements())
        std::fprintf(stderr,
                     "roadpreview: warning: %lld frame(s) fitted a ground that disagrees with the mounting "
                     "(mounting.disagrees in the output)\n",
                     static_cast<long long>(runner.mounting_disagreements()));
    if (route) write_route(o, *route);
    if (g_stop_live) {
        std::fprintf(stderr, "roadpreview: interrupted: the live run ended there (its output and summary are complete)\n");
        return 130;  // as a shell reports a run stopped by Ctrl-C
    }
    return 0;
}

// One of the two estimators of method.md §8: `motion` compares the road cells that different beams see as the
// vehicle moves (needs the poses); `surface` compares every frame's beams with its smooth road (needs no motion).
class Calibration {
public:
    Calibration(const RunOptions& o, const rp::Config& cfg, int beam_count) {
        if (o.calibration_method == "surface") {
            rp::SurfaceCalibrationOptions options;
            if (o.max_sigma > 0) options.max_sigma_deg = o.max_sigma;
            surface_.emplace(cfg, beam_count, options);
        } else {
            rp::CalibrationOptions options;
            options.cell_m = o.cell;
            if (o.max_sigma > 0) options.max_sigma_deg = o.max_sigma;
            motion_.emplace(cfg, beam_count, options);
        }
    }
    void add_frame(rp::PointsView points, const std::vector<std::int32_t>& beams, const rp::Pose2& pose) {
        if (surface_) surface_->add_frame(points, beams);
        else motion_->add_frame(points, beams, pose);
    }
    rp::BeamCalibration solve() const { return surface_ ? surface_->solve() : motion_->solve(); }

private:
    std::optional<rp::BeamCalibrator> motion_;
    std::optional<rp::SurfaceCalibrator> surface_;
};

// Frames of the drive into the calibrator: numbered points at once, files (no beam numbers) at the end, by their
// scan order or the beam centres their elevations show. Poses (method motion): the poses file's, else the motion
// integrated over the time since the previous frame (timestamps, else 1/frame rate).
int calibrate(const RunOptions& o, const CLI::App& app) {
    const bool by_motion = o.calibration_method != "surface";
    if (by_motion && !app.count("--speed") && o.motion_file.empty() && o.poses_file.empty())
        throw UsageError("give the vehicle's motion: --speed (and --yaw-rate), --motion FILE or --poses FILE "
                         "(or --method surface, which needs none)");
    if (o.output.empty()) throw UsageError("give the beams file to write: -o beams.yaml");
    rp::DriveOptions drive = drive_options(o, app);
    if (!by_motion && !drive.speed_mps && drive.motion_file.empty() && drive.poses_file.empty())
        drive.speed_mps = 0.0;  // the surface method reads no motion
    rp::DriveFrames frames(rp::open_frames(o.inputs, o.source), build_config(o, app), drive);
    std::optional<Calibration> calibrator;
    std::vector<rp::Frame> unnumbered;
    std::vector<rp::Pose2> unnumbered_poses;
    std::optional<rp::Pose2> pose;
    std::optional<double> last_time;
    while (std::optional<rp::DriveFrame> in = frames.next()) {
        if (!pose && !o.quiet) report_source(frames.info());
        const std::optional<double> t = in->at.timestamp_s;
        const double dt = t && last_time ? *t - *last_time : 1.0 / frames.config().fusion.frame_rate_hz;
        last_time = t;
        const rp::Motion& m = in->motion;
        pose = in->at.pose ? *in->at.pose : pose ? rp::integrate_motion(*pose, m.speed_mps, m.yaw_rate_rps, dt)
                                                 : rp::Pose2{};
        if (!o.quiet) {
            if (by_motion)
                std::fprintf(stderr, "[%lld] %s: pose x %.2f m, y %.2f m, yaw %.4f rad\n",
                             static_cast<long long>(in->index + 1), rp::frame_label(in->frame).c_str(), pose->x_m,
                             pose->y_m, pose->yaw_rad);
            else
                std::fprintf(stderr, "[%lld] %s\n", static_cast<long long>(in->index + 1),
                             rp::frame_label(in->frame).c_str());
        }
        if (in->frame.beams.empty()) {
            unnumbered.push_back(std::move(in->frame));
            unnumbered_poses.push_back(*pose);
            continue;
        }
        // Made again when a later frame gives the mounting: the frames before were compared in the wrong frame.
        if (!calibrator || in->mounting_estimated) calibrator.emplace(o, frames.config(), frames.info().beams);
        calibrator->add_frame(rp::points_view(in->frame.points.data(), in->frame.points.rows(), 4), in->frame.beams,
                              *pose);
    }
    rp::BeamCalibration indexing;
    if (!unnumbered.empty()) {
        std::vector<rp::PointsView> views;
        for (const rp::Frame& f : unnumbered) views.push_back(rp::points_view(f.points.data(), f.points.rows(), 4));
        rp::find_beam_centres(views, o.beams, indexing);
        calibrator.emplace(o, frames.config(), o.beams);
        for (std::size_t k = 0; k < views.size(); ++k)
            calibrator->add_frame(views[k], rp::beams_of_points(views[k], indexing, rp::frame_label(unnumbered[k])),
                                  unnumbered_poses[k]);
    }
    if (!calibrator) throw rp::CalibrationError(o.inputs[0] + ": no frames to calibrate from");
    rp::BeamCalibration c;
    try {
        c = calibrator->solve();
    } catch (const rp::CalibrationError& e) {
        throw rp::CalibrationError(o.inputs[0] + ": " + e.what());
    }
    const rp::SourceInfo info = frames.info();
    c.sensor_model = info.format == "files" ? o.source.sensor_model : info.sensor_model;
    c.serial = info.serial;
    rp::adopt_beam_indexing(c, indexing);
    rp::write_beam_calibration(c, o.output);
    int determined = 0;
    double largest = 0.0;
    for (const rp::BeamOffsets& b : c.beams)
        if (b.determined) ++determined, largest = std::max(largest, std::abs(b.elevation_offset_deg));
    char travel[64] = "";  // the surface method reads no motion
    if (by_motion) std::snprintf(travel, sizeof travel, " over %.2f m", c.travel_m);
    std::fprintf(stderr, "roadpreview: %d of %d beams determined (%s) from %lld frames%s (point noise %.1f mm); "
                 "largest offset %.4f deg; wrote %s\n", determined, c.beam_count, o.calibration_method.c_str(),
                 static_cast<long long>(c.frames), travel, 1e3 * c.residual_m, largest, o.output.c_str());
    if (const std::string warning = by_motion ? rp::short_drive_warning(c.travel_m) : ""; !warning.empty())
        std::fprintf(stderr, "roadpreview: warning: %s (--method surface)\n", warning.c_str());
    return 0;
}

// Decodes every frame and prints what the recording holds.
int info(const std::vector<std::string>& inputs, const rp::SourceOptions& options) {
    const auto source = rp::open_frames(inputs, options);
    std::int64_t frames = 0, complete = 0, imu = 0, missing = 0, cut = 0, skipped = 0, first_id = -1, last_id = -1;
    std::vector<Eigen::Index> points;
    std::optional<double> t0, t1;
    double last_span = 0.0;  // s from the last frame's timestamp to its last point
    while (std::optional<rp::Frame> f = source->next()) {
        ++frames;
        complete += f->diagnostics.complete;
        imu += static_cast<std::int64_t>(f->imu.size());
        missing += f->diagnostics.missing_columns;
        cut += f->diagnostics.cut_columns;
        skipped += f->diagnostics.skipped_packets;
        points.push_back(f->points.rows());
        if (first_id < 0) first_id = f->frame_id;
        last_id = f->frame_id;
        if (f->timestamp) {
            if (!t0) t0 = f->timestamp;
            t1 = f->timestamp;
            last_span = f->point_times.empty() ? 0.0 : *std::max_element(f->point_times.begin(), f->point_times.end());
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
    if (t0) {  // to the end of the last frame: its period when the rate is known, else its last point's time
        const double last = s.frame_rate_hz > 0 ? 1.0 / s.frame_rate_hz : last_span;
        std::printf("duration: %.3f s (first frame at %.6f s, UNIX time)\n", *t1 - *t0 + last, *t0);
    }
    if (missing)
        std::printf("missing columns: %lld (%lld where the capture began or ended within a frame)\n",
                    static_cast<long long>(missing), static_cast<long long>(cut));
    if (skipped) std::printf("skipped packets: %lld\n", static_cast<long long>(skipped));
    if (imu) std::printf("IMU samples: %lld\n", static_cast<long long>(imu));
    for (const auto& note : s.notes) std::printf("note: %s\n", note.c_str());
    return 0;
}

// Usage errors exit with 2 (argparse's and CLI11's convention); --help and --version with 0.
int parse_command_line(CLI::App& app, int argc, char** argv) {
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        const int status = app.exit(e);
        return status == 0 ? 0 : 2;
    }
    return -1;
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
    cmd->add_option("--beam-calibration", s.beam_calibration,
                    "Beams file (roadpreview calibrate) applied while decoding; .bin/.pcd points find their beam by scan "
                    "order or elevation");
}

}  // namespace

int main(int argc, char** argv) {
    if (const auto status = delegate_to_python(argc, argv)) return *status;
    CLI::App app{"roadpreview: road height profiles and ISO 8608 roughness ahead of the wheels, from LiDAR"};
    app.set_version_flag("--version", std::string("roadpreview ") + rp::kVersion);
    app.require_subcommand(1);
    app.footer("Also, from the Python package (pip install 'roadpreview[drives]'): batch (many recordings to Parquet "
               "and summaries; roadpreview batch --help), and run / info of ROS bags and MCAP files and with "
               "--motion-from");

    RunOptions o;
    CLI::App* run_cmd =
        app.add_subcommand("run", "Process .bin / .pcd / .ply frames (files or directories), pcap recordings or "
                                  "stereo pairs");
    run_cmd->add_option("INPUT", o.inputs,
                        "Frame files, or directories of them (sorted by name), or Ouster/Velodyne .pcap recordings "
                        "(several: one drive split into files, in time order), or a live sensor: udp://[ADDR][:PORT] "
                        "(Ouster with --meta, else Velodyne)");
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
    run_cmd->add_option("--frames", o.frames,
                        "Frames A:B of the input (0-based, B excluded; A: or :B; A alone: that frame; udp:// input: "
                        "N alone ends the run after N frames)");
    run_cmd->add_option("--columns", o.source.columns,
                        "Raw float32 .bin files: values per point, x y z first (default 5 for *.pcd.bin, else 4)")
        ->check(CLI::Range(3, 64));
    add_source_options(run_cmd, o.source);
    add_live_options(run_cmd, o.live);
    auto* height = run_cmd->add_option("--sensor-height", o.sensor_height,
                                       "Sensor height above the ground, m (default: estimated from the first "
                                       "frame's ground, see the output's mounting)")
                       ->check(rp::cli::above_and_at_most(0.0, 10.0));
    auto* extr = run_cmd->add_option("--extrinsics", o.extrinsics, "Sensor pose in the base frame: x,y,z,roll,pitch,yaw (m, rad)")
                     ->delimiter(',')
                     ->expected(6);
    height->excludes(extr);
    run_cmd->add_option("--track-width", o.track_width, "Track width, m (default 1.6)");
    run_cmd->add_option("--tire-width", o.tire_width, "Tire width, m (default 0.3)");
    run_cmd->add_option("--ground", o.ground, "Ground method (default zones)")
        ->check(CLI::IsMember({"zones", "pca", "ransac"}));
    run_cmd->add_option("--clusters", o.clusters, "Obstacle clustering (default on)")->check(CLI::IsMember({"on", "off"}));
    run_cmd->add_option("--cluster-tolerance", o.cluster_tolerance, "Euclidean cluster tolerance, m (default 0.5)")
        ->check(rp::cli::positive_finite());
    run_cmd->add_option("--threads", o.threads, "Threads one frame may use; the same answer for any number (default 1)")
        ->check(CLI::Range(1, rp::kMaxThreads));
    run_cmd->add_option("--frame-rate", o.frame_rate, "File inputs: frames per second; adds timestamps frame/rate")
        ->check(rp::cli::above_and_at_most(0.01, 10000.0, true));  // fusion.frame_rate_hz's range
    run_cmd->add_option("--fusion", o.fusion, "Temporal fusion of the frames into an elevation map (default none)")
        ->check(CLI::IsMember({"none", "ema", "kalman"}));
    run_cmd->add_option("--alpha", o.alpha, "EMA fusion (--fusion ema): weight of the newest frame (default 0.5)")
        ->check(rp::cli::above_and_at_most(0.0, 1.0));
    run_cmd->add_option("--beam-sigma-deg", o.beam_sigma_deg,
                        "σ of each beam's elevation angle, deg: counted in the profiles' noise for points whose beam "
                        "the decoder or a beams file gives (default 0: not counted)")
        ->check(CLI::Range(0.0, 10.0));
    run_cmd->add_flag("--beam-sigmas-from-calibration", o.beam_sigmas_from_calibration,
                      "Count each calibrated beam's remaining elevation error, the σ the --beam-calibration file "
                      "states for it (--beam-sigma-deg for the beams it could not determine)")
        ->needs(run_cmd->get_option("--beam-calibration"));
    run_cmd->add_option("--poses", o.poses_file, "KITTI poses file (one 3x4 row-major pose per frame of the input): "
                                                  "moves the fusion map instead of integrating the motion");
    run_cmd->add_option("--segments", o.segment_lengths_m,
                        "Segment lengths along the drive, m (e.g. 10,100): per-segment class, G_d(n0), IRI to a CSV")
        ->delimiter(',')
        ->check(rp::cli::positive_finite());
    run_cmd->add_option("--segments-csv", o.segments_file, "File for the --segments rows (default: OUT.segments.csv, "
                                                            "or segments.csv without -o)");
    run_cmd->add_option("--export-profile", o.profile_dir,
                        "Directory for each wheel's profile stitched along the drive: left/right .csv and .erd "
                        "(ProVAL)");
    run_cmd->add_option("--read-ahead-m", o.read_ahead_m,
                        "Add each wheel's readout to every line: the profile read this far ahead, m, and kept in an "
                        "array along the drive as the vehicle drives on (the moving-average paper's profile)")
        ->check(rp::cli::positive_finite());
    run_cmd->add_option("--config", o.config_file, "JSON or YAML config file with the fields of rp.Config; flags override it");
    run_cmd->add_option("-o,--output", o.output, "Output JSON-lines file (default stdout)");
    run_cmd->add_flag("--roi-columns", o.roi_columns,
                      "End each frame as soon as the region of interest has been scanned (Ouster: decode only "
                      "the columns that can see it; Velodyne: the cut angle after it); needs the mounting");
    run_cmd->add_flag("-q,--quiet", o.quiet, "No per-frame progress on stderr");

    std::vector<std::string> info_inputs;
    rp::SourceOptions info_options;
    CLI::App* info_cmd = app.add_subcommand("info", "Describe a recording: sensor model, packet profile, frames, duration");
    info_cmd->add_option("INPUT", info_inputs, "One pcap, or frame files / directories")->required();
    add_source_options(info_cmd, info_options);

    RunOptions c;
    CLI::App* cal_cmd = app.add_subcommand("calibrate", "Estimate each beam's elevation (and range) offset from a drive");
    cal_cmd->add_option("INPUT", c.inputs, "Frame files, or directories of them (sorted by name), or one .pcap")->required();
    cal_cmd->add_option("--speed", c.speed, "Vehicle speed V in m/s");
    cal_cmd->add_option("--yaw-rate", c.yaw_rate, "Yaw rate in rad/s, positive turning left (default: IMU, else 0)");
    cal_cmd->add_option("--motion", c.motion_file, "CSV with columns t,speed,yaw_rate, interpolated at each frame's timestamp");
    cal_cmd->add_option("--poses", c.poses_file, "KITTI poses file, one 3x4 row-major pose per frame of the input");
    cal_cmd->add_option("--frames", c.frames, "Frames A:B of the input (0-based, B excluded; A: or :B)");
    cal_cmd->add_option("--frame-rate", c.frame_rate, "File inputs: frames per second (default 10)")
        ->check(rp::cli::above_and_at_most(0.01, 10000.0, true));
    auto* cal_height = cal_cmd->add_option("--sensor-height", c.sensor_height, "Sensor height above the ground, m");
    cal_cmd->add_option("--extrinsics", c.extrinsics, "Sensor pose in the base frame: x,y,z,roll,pitch,yaw (m, rad)")
        ->expected(6)->delimiter(',')->excludes(cal_height);
    cal_cmd->add_option("--ground", c.ground, "Ground method (default zones)")
        ->check(CLI::IsMember({"zones", "pca", "ransac"}));
    cal_cmd->add_option("--config", c.config_file, "JSON or YAML config file with the fields of rp.Config");
    cal_cmd->add_option("--beams", c.beams, "Beams of a sensor whose files do not number them (default 64, HDL-64E)")
        ->check(rp::cli::positive_finite());
    cal_cmd->add_option("--cell", c.cell, "Method motion: road cell in which beams are compared, m (default 0.2)")
        ->check(rp::cli::positive_finite());
    cal_cmd->add_option("--max-sigma", c.max_sigma,
                        "A beam less certain than this (deg) is not determined (default 0.01 motion, 0.05 surface)")
        ->check(rp::cli::positive_finite());
    cal_cmd->add_option("--method", c.calibration_method,
                        "motion: the same road seen by different beams as the vehicle moves (default); surface: each "
                        "frame's beams against its smooth road, no motion needed (docs/method.md §8)")
        ->check(CLI::IsMember({"motion", "surface"}));
    cal_cmd->add_option("-o,--output", c.output, "Beams file to write (YAML)")->required();
    cal_cmd->add_flag("-q,--quiet", c.quiet, "No per-frame progress on stderr");
    add_source_options(cal_cmd, c.source);

    const auto range_action = add_range_commands(app);
    const auto roadside_action = add_roadside_commands(app);  // roadside: see roadside_commands.cpp
    const auto replay_action = add_replay_command(app);

    if (const int status = parse_command_line(app, argc, argv); status >= 0) return status;
    try {
        if (info_cmd->parsed()) return info(info_inputs, info_options);
        if (cal_cmd->parsed()) return calibrate(c, *cal_cmd);
        if (app.got_subcommand("range")) return range_action();
        if (app.got_subcommand("roadside")) return roadside_action();
        if (const int status = replay_action(); status >= 0) return status;
        return run(o, *run_cmd);
    } catch (const UsageError& e) {
        std::fprintf(stderr, "roadpreview: error: %s\n", e.what());
        return 2;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "roadpreview: error: %s\n", e.what());
        return 1;
    }
}
