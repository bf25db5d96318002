// SPDX-License-Identifier: BSD-3-Clause
// `roadpreview range ...`: distance and offset calibration of point range sensors, and profiles from their
// readings (docs/method.md §8, docs/output.md "Range sensors").
#include "range_commands.hpp"

#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <stdexcept>

#include "cli_checks.hpp"
#include "output_file.hpp"

#include "roadpreview/roadpreview.hpp"

namespace rp = roadpreview;

namespace {

struct RangeOptions {
    std::string bench, reference, sensors, calibration, output, motion_file;
    std::vector<std::string> runs, motions;
    std::string readings;
    double speed = 0.0, yaw_rate = 0.0, frame_length_m = 40.0, search_m = 0.5;
    bool quiet = false;
};

int calibrate_distance(const RangeOptions& o) {
    std::vector<double> counts, distances;
    rp::read_bench_csv(o.bench, counts, distances);
    rp::RangeCalibration cal;
    if (!o.calibration.empty()) cal = rp::read_range_calibration(o.calibration);
    try {
        cal.distance = rp::calibrate_distance(counts, distances);
    } catch (const std::invalid_argument& e) {
        throw std::runtime_error(o.bench + ": " + e.what());
    }
    const rp::DistanceCalibration& d = *cal.distance;
    std::fprintf(stderr, "%s: d = %.9g * c + %.9g m  (a1 ± %.3g, a2 ± %.3g m), residual RMS %.3g mm, R² %.8f, "
                 "%lld readings used, %lld outliers rejected\n", o.bench.c_str(), d.a1, d.a2, d.a1_sigma, d.a2_sigma,
                 d.rms_m * 1e3, d.r_squared, static_cast<long long>(d.used), static_cast<long long>(d.rejected));
    rp::write_range_calibration(cal, o.output);
    return 0;
}

// The reference profile: a CSV with header x,z (m), x increasing.
void read_reference(const std::string& path, std::vector<double>& x, std::vector<double>& z) {
    std::ifstream in(path);
    if (!in) throw std::runtime_error(path + ": cannot open the reference profile");
    std::string line;
    std::int64_t number = 0;
    int xi = -1, zi = -1;
    while (std::getline(in, line)) {
        ++number;
        if (line.empty() || line[0] == '#') continue;
        std::vector<std::string> cells;
        std::size_t start = 0;
        for (std::size_t p; (p = line.find(',',
            start)) != std::string::npos; start = p + 1) cells.push_back(line.substr(start, p - start));
        cells.push_back(line.substr(start));
        for (auto& c : cells)
            while (!c.empty() && (c.back() == '\r' || c.back() == ' ')) c.pop_back();
        if (xi < 0) {
            for (std::size_t i = 0; i < cells.size(); ++i) {
                if (cells[i] == "x") xi = static_cast<int>(i);
                if (cells[i] == "z") zi = static_cast<int>(i);
            }
            if (xi < 0 || zi < 0) throw std::runtime_error(path + ":" + std::to_string(number)
                + ": expected a header x,z");
            continue;
        }
        try {
            const std::string& x_cell = cells.at(static_cast<std::size_t>(xi));
            const std::string& z_cell = cells.at(static_cast<std::size_t>(zi));
            std::size_t x_used = 0, z_used = 0;  // a cell is all number: "1.5abc" is no 1.5
            const double xv = std::stod(x_cell, &x_used), zv = std::stod(z_cell, &z_used);
            if (x_used != x_cell.size() || z_used != z_cell.size() || !std::isfinite(xv) || !std::isfinite(zv))
                throw std::invalid_argument("not finite numbers");
            if (!x.empty() && xv <= x.back()) throw std::runtime_error(path + ":" + std::to_string(number)
                + ": x must increase");
            x.push_back(xv);
            z.push_back(zv);
        } catch (const std::logic_error&) {
            throw std::runtime_error(path + ":" + std::to_string(number) + ": expected finite numbers x,z");
        }
    }
    if (x.size() < 2) throw std::runtime_error(path + ": the reference profile needs at least two rows");
}

int calibrate_offset(const RangeOptions& o) {
    if (o.runs.size() != o.motions.size())
        throw roadpreview::cli::UsageError("give one --motion file per run (" + std::to_string(o.runs.size()) +
                                           " runs, " + std::to_string(o.motions.size()) + " motion files)");
    rp::ReferenceProfile ref;
    read_reference(o.reference, ref.x_m, ref.z_m);
    const auto layout = rp::read_range_layout(o.sensors);
    std::vector<rp::RangeMotion> motions;
    for (const std::string& m : o.motions) motions.emplace_back(rp::MotionTable::read_csv(m));
    const rp::RangeCalibration cal = rp::calibrate_offsets(
        layout, o.calibration.empty() ? rp::RangeCalibration{} : rp::read_range_calibration(o.calibration), o.runs,
        motions, {{ref}}, o.search_m);
    for (const rp::RangeSensor& s : layout) {
        const rp::OffsetCalibration& c = *cal.offset_for(s.id);
        std::fprintf(stderr, "sensor %s: x = %.6f s * v + %.6f m  (b1 ± %.3g s, b2 ± %.3g m); cross-correlation: "
                     "b1 %.6f s, b2 %.6f m\n", s.id.c_str(), c.b1_s, c.b2_m, c.b1_sigma_s, c.b2_sigma_m, c.b1_xcorr_s,
                     c.b2_xcorr_m);
        for (const rp::RunShift& run : c.runs)
            std::fprintf(stderr, "  %s: %.3f m/s, shift %.5f ± %.5f m (cross-correlation %.5f m), height RMS %.2f mm, "
                         "%lld samples\n", run.source.c_str(), run.speed_mps, run.shift_m, run.shift_sigma_m,
                         run.xcorr_shift_m, run.rms_m * 1e3, static_cast<long long>(run.samples));
    }
    rp::write_range_calibration(cal, o.output);
    return 0;
}

// Streams the readings' windows to `out` as JSON lines (progress on stderr), counting them in `windows`; returns
// the readings read.
std::int64_t run_windows(rp::RangeProfiler& profiler, const RangeOptions& o, rp::RangeMotion motion,
                         std::ostream& out, std::int64_t& windows) {
    return profiler.run(o.readings, std::move(motion), [&](const rp::RangeWindow& w) {
        out << rp::range_window_to_json(w, profiler.layout(), o.readings) << '\n';
        ++windows;
        if (!o.quiet) {
            const auto cls = [](const rp::Roughness& r) { return r.iso_class ? std::string(1, *r.iso_class) : "-"; };
            std::fprintf(stderr, "window %lld: s %.1f-%.1f m, %zu samples, class L %s R %s\n",
                         static_cast<long long>(w.index), w.s_start_m, w.s_end_m, w.samples.size(),
                         cls(w.left.roughness).c_str(), cls(w.right.roughness).c_str());
        }
    });
}

int run_readings(const RangeOptions& o, bool with_motion) {
    auto layout = rp::read_range_layout(o.sensors);
    rp::RangeCalibration cal = o.calibration.empty()
        ? rp::RangeCalibration{} : rp::read_range_calibration(o.calibration);
    rp::RangeProfilerConfig cfg;
    cfg.frame_length_m = o.frame_length_m;
    rp::RangeProfiler profiler(std::move(layout), std::move(cal), cfg);
    rp::RangeMotion motion = with_motion ? rp::RangeMotion(rp::MotionTable::read_csv(o.motion_file))
                                         : rp::RangeMotion(o.speed, o.yaw_rate);
    rp::cli::OutputFile output(o.output);  // a run that writes no window leaves no empty file, as `run` leaves none
    std::int64_t windows = 0;
    const auto start = std::chrono::steady_clock::now();
    const std::int64_t readings = run_windows(profiler, o, std::move(motion), output.stream(), windows);
    output.check_written();
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::fprintf(stderr, "%s: %lld readings, %lld windows in %.2f s (%.0f readings/s)\n", o.readings.c_str(),
                 static_cast<long long>(readings), static_cast<long long>(windows), s, readings / std::max(s, 1e-9));
    if (profiler.dropped_behind() > 0)
        std::fprintf(stderr, "roadpreview: warning: %s: %lld samples fell behind the start of their window and were "
                     "dropped: the track ran backwards (reversing, or a negative speed in the motion), or samples lay "
                     "behind the axle (b1·v + b2 < 0: at that speed the latency b1 outruns the lead b2)\n",
                     o.readings.c_str(), static_cast<long long>(profiler.dropped_behind()));
    if (windows == 0) {  // as `roadpreview run` does: a run that writes nothing fails
        throw std::runtime_error(o.readings + ": no window was written (" + std::to_string(readings) +
                                 " readings); nothing was written");
    }
    return 0;
}

}  // namespace

