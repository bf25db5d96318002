// SPDX-License-Identifier: BSD-3-Clause
// The site file: yaml-cpp reads it, every key is checked (an unknown key is a typo, not ignored), OpenCV fits
// the camera's ground homography.
#include "roadpreview/roadside/site.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <set>
#include <sstream>
#include <stdexcept>

#include "core/input_file.hpp"

namespace roadpreview::roadside {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

[[noreturn]] void fail(const std::string& where, const std::string& what) { throw std::runtime_error(where + ": " + what); }

void check_keys(const YAML::Node& node, const std::set<std::string>& allowed, const std::string& where) {
    if (!node.IsMap()) fail(where, "expected a mapping");
    for (const auto& kv : node) {
        const auto key = kv.first.as<std::string>();
        if (!allowed.count(key)) fail(where, "unknown key '" + key + "'");
    }
}

double number(const YAML::Node& node, const std::string& key, double fallback, const std::string& where) {
    if (!node[key]) return fallback;
    double v = 0.0;
    try {
        v = node[key].as<double>();
    } catch (const YAML::Exception&) {
        fail(where, key + " must be a number");
    }
    if (!std::isfinite(v)) fail(where, key + " must be finite");
    return v;
}

double required(const YAML::Node& node, const std::string& key, const std::string& where) {
    if (!node[key]) fail(where, "missing " + key);
    return number(node, key, 0.0, where);
}

std::optional<double> optional_number(const YAML::Node& node, const std::string& key, const std::string& where) {
    if (!node[key]) return std::nullopt;
    return number(node, key, 0.0, where);
}

void positive(double v, const std::string& key, const std::string& where) {
    if (!(v > 0.0)) fail(where, key + " must be > 0");
}

SiteOrigin read_origin(const YAML::Node& node, const std::string& where) {
    check_keys(node, {"lat_deg", "lon_deg", "height_m", "heading_deg"}, where);
    SiteOrigin o;
    o.lat_deg = required(node, "lat_deg", where);
    o.lon_deg = required(node, "lon_deg", where);
    o.height_m = number(node, "height_m", 0.0, where);
    o.heading_deg = number(node, "heading_deg", 90.0, where);
    if (std::abs(o.lat_deg) > 90.0 || std::abs(o.lon_deg) > 180.0) fail(where, "lat_deg/lon_deg out of range");
    return o;
}

ScannerSite read_scanner(const YAML::Node& node, const std::string& where) {
    check_keys(node, {"name", "x_m", "y_m", "yaw_deg", "time_offset_s", "max_range_m", "start_angle_deg", "step_deg",
                      "beams"}, where);
    ScannerSite s;
    s.name = node["name"] ? node["name"].as<std::string>() : "";
    s.pose = {number(node, "x_m", 0.0, where), number(node, "y_m", 0.0, where), number(node, "yaw_deg", 0.0, where) * kDeg};
    s.time_offset_s = number(node, "time_offset_s", 0.0, where);
    s.max_range_m = number(node, "max_range_m", 80.0, where);
    positive(s.max_range_m, "max_range_m", where);
    s.start_angle_deg = optional_number(node, "start_angle_deg", where);
    s.step_deg = optional_number(node, "step_deg", where);
    if (s.step_deg) positive(*s.step_deg, "step_deg", where);
    if (const auto beams = optional_number(node, "beams", where)) {
        if (*beams < 1 || *beams > 100000 || *beams != std::floor(*beams)) fail(where, "beams must be a whole number ≥ 1");
        s.beams = static_cast<int>(*beams);
    }
    return s;
}

CameraSite read_camera(const YAML::Node& node, const std::string& where) {
    check_keys(node, {"width_px", "height_px", "intrinsics", "points", "time_offset_s"}, where);
    CameraSite c;
    c.width_px = static_cast<int>(number(node, "width_px", 0.0, where));
    c.height_px = static_cast<int>(number(node, "height_px", 0.0, where));
    c.time_offset_s = number(node, "time_offset_s", 0.0, where);
    if (node["intrinsics"]) {
        const auto v = node["intrinsics"].as<std::vector<double>>();
        if (v.size() != 4) fail(where, "intrinsics must be [fx, fy, cx, cy]");
        c.intrinsics = std::array<double, 4>{v[0], v[1], v[2], v[3]};
    }
    if (!node["points"] || !node["points"].IsSequence()) fail(where, "missing points: [[u_px, v_px, x_m, y_m], ...]");
    for (const auto& p : node["points"]) {
        const auto v = p.as<std::vector<double>>();
        if (v.size() != 4) fail(where, "each of points must be [u_px, v_px, x_m, y_m]");
        for (double x : v)
            if (!std::isfinite(x)) fail(where, "points must be finite");
        c.image_points.push_back({v[0], v[1]});
        c.site_points.push_back({v[2], v[3]});
    }
    try {
        c.homography = fit_homography(c.image_points, c.site_points);
    } catch (const std::invalid_argument& e) {
        fail(where, e.what());
    }
    return c;
}

WorldBackgroundSettings read_world_settings(const YAML::Node& node, const std::string& where) {
    WorldBackgroundSettings w;
    if (!node) return w;
    check_keys(node, {"cell_m", "free_margin_m", "max_range_m", "min_free_scans", "hit_radius_cells", "max_hit_ratio",
                      "max_hit_s"}, where);
    w.cell_m = number(node, "cell_m", w.cell_m, where);
    w.free_margin_m = number(node, "free_margin_m", w.free_margin_m, where);
    w.max_range_m = number(node, "max_range_m", w.max_range_m, where);
    w.max_hit_ratio = number(node, "max_hit_ratio", w.max_hit_ratio, where);
    w.max_hit_s = number(node, "max_hit_s", w.max_hit_s, where);
    const double min_free = number(node, "min_free_scans", w.min_free_scans, where);
    const double radius = number(node, "hit_radius_cells", w.hit_radius_cells, where);
    if (!(w.cell_m >= 0.01)) fail(where, "cell_m must be ≥ 0.01 m");
    if (!(w.free_margin_m >= 0.0) || !(w.max_range_m > w.free_margin_m) || w.max_range_m > 1000.0)
        fail(where, "need 0 ≤ free_margin_m < max_range_m ≤ 1000 m");
    if (!(w.max_hit_ratio > 0.0) || !(w.max_hit_s > 0.0)) fail(where, "max_hit_ratio and max_hit_s must be > 0");
    if (min_free < 1 || min_free > 1e6) fail(where, "min_free_scans must be 1 … 10⁶");
    if (radius < 0 || radius > 50) fail(where, "hit_radius_cells must be 0..50");
    w.min_free_scans = static_cast<int>(min_free);
    w.hit_radius_cells = static_cast<int>(radius);
    return w;
}

RoadsideSettings read_settings(const YAML::Node& node, const std::string& where) {
    RoadsideSettings s;
    if (!node) return s;
    check_keys(node, {"cell_m", "dilation_cells", "min_points", "background_s", "background_margin_m", "cycle_s",
                      "accel_sigma_mps2", "position_sigma_m", "gate_chi2", "confirm_hits", "max_coast_s",
                      "camera_gate_m", "camera_weight_position", "camera_weight_heading", "scanner_timeout_s",
                      "max_speed_mps", "world"}, where);
    auto set = [&](const char* key, double& field) {
        field = number(node, key, field, where);
        positive(field, key, where);
    };
    set("cell_m", s.cell_m);
    set("background_s", s.background_s);
    set("background_margin_m", s.background_margin_m);
    set("cycle_s", s.cycle_s);
    set("accel_sigma_mps2", s.accel_sigma_mps2);
    set("position_sigma_m", s.position_sigma_m);
    set("gate_chi2", s.gate_chi2);
    set("max_coast_s", s.max_coast_s);
    set("camera_gate_m", s.camera_gate_m);
    set("scanner_timeout_s", s.scanner_timeout_s);
    s.max_speed_mps = number(node, "max_speed_mps", s.max_speed_mps, where);
    if (s.max_speed_mps < 0.0) fail(where, "max_speed_mps must be ≥ 0 (0: no limit)");
    s.camera_weight_position = number(node, "camera_weight_position", s.camera_weight_position, where);
    s.camera_weight_heading = number(node, "camera_weight_heading", s.camera_weight_heading, where);
    const double dilation = number(node, "dilation_cells", s.dilation_cells, where);
    const double min_points = number(node, "min_points", s.min_points, where);
    const double confirm = number(node, "confirm_hits", s.confirm_hits, where);
    if (dilation < 0 || dilation > 50) fail(where, "dilation_cells must be 0..50");
    if (min_points < 1 || confirm < 1) fail(where, "min_points and confirm_hits must be ≥ 1");
    s.dilation_cells = static_cast<int>(dilation);
    s.min_points = static_cast<int>(min_points);
    s.confirm_hits = static_cast<int>(confirm);
    if (s.cell_m < 0.01) fail(where, "cell_m must be ≥ 0.01 m");
    s.world = read_world_settings(node["world"], where + ": processing.world");
    return s;
}

}  // namespace

