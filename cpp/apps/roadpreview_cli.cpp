// SPDX-License-Identifier: BSD-3-Clause
// roadpreview — command-line front end: `roadpreview run INPUT... [options]` writes one JSON line per frame.
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>

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

void report_frame(std::size_t i, std::size_t total, const rp::Result& r) {
    std::fprintf(stderr, "[%zu/%zu] %s: %lld points, %lld ground%s, class L=%s R=%s vehicle=%s%s%s, %.2f ms\n", i + 1,
                 total, r.source.c_str(), static_cast<long long>(r.points.input),
                 static_cast<long long>(r.points.ground), obstacles_of(r).c_str(), class_of(r.left.roughness).c_str(),
                 class_of(r.right.roughness).c_str(), class_of(r.vehicle).c_str(), r.reason.empty() ? "" : " — ",
                 r.reason.c_str(), r.timing_ms.total);
}

int run(const RunOptions& o, const CLI::App& app) {
    rp::Estimator est(build_config(o, app));
    const std::vector<std::string> files = rp::expand_inputs(o.inputs);
    std::ofstream file;
    if (!o.output.empty()) {
        file.open(o.output);
        if (!file) throw std::runtime_error(o.output + ": cannot open output file for writing");
    }
    std::ostream& out = o.output.empty() ? std::cout : file;

    std::map<std::string, int> classes;
    std::vector<double> ms;
    for (std::size_t i = 0; i < files.size(); ++i) {
        const rp::Frame frame = rp::read_frame(files[i]);
        rp::Result r = est.process(frame.points, o.speed, o.yaw_rate, frame.source);
        if (o.frame_rate > 0.0) r.timestamp = static_cast<double>(i) / o.frame_rate;
        out << rp::result_to_json(r) << '\n';
        if (!out) throw std::runtime_error((o.output.empty() ? "stdout" : o.output) + ": write failed");
        ++classes[class_of(r.vehicle)];
        ms.push_back(r.timing_ms.total);
        if (!o.quiet) report_frame(i, files.size(), r);
    }
    std::sort(ms.begin(), ms.end());
    std::fprintf(stderr, "roadpreview: %zu frame(s), pipeline median %.2f ms, max %.2f ms; vehicle classes:", ms.size(),
                 ms[ms.size() / 2], ms.back());
    for (const auto& [cls, n] : classes) std::fprintf(stderr, " %s×%d", cls.c_str(), n);
    std::fprintf(stderr, "\n");
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"roadpreview: road height profiles and ISO 8608 roughness ahead of the wheels, from LiDAR"};
    app.set_version_flag("--version", std::string("roadpreview ") + rp::kVersion);
    app.require_subcommand(1);

    RunOptions o;
    CLI::App* run_cmd = app.add_subcommand("run", "Process KITTI .bin / .pcd frames (files or directories)");
    run_cmd->add_option("INPUT", o.inputs, "Frame files, or directories of them (sorted by name)")->required();
    run_cmd->add_option("--speed", o.speed, "Vehicle speed V in m/s (negative when reversing)")->required();
    run_cmd->add_option("--yaw-rate", o.yaw_rate, "Yaw rate ω in rad/s (positive turning left)")->default_val(0.0);
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
    run_cmd->add_option("--frame-rate", o.frame_rate, "Frames per second; adds timestamps frame/rate")
        ->check(CLI::PositiveNumber);
    run_cmd->add_option("--config", o.config_file, "JSON or YAML config file with the fields of rp.Config; flags override it");
    run_cmd->add_option("-o,--output", o.output, "Output JSON-lines file (default stdout)");
    run_cmd->add_flag("-q,--quiet", o.quiet, "No per-frame progress on stderr");

    CLI11_PARSE(app, argc, argv);
    try {
        return run(o, *run_cmd);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "roadpreview: error: %s\n", e.what());
        return 1;
    }
}
