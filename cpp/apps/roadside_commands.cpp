// SPDX-License-Identifier: BSD-3-Clause
// `roadpreview roadside run|detect|info|extrinsics` (README "Roadside", docs/output.md "Roadside").
#include "roadside_commands.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>

#include <unistd.h>

#include "cli_checks.hpp"
#include "helper_programs.hpp"
#include "output_file.hpp"
#include "roadpreview/roadside/extrinsics.hpp"
#include "roadpreview/roadside/processor.hpp"
#include "roadpreview/roadside/sick.hpp"

namespace rs = roadpreview::roadside;
using roadpreview::cli::UsageError;

namespace {

// Camera detection from a video, done by the helper program roadpreview-video (README "Roadside").
struct VideoOptions {
    std::string video;
    std::vector<std::string> cascades;
    bool no_people = false;
    double people_threshold = 0.0, start_s = 0.0;
    int process_width_px = 720, stride = 1;
};

struct RoadsideOptions {
    VideoOptions camera;
    std::string site, detections, output, geojson;
    std::vector<std::string> inputs;
    double carmen_rate_hz = 37.5, max_distance_m = 1.0;
    int sensor_port = 2112;
    bool skip_bad = false, quiet = false;
};

// Round-trips exactly through the helper's command line.
std::string number(double v) {
    std::ostringstream s;
    s.precision(std::numeric_limits<double>::max_digits10);
    s << v;
    return s.str();
}

bool ends_with(const std::string& s, const std::string& tail) {
    return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

// "NAME=FILE" names the site scanner of a file; a bare FILE is the next scanner, in the site's order, that no file
// is named for.
struct Input {
    std::string path;
    int scanner = -1;
};

std::vector<Input> resolve_inputs(const std::vector<std::string>& args, const rs::Site* site) {
    std::vector<Input> out;
    std::vector<bool> named(site ? site->scanners.size() : 0, false);
    for (const auto& a : args) {
        Input in{a, -1};
        const auto eq = a.find('=');
        if (site && eq != std::string::npos) {
            const std::string name = a.substr(0, eq);
            for (std::size_t i = 0; i < site->scanners.size(); ++i)
                if (site->scanners[i].name == name) in = {a.substr(eq + 1), static_cast<int>(i)}, named[i] = true;
            if (in.scanner < 0) throw UsageError(a + ": no scanner named '" + name + "' in " + site->path);
        }
        out.push_back(in);
    }
    // A file without a name takes the next scanner no file is named for (s1=a.json b.json: b is s2, not s1 again).
    std::size_t next = 0;
    for (Input& in : out) {
        if (in.scanner >= 0 || ends_with(in.path, ".csv")) continue;
        while (next < named.size() && named[next]) ++next;
        in.scanner = static_cast<int>(next++);
        if (site && in.scanner >= static_cast<int>(site->scanners.size()))
            throw UsageError(in.path + ": the site file " + site->path + " has " +
                             std::to_string(site->scanners.size()) + " scanner(s), and no scanner is left for this "
                             "scan file (name each file's scanner: NAME=FILE)");
    }
    return out;
}

// Every scan of one input file, by its extension; CSV files say their scanner per row.
std::vector<rs::LaserScan> read_input(const Input& in, const RoadsideOptions& o, rs::SickDecodeCounts* counts,
                                      std::string* note) {
    std::vector<rs::LaserScan> scans;
    const std::string& p = in.path;
    if (ends_with(p, ".csv")) {
        scans = rs::read_scan_csv(p);
    } else if (ends_with(p, ".json")) {
        scans = rs::scans_from_telegrams(rs::read_sick_json(p), o.skip_bad, counts);
    } else if (ends_with(p, ".pcap") || ends_with(p, ".pcapng")) {
        std::string truncated;  // with --skip-bad, the telegrams before a break are read and the break noted
        scans = rs::scans_from_telegrams(rs::read_sick_pcap(p, o.sensor_port, o.skip_bad ? &truncated : nullptr),
                                         o.skip_bad, counts);
        if (!truncated.empty() && note) *note = truncated;
    } else if (ends_with(p, ".log") || ends_with(p, ".log.gz") || ends_with(p, ".clf") || ends_with(p, ".clf.gz")) {
        bool missing = false;
        scans = rs::read_carmen_log(p, o.carmen_rate_hz, 0.0, &missing);
        char rate[32];
        std::snprintf(rate, sizeof rate, "%g", o.carmen_rate_hz);
        if (missing && note) *note = p + ": the log's timestamps are all 0; scans timed at --scan-rate " + rate + " Hz";
    } else if (ends_with(p, ".bag") || ends_with(p, ".mcap") || ends_with(p, ".db3")) {
        throw std::runtime_error(p + ": ROS bags are read in Python (rp.roadside.read_rosbag_scans, the rosbags "
                                     "package); write them to the scan CSV for the CLI");
    } else {
        throw std::runtime_error(p + ": unknown scan format (expected .csv, SICK .json dump, .pcap/.pcapng, CARMEN "
                                     ".log[.gz])");
    }
    if (in.scanner >= 0)
        for (auto& s : scans) s.scanner = in.scanner;
    return scans;
}

// Why an input gave no scans, for the error when none did.
std::string why_no_scans(const Input& in, const rs::SickDecodeCounts& counts, int sensor_port) {
    const std::string& p = in.path;
    if ((ends_with(p, ".pcap") || ends_with(p, ".pcapng")) && counts.telegrams == 0)
        return p + ": no SICK telegram in a TCP stream on port " + std::to_string(sensor_port) +
               " (not a SICK capture, or another --sensor-port)";
    if (counts.telegrams > 0) return p + ": " + std::to_string(counts.telegrams) + " telegrams, none a scan";
    return p + ": no scans";
}

// A file's scans of one scanner should come in time order; the run merges every file's scans by time, which would
// take a restamped scan (0.5 s back) elsewhere in the sequence unsaid.
void warn_time_steps_back(const std::string& path, const std::vector<rs::LaserScan>& scans) {
    std::map<int, double> last;  // per scanner
    long long back = 0;
    double most = 0.0;
    for (const auto& s : scans) {
        const auto it = last.find(s.scanner);
        if (it != last.end() && s.time_s < it->second) ++back, most = std::max(most, it->second - s.time_s);
        last[s.scanner] = it != last.end() ? std::max(it->second, s.time_s) : s.time_s;
    }
    if (back > 0)
        std::fprintf(stderr, "roadpreview: warning: %s: %lld scans are timed before a scan they follow (by up to "
                     "%.3g s); the run takes every scan in time order\n", path.c_str(), back, most);
}

std::vector<rs::LaserScan> read_all(const std::vector<Input>& inputs, const RoadsideOptions& o, bool quiet,
                                    std::vector<std::string>* empty = nullptr) {
    std::vector<rs::LaserScan> all;
    for (const auto& in : inputs) {
        rs::SickDecodeCounts counts;
        std::string note;
        auto scans = read_input(in, o, &counts, &note);
        if (scans.empty() && empty) empty->push_back(why_no_scans(in, counts, o.sensor_port));
        if (!quiet && counts.telegrams)
            std::fprintf(stderr, "%s: %lld telegrams, %lld scans, %lld other, %lld bad, %lld repeating the scan before "
                         "(dropped)\n", in.path.c_str(), static_cast<long long>(counts.telegrams),
                         static_cast<long long>(counts.scans), static_cast<long long>(counts.other),
                         static_cast<long long>(counts.bad), static_cast<long long>(counts.repeated));
        if (!note.empty()) std::fprintf(stderr, "note: %s\n", note.c_str());
        warn_time_steps_back(in.path, scans);
        all.insert(all.end(), std::make_move_iterator(scans.begin()), std::make_move_iterator(scans.end()));
    }
    return all;
}

// roadpreview-video's command line for `video` writing the detections CSV `output`.
std::vector<std::string> video_command(const VideoOptions& v, const std::string& output, const std::string& size,
                                       bool quiet) {
    std::vector<std::string> args{program_beside_self("roadpreview-video"), v.video, "-o", output,
                                  "--process-width", std::to_string(v.process_width_px),
                                  "--stride", std::to_string(v.stride), "--start", number(v.start_s),
                                  "--people-threshold", number(v.people_threshold)};
    for (const auto& c : v.cascades) args.insert(args.end(), {"--cascade", c});
    if (v.no_people) args.push_back("--no-people");
    if (!size.empty()) args.insert(args.end(), {"--expect-size", size});
    if (quiet) args.push_back("-q");
    return args;
}

// The video's detections through roadpreview-video and a scratch CSV; frames must have the site camera's size.
std::vector<rs::CameraDetection> detect_in_video(const VideoOptions& v, const rs::Site& site, bool quiet) {
    if (!site.camera) throw std::runtime_error(v.video + ": a video needs a camera in the site file " + site.path);
    const std::string size = site.camera->width_px > 0 && site.camera->height_px > 0
                                 ? std::to_string(site.camera->width_px) + "x" + std::to_string(site.camera->height_px)
                                 : "";
    std::string scratch = (std::filesystem::temp_directory_path() / "roadpreview-video-XXXXXX.csv").string();
    const int fd = mkstemps(scratch.data(), 4);
    if (fd < 0) throw std::runtime_error(scratch + ": cannot create a scratch file for the video's detections");
    close(fd);
    struct Remove {
        std::string path;
        ~Remove() { std::remove(path.c_str()); }
    } remove{scratch};
    const int status = run_program(video_command(v, scratch, size, quiet));
    if (status != 0)
        throw std::runtime_error(v.video + ": camera detection failed (roadpreview-video exited with " +
                                 std::to_string(status) + ")");
    return rs::read_detections(scratch);
}

int detect(const RoadsideOptions& o) { return run_program(video_command(o.camera, o.output, "", o.quiet)); }

int run(const RoadsideOptions& o) {
    const rs::Site site = rs::read_site(o.site);
    std::vector<std::string> empty;
    auto scans = read_all(resolve_inputs(o.inputs, &site), o, o.quiet, &empty);
    if (scans.empty()) {
        std::string why;
        for (const std::string& e : empty) why += (why.empty() ? "" : "; ") + e;
        throw std::runtime_error("no scans in the inputs: " + why);
    }
    for (std::size_t i = 0; i < site.scanners.size(); ++i)  // a scanner named in the site but given no file
        if (std::none_of(scans.begin(), scans.end(), [&](const rs::LaserScan& s) { return s.scanner == static_cast<int>(i); }))
            std::fprintf(stderr, "roadpreview: warning: site scanner '%s' has no scans in the inputs\n",
                         site.scanners[i].name.c_str());
    // Site clock: each scanner's offset applied before merging, so the cycles see one time line.
    std::stable_sort(scans.begin(), scans.end(), [&](const rs::LaserScan& a, const rs::LaserScan& b) {
        auto offset = [&](const rs::LaserScan& s) {
            return s.scanner >= 0 && s.scanner < static_cast<int>(site.scanners.size())
                       ? site.scanners[static_cast<std::size_t>(s.scanner)].time_offset_s : 0.0;
        };
        return a.time_s + offset(a) < b.time_s + offset(b);
    });
    rs::Processor processor(site);
    if (std::any_of(scans.begin(), scans.end(), [](const rs::LaserScan& s) { return s.pose.has_value(); })) {
        processor.learn_world(scans);  // a moving scanner: its background is the world its log saw
        const rs::WorldBackground& w = *processor.world();
        if (!o.quiet)
            std::fprintf(stderr, "world background from the scans with poses: %d × %d cells of %.2f m, scan period %.3f s\n",
                         w.width_cells(), w.height_cells(), site.settings.world.cell_m, w.scan_period_s());
    }
    if (!o.detections.empty()) processor.add_detections(rs::read_detections(o.detections));
    if (!o.camera.video.empty()) processor.add_detections(detect_in_video(o.camera, site, o.quiet));
    roadpreview::cli::OutputFile output(o.output);  // a run that fails before its first cycle leaves no empty file
    std::ostream& out = output.stream();
    std::vector<rs::Cycle> kept;  // for GeoJSON only
    long long cycles = 0, objects = 0, dropouts = 0;
    double worst_ms = 0.0, total_ms = 0.0;
    std::vector<bool> was_active(site.scanners.size(), true);
    auto emit = [&](const std::vector<rs::Cycle>& done) {
        for (const auto& c : done) {
            out << rs::cycle_to_json(c) << '\n';
            ++cycles, objects += static_cast<long long>(c.objects.size());
            worst_ms = std::max(worst_ms, c.process_ms), total_ms += c.process_ms;
            for (std::size_t i = 0; i < c.scanners.size(); ++i) {
                if (was_active[i] && !c.scanners[i].active && c.scanners[i].scans > 0) {
                    ++dropouts;
                    std::fprintf(stderr, "warning: scanner '%s' silent since t = %.3f s (cycle t = %.3f s)\n",
                                 c.scanners[i].name.c_str(), c.scanners[i].last_scan_s, c.t_s);
                }
                was_active[i] = c.scanners[i].active;
            }
            if (!o.geojson.empty()) kept.push_back(c);
            if (!o.quiet && cycles % 500 == 0) std::fprintf(stderr, "cycle %lld, t = %.2f s\n", cycles, c.t_s);
        }
    };
    for (const auto& s : scans) emit(processor.push(s));
    emit(processor.finish());
    if (const std::string warning = processor.detections_outside_warning(); !warning.empty() && cycles > 0)
        std::fprintf(stderr, "roadpreview: warning: %s\n", warning.c_str());
    output.check_written();
    if (cycles == 0) throw std::runtime_error("no cycle written: the inputs end within the background learning time");
    if (!o.geojson.empty()) {
        std::ofstream g(o.geojson);
        if (!g) throw std::runtime_error(o.geojson + ": cannot write");
        g << rs::cycles_to_geojson(kept) << '\n';
        g.flush();
        if (!g) throw std::runtime_error(o.geojson + ": write failed");
    }
    std::fprintf(stderr, "%lld scans, %lld cycles, %lld object reports, %lld scanner dropouts; cycle processing "
                 "mean %.3f ms, worst %.3f ms\n", static_cast<long long>(scans.size()), cycles, objects, dropouts,
                 total_ms / static_cast<double>(cycles), worst_ms);
    return 0;
}

// One scanner's scans of a file: layout, time span and rate, counters, ranges.
void describe_scans(const std::vector<const rs::LaserScan*>& scans) {
    const rs::LaserScan& f = *scans.front();
    const double deg = 180.0 / 3.14159265358979323846;
    std::printf("  beams %zu, angles %.4f° to %.4f° in %.4f° steps (scanner frame, 0° ahead), intensities %s\n",
                f.ranges_m.size(), f.start_angle_rad * deg, f.angle_rad(f.ranges_m.size() - 1) * deg, f.step_rad * deg,
                f.intensities.empty() ? "no" : "yes");
    const auto [first, last] = std::minmax_element(scans.begin(), scans.end(),
                                                   [](const auto* a, const auto* b) { return a->time_s < b->time_s; });
    const double t0 = (*first)->time_s, t1 = (*last)->time_s;
    std::printf("  time %.3f to %.3f s (%.3f s)", t0, t1, t1 - t0);
    if (scans.size() > 1 && t1 > t0) std::printf(", %.2f Hz", static_cast<double>(scans.size() - 1) / (t1 - t0));
    std::printf("\n");
    if (f.counter >= 0)
        std::printf("  scan counter %lld to %lld\n", static_cast<long long>(f.counter),
                    static_cast<long long>(scans.back()->counter));
    float lo = INFINITY, hi = 0.0f;
    long long valid = 0, total = 0;
    for (const auto* s : scans)
        for (float r : s->ranges_m) {
            ++total;
            if (std::isfinite(r)) ++valid, lo = std::min(lo, r), hi = std::max(hi, r);
        }
    std::printf("  ranges %.3f to %.3f m, %lld of %lld beams with a return\n", valid ? lo : 0.0f, hi, valid, total);
}

// What each file holds, per scanner (a CSV may hold several): 1 when a file holds no scan, and why.
int info(const RoadsideOptions& o) {
    int status = 0;
    for (const auto& in : resolve_inputs(o.inputs, nullptr)) {
        std::vector<std::string> empty;
        const auto scans = read_all({in}, o, false, &empty);
        std::printf("%s: %zu scans\n", in.path.c_str(), scans.size());
        if (scans.empty()) {
            std::fprintf(stderr, "roadpreview: %s\n", empty.empty() ? (in.path + ": no scans").c_str() : empty[0].c_str());
            status = 1;
            continue;
        }
        std::map<int, std::vector<const rs::LaserScan*>> by_scanner;
        for (const auto& s : scans) by_scanner[s.scanner].push_back(&s);
        for (const auto& [scanner, of_one] : by_scanner) {
            if (by_scanner.size() > 1) std::printf(" scanner %d: %zu scans\n", scanner, of_one.size());
            describe_scans(of_one);
        }
    }
    return status;
}

// Scanner 2 (or the second input's scanner) registered onto the first from a static scene: prints the pose.
int extrinsics(const RoadsideOptions& o) {
    const rs::Site site = rs::read_site(o.site);
    const auto inputs = resolve_inputs(o.inputs, &site);
    if (inputs.size() != 2)
        throw UsageError("extrinsics takes two scan files: the fixed scanner's, then the moving one's");
    std::vector<std::vector<rs::LaserScan>> scans;
    for (const auto& in : inputs) scans.push_back(read_all({in}, o, true));
    for (std::size_t k = 0; k < 2; ++k)
        if (scans[k].empty()) throw std::runtime_error(inputs[k].path + ": no scans");
    const int a = scans[0][0].scanner, b = scans[1][0].scanner;
    for (int s : {a, b})
        if (s < 0 || s >= static_cast<int>(site.scanners.size()))
            throw std::runtime_error("scanner " + std::to_string(s) + " is not in " + site.path);
    if (a == b) throw std::runtime_error("both inputs are scanner '" + site.scanners[static_cast<std::size_t>(a)].name + "'");
    const auto& fixed = site.scanners[static_cast<std::size_t>(a)];
    const auto& moving = site.scanners[static_cast<std::size_t>(b)];
    const rs::ExtrinsicsResult r = rs::register_scanners(scans[0], fixed.pose, scans[1], moving.pose, o.max_distance_m);
    const double deg = 180.0 / 3.14159265358979323846;
    if (!r.converged) {  // no site entry to paste: the one printed would be the guess, or ICP's last wrong step
        char fitness[64] = "no point pairs within --max-distance";  // PCL's fitness is then DBL_MAX
        if (r.fitness_m2 < std::numeric_limits<double>::max()) std::snprintf(fitness, sizeof fitness, "fitness %.4g m²", r.fitness_m2);
        throw std::runtime_error(moving.name + " onto " + fixed.name + ": ICP did not converge (" + fitness +
                                 "): the scans share too little of the scene within --max-distance, or the site "
                                 "poses are too far off to start from");
    }
    std::fprintf(stderr, "%s onto %s: converged, fitness %.4f m² (RMS %.3f m), moved by (%.3f, %.3f) m and %.3f°\n",
                 moving.name.c_str(), fixed.name.c_str(), r.fitness_m2, std::sqrt(r.fitness_m2),
                 r.pose.x_m - moving.pose.x_m, r.pose.y_m - moving.pose.y_m, (r.pose.yaw_rad - moving.pose.yaw_rad) * deg);
    std::printf("- {name: %s, x_m: %.4f, y_m: %.4f, yaw_deg: %.4f, time_offset_s: %g}\n", moving.name.c_str(),
                r.pose.x_m, r.pose.y_m, r.pose.yaw_rad * deg, moving.time_offset_s);
    return 0;
}

}  // namespace

std::function<int()> add_roadside_commands(CLI::App& app) {
    auto o = std::make_shared<RoadsideOptions>();
    CLI::App* roadside = app.add_subcommand("roadside", "Roadside perception: 2-D laser scanners (+ camera) → tracked "
                                                        "objects in WGS84");
    roadside->require_subcommand(1);
    CLI::App* run_cmd = roadside->add_subcommand("run", "Objects per cycle from scans (JSON lines)");
    run_cmd->add_option("--site", o->site, "Site file (YAML): scanners, camera, origin, processing")->required();
    run_cmd->add_option("SCANS", o->inputs, "Scan files: SICK .json dump or .pcap/.pcapng, CARMEN .log[.gz], scan "
                                            ".csv; NAME=FILE assigns a site scanner")->required();
    run_cmd->add_option("--detections", o->detections, "Camera detections, CSV t,x,y,w,h,class,score or JSON");
    run_cmd->add_option("--video", o->camera.video, "Camera video: detections by the built-in HOG people detector "
                                                    "and --cascade files (roadpreview-video)");
    run_cmd->add_option("-o,--output", o->output, "JSON lines to write (default stdout)");
    run_cmd->add_option("--geojson", o->geojson, "Also write the objects as a GeoJSON FeatureCollection");
    run_cmd->add_flag("--skip-bad", o->skip_bad, "Skip and count telegrams that do not decode instead of stopping");
    run_cmd->add_flag("-q,--quiet", o->quiet, "No progress on stderr");
    CLI::App* detect_cmd = roadside->add_subcommand("detect", "Camera detections from a video (HOG people detector, "
                                                              "Viola–Jones cascades) as CSV t,x,y,w,h,class,score");
    detect_cmd->add_option("VIDEO", o->camera.video, "Video file (any container and codec OpenCV's FFmpeg reads)")
        ->required();
    detect_cmd->add_option("-o,--output", o->output, "Detections CSV to write")->required();
    detect_cmd->add_flag("-q,--quiet", o->quiet, "No progress on stderr");
    for (CLI::App* cmd : {run_cmd, detect_cmd}) {
        VideoOptions& v = o->camera;
        cmd->add_option("--cascade", v.cascades, "CLASS=FILE[:MIN_NEIGHBOURS]: a Viola–Jones cascade (OpenCV XML) "
                                                 "whose detections get CLASS (repeatable)");
        cmd->add_flag("--no-people", v.no_people, "Do not run the HOG people detector (class pedestrian)");
        cmd->add_option("--people-threshold", v.people_threshold, "HOG SVM margin a person needs, ≥ 0 (default 0; its score is margin/(1 + margin))");
        cmd->add_option("--process-width", v.process_width_px, "Video frames are scaled to this width for detection, "
                                                               "px (default 720, as the paper)");
        cmd->add_option("--video-stride", v.stride, "Detect in every n-th video frame (default 1)")
            ->check(roadpreview::cli::positive_finite());
        cmd->add_option("--video-start", v.start_s, "Camera time of the video's first frame, s (default 0)");
    }
    CLI::App* info_cmd = roadside->add_subcommand("info", "What scan files hold: scans, beams, angles, times, ranges");
    info_cmd->add_option("SCANS", o->inputs, "Scan files")->required();
    info_cmd->add_flag("--skip-bad", o->skip_bad, "Skip and count telegrams that do not decode");
    CLI::App* ext_cmd = roadside->add_subcommand("extrinsics", "Register a scanner onto another from a static scene "
                                                                "(PCL ICP); prints its site entry");
    ext_cmd->add_option("--site", o->site, "Site file with both scanners' approximate poses")->required();
    ext_cmd->add_option("SCANS", o->inputs, "FIXED MOVING scan files (NAME=FILE to name their scanners)")->required();
    ext_cmd->add_option("--max-distance", o->max_distance_m, "ICP correspondence distance, m (default 1)")
        ->check(roadpreview::cli::positive_finite());
    for (CLI::App* cmd : {run_cmd, info_cmd, ext_cmd}) {
        cmd->add_option("--scan-rate", o->carmen_rate_hz, "Scan rate for logs without timestamps (CARMEN), Hz "
                                                          "(default 37.5)")->check(roadpreview::cli::positive_finite());
        cmd->add_option("--sensor-port", o->sensor_port, "TCP port of the scanner in captures (default 2112)")
            ->check(CLI::Range(1, 65535));
    }
    return [o, run_cmd, ext_cmd, detect_cmd]() {
        if (run_cmd->parsed()) return run(*o);
        if (detect_cmd->parsed()) return detect(*o);
        return ext_cmd->parsed() ? extrinsics(*o) : info(*o);
    };
}
