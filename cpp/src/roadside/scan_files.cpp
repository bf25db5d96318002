// SPDX-License-Identifier: BSD-3-Clause
// Plain scan files: the project's CSV and CARMEN logs (zlib reads them gzipped or not).
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "core/csv.hpp"
#include "core/input_file.hpp"
#include "core/text.hpp"
#include "roadpreview/roadside/scan.hpp"

namespace roadpreview::roadside {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

struct CsvBeam {
    double t, angle_deg;
    int scanner;
    float range_m, intensity;
    std::int64_t line;
};

// Closes the scan being built: the beams must be at one constant step.
void finish_scan(std::vector<CsvBeam>& beams, bool with_intensity, const std::string& path, std::vector<LaserScan>& out) {
    if (beams.empty()) return;
    LaserScan s;
    s.time_s = beams[0].t;
    s.scanner = beams[0].scanner;
    s.source = path + ":" + std::to_string(beams[0].line);
    s.start_angle_rad = beams[0].angle_deg * kDeg;
    const double step_deg = beams.size() > 1 ? beams[1].angle_deg - beams[0].angle_deg : 0.0;
    if (beams.size() > 1 && !(step_deg > 0.0))
        throw std::runtime_error(path + ":" + std::to_string(beams[1].line) + ": angles must increase within a scan");
    s.step_rad = step_deg * kDeg;
    for (std::size_t i = 0; i < beams.size(); ++i) {
        const double expected = beams[0].angle_deg + step_deg * static_cast<double>(i);
        if (std::abs(beams[i].angle_deg - expected) > 1e-3 * std::max(1.0, step_deg) + 1e-6)
            throw std::runtime_error(path + ":" + std::to_string(beams[i].line) +
                                     ": angle_deg breaks the scan's constant step");
        s.ranges_m.push_back(beams[i].range_m);
        if (with_intensity) s.intensities.push_back(beams[i].intensity);
    }
    out.push_back(std::move(s));
    beams.clear();
}

// One line of a gzip or plain text file; false at the end.
class TextLines {
public:
    explicit TextLines(const std::string& path)
        : file_((require_input_file<std::runtime_error>(path, "scans"), gzopen(path.c_str(), "rb")), &gzclose) {
        if (!file_) throw std::runtime_error(path + ": cannot open");
    }
    bool next(std::string& line) {
        line.clear();
        char buffer[8192];
        while (gzgets(file_.get(), buffer, sizeof buffer)) {
            line += buffer;
            if (!line.empty() && line.back() == '\n') break;
        }
        if (line.empty()) return false;
        while (!line.empty() && (line.back() == '\n' || line.back() == '\r')) line.pop_back();
        ++number_;
        return true;
    }
    std::int64_t number() const { return number_; }

private:
    std::unique_ptr<gzFile_s, decltype(&gzclose)> file_;
    std::int64_t number_ = 0;
};

double parse_double(const std::string& token, const std::string& where, const char* what) {
    const std::optional<double> v = parse_number(token);
    if (!v) throw std::runtime_error(where + ": " + what + " '" + token + "' is not a number");
    return *v;
}

}  // namespace

std::vector<LaserScan> read_scan_csv(const std::string& path) {
    require_input_file<std::runtime_error>(path, "scans");
    std::ifstream in(path);
    if (!in) throw std::runtime_error(path + ": cannot open");
    std::vector<LaserScan> out;
    std::vector<CsvBeam> beams;
    csv::Header header;
    bool with_intensity = false;
    std::string line;
    for (std::int64_t number = 1; std::getline(in, line); ++number) {
        if (csv::skipped(line)) continue;
        const auto cells = csv::split(line);
        const std::string where = path + ":" + std::to_string(number);
        if (header.empty()) {
            header = csv::Header(cells, {"t", "scanner", "angle_deg", "range_m"}, where);
            with_intensity = std::find(cells.begin(), cells.end(), "intensity") != cells.end();
            continue;
        }
        CsvBeam b;
        b.line = number;
        b.t = csv::finite_cell(cells, header.at("t"), where, "t");
        const double scanner = csv::finite_cell(cells, header.at("scanner"), where, "scanner");
        if (scanner < 0 || scanner > 255 || scanner != std::floor(scanner))
            throw std::runtime_error(where + ": scanner must be an integer 0..255");
        b.scanner = static_cast<int>(scanner);
        b.angle_deg = csv::finite_cell(cells, header.at("angle_deg"), where, "angle_deg");
        const std::size_t rc = header.at("range_m");
        if (rc >= cells.size())  // an empty cell is no return; a missing one, a line cut short
            throw std::runtime_error(where + ": the row ends before its range_m column (a line cut short?)");
        const std::string& range = cells[rc];
        const double r = range.empty() ? NAN : parse_double(range, where, "range_m");
        b.range_m = std::isfinite(r) && r > 0.0 ? static_cast<float>(r) : NAN;
        b.intensity = with_intensity ? static_cast<float>(csv::finite_cell(cells, header.at("intensity"), where, "intensity")) : 0.0f;
        if (!beams.empty() && (b.t != beams[0].t || b.scanner != beams[0].scanner)) finish_scan(beams, with_intensity, path, out);
        beams.push_back(b);
    }
    finish_scan(beams, with_intensity, path, out);
    if (header.empty()) throw std::runtime_error(path + ": empty file, expected the header t,scanner,angle_deg,range_m");
    return out;
}