std::array<double, 9> fit_homography(const std::vector<std::array<double, 2>>& image_points,
                                     const std::vector<std::array<double, 2>>& site_points) {
    if (image_points.size() < 4 || image_points.size() != site_points.size())
        throw std::invalid_argument("a ground homography needs at least 4 surveyed points (got " +
                                    std::to_string(image_points.size()) + ")");
    std::vector<cv::Point2d> src, dst;
    for (std::size_t i = 0; i < image_points.size(); ++i) {
        src.emplace_back(image_points[i][0], image_points[i][1]);
        dst.emplace_back(site_points[i][0], site_points[i][1]);
    }
    // Collinear points leave the homography undetermined: the spread across the best-fit line must be real.
    for (const auto* pts : {&src, &dst}) {
        cv::Mat data(static_cast<int>(pts->size()), 2, CV_64F, const_cast<cv::Point2d*>(pts->data()));
        cv::PCA pca(data, cv::Mat(), cv::PCA::DATA_AS_ROW);
        const double major = pca.eigenvalues.at<double>(0), minor = pca.eigenvalues.at<double>(1);
        if (!(minor > 1e-6 * major))
            throw std::invalid_argument("the surveyed points are collinear: no ground homography");
    }
    const cv::Mat h = cv::findHomography(src, dst, 0);
    if (h.empty() || std::abs(cv::determinant(h)) < 1e-12)
        throw std::invalid_argument("cv::findHomography found no homography for the surveyed points");
    std::array<double, 9> out{};
    for (int i = 0; i < 9; ++i) out[i] = h.at<double>(i / 3, i % 3);
    return out;
}