std::function<int()> add_range_commands(CLI::App& app) {
    auto o = std::make_shared<RangeOptions>();
    CLI::App* range = app.add_subcommand("range", "Point range preview sensors (ultrasonic, laser): calibrate, run");
    range->require_subcommand(1);

    CLI::App* dist = range->add_subcommand("calibrate-distance",
        "Fit d = a1*c + a2 to bench readings (CSV count,distance)");
    dist->add_option("BENCH", o->bench, "CSV with header count,distance (m)")->required();
    dist->add_option("--calibration", o->calibration, "Existing calibration file to keep the per-sensor entries of");
    dist->add_option("-o,--output", o->output, "Calibration file to write (YAML)")->required();

    CLI::App* off = range->add_subcommand("calibrate-offset",
        "Fit x = b1*v + b2 from runs over a known profile at 2+ speeds");
    off->add_option("RUNS", o->runs, "Readings CSV of each run")->required();
    off->add_option("--reference", o->reference, "Known profile, CSV with header x,z (m; x where the axle is at the "
                                                  "motion table's first time = 0)")->required();
    off->add_option("--sensors", o->sensors, "Sensor layout (YAML)")->required();
    off->add_option("--calibration", o->calibration, "Calibration file with the distance calibration");
    off->add_option("--motion", o->motions,
        "Motion CSV (t,speed,yaw_rate) of each run, in the runs' order")->required();
    off->add_option("--search", o->search_m,
        "Search the shift within the layout's geometric foot ± this, m (default 0.5)")
        ->check(roadpreview::cli::positive_finite());
    off->add_option("-o,--output", o->output, "Calibration file to write (YAML)")->required();

    CLI::App* run = range->add_subcommand("run", "Profiles, ISO 8608 class and IRI from range sensor readings");
    run->add_option("READINGS", o->readings, "CSV t,sensor,count or t,sensor,distance [,temperature_c]")->required();
    run->add_option("--sensors", o->sensors, "Sensor layout (YAML)")->required();
    run->add_option("--calibration", o->calibration, "Calibration file (needed for counts)");
    auto* speed = run->add_option("--speed", o->speed, "Constant speed, m/s");
    auto* yaw = run->add_option("--yaw-rate", o->yaw_rate, "Constant yaw rate, rad/s (with --speed; default 0)");
    auto* motion = run->add_option("--motion", o->motion_file, "Motion CSV t,speed,yaw_rate in the readings' clock");
    motion->excludes(speed)->excludes(yaw);
    run->add_option("--frame-length-m", o->frame_length_m, "Window length along the track, m (default 40)")
        ->check(roadpreview::cli::positive_finite());
    run->add_option("-o,--output", o->output, "Output JSON-lines file (default stdout)");
    run->add_flag("-q,--quiet", o->quiet, "No per-window progress on stderr");

    return [o, dist, off, run, motion, speed]() {
        if (dist->parsed()) return calibrate_distance(*o);
        if (off->parsed()) return calibrate_offset(*o);
        if (!motion->count() && !speed->count())
            throw roadpreview::cli::UsageError("range run needs --motion M.csv or --speed V");
        return run_readings(*o, motion->count() > 0);
    };
}