// A log without `laser_front_laser_resolution`: the step CARMEN itself assumes for a SICK of n beams
// (carmen_laser_guess_angle_increment): 1° for 180 or 181, 0.5° for 360 or 361, 0.25° for 400 or 401 (a last beam
// may be left out), else 180° over the n − 1 steps. 180°/n gave a 181-beam scan 0.9945°, its last beam 1° short.
double guessed_step_deg(std::size_t n) {
    if (n == 180 || n == 181) return 1.0;
    if (n == 360 || n == 361) return 0.5;
    if (n == 400 || n == 401) return 0.25;
    return n > 1 ? 180.0 / static_cast<double>(n - 1) : 1.0;
}

std::vector<LaserScan> read_carmen_log(const std::string& path, double rate_hz, double max_range_m,
                                       bool* timestamps_missing) {
    // A 2-D scanner turns 1–100 times a second; outside 0.001–100,000 Hz the times are a unit mixed up, or overflow.
    if (!(rate_hz >= 1e-3 && rate_hz <= 1e5))
        throw std::invalid_argument(path + ": the CARMEN scan rate must be within 0.001–100000 Hz, got " +
                                    number_text(rate_hz) + " Hz");
    TextLines lines(path);
    std::vector<LaserScan> out;
    double resolution_deg = 0.0, log_max_m = 0.0;
    bool any_time = false;
    std::string line;
    while (lines.next(line)) {
        const std::string where = path + ":" + std::to_string(lines.number());
        std::istringstream in(line);
        std::string kind;
        in >> kind;
        if (kind == "PARAM") {
            std::string name, value;
            in >> name >> value;
            if (name == "laser_front_laser_resolution") resolution_deg = parse_double(value, where, "resolution");
            if (name == "robot_front_laser_max") log_max_m = parse_double(value, where, "maximum range");
            continue;
        }
        if (kind != "FLASER") continue;
        std::vector<std::string> tokens;
        for (std::string tok; in >> tok;) tokens.push_back(tok);
        const double declared = tokens.empty() ? -1 : parse_double(tokens[0], where, "num_readings");
        if (!(declared > 0 && declared <= 10000) || tokens.size() < static_cast<std::size_t>(declared) + 10)
            throw std::runtime_error(where + ": FLASER line shorter than its num_readings + pose + timestamps");
        const auto n = static_cast<std::size_t>(declared);
        const double max_m = max_range_m > 0.0 ? max_range_m : (log_max_m > 0.0 ? log_max_m : INFINITY);
        LaserScan s;
        s.source = where;
        const double step_deg = resolution_deg > 0.0 ? resolution_deg : guessed_step_deg(n);
        s.start_angle_rad = -90.0 * kDeg;
        s.step_rad = step_deg * kDeg;
        s.ranges_m.resize(n);
        for (std::size_t i = 0; i < n; ++i) {
            const double r = parse_double(tokens[1 + i], where, "range");
            s.ranges_m[i] = std::isfinite(r) && r > 0.0 && r < max_m ? static_cast<float>(r) : NAN;
        }
        s.pose = Pose2{parse_double(tokens[n + 1], where, "x"), parse_double(tokens[n + 2], where, "y"),
                       parse_double(tokens[n + 3], where, "theta")};
        s.time_s = parse_double(tokens[n + 7], where, "ipc_timestamp");
        any_time = any_time || s.time_s != 0.0;
        s.counter = static_cast<std::int64_t>(out.size());
        out.push_back(std::move(s));
    }
    if (!any_time)
        for (auto& s : out) s.time_s = static_cast<double>(s.counter) / rate_hz;
    if (timestamps_missing) *timestamps_missing = !any_time && !out.empty();
    return out;
}

}  // namespace roadpreview::roadside