bool image_to_site(const std::array<double, 9>& h, double u, double v, double& x_m, double& y_m) {
    const double w = h[6] * u + h[7] * v + h[8];
    if (!(std::abs(w) > 1e-12)) return false;
    x_m = (h[0] * u + h[1] * v + h[2]) / w;
    y_m = (h[3] * u + h[4] * v + h[5]) / w;
    return std::isfinite(x_m) && std::isfinite(y_m);
}

Site parse_site(const std::string& yaml_text, const std::string& where) {
    YAML::Node root;
    try {
        root = YAML::Load(yaml_text);
    } catch (const YAML::Exception& e) {
        fail(where, std::string("not YAML (") + e.what() + ")");
    }
    check_keys(root, {"origin", "scanners", "camera", "processing"}, where);
    Site site;
    site.path = where;
    try {
        if (!root["origin"]) fail(where, "missing origin (lat_deg, lon_deg, height_m, heading_deg)");
        site.origin = read_origin(root["origin"], where + ": origin");
        if (!root["scanners"] || !root["scanners"].IsSequence() || root["scanners"].size() == 0)
            fail(where, "missing scanners: a list of {name, x_m, y_m, yaw_deg, time_offset_s}");
        for (std::size_t i = 0; i < root["scanners"].size(); ++i) {
            site.scanners.push_back(read_scanner(root["scanners"][i], where + ": scanners[" + std::to_string(i) + "]"));
            if (site.scanners.back().name.empty()) site.scanners.back().name = "scanner" + std::to_string(i);
        }
        if (site.scanners.size() > 32) fail(where, "at most 32 scanners");
        if (root["camera"]) site.camera = read_camera(root["camera"], where + ": camera");
        site.settings = read_settings(root["processing"], where + ": processing");
    } catch (const YAML::Exception& e) {
        fail(where, std::string("bad value (") + e.what() + ")");
    }
    return site;
}

Site read_site(const std::string& path) {
    if (const std::string why = not_an_input_file(path); !why.empty()) fail(path, "cannot read the site file: " + why);
    std::ifstream in(path);
    if (!in) fail(path, "cannot open the site file");
    std::stringstream text;
    text << in.rdbuf();
    return parse_site(text.str(), path);
}

}  // namespace roadpreview::roadside
