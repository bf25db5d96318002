// SPDX-License-Identifier: BSD-3-Clause
// Stereo calibration files: KITTI calib.txt (P2/P3) and a small YAML.
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "roadpreview/io/stereo.hpp"
#include "core/input_file.hpp"
#include "core/text.hpp"

namespace roadpreview {
namespace {

bool ends_with(const std::string& s, const std::string& tail) {
    return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

// "NAME: 12 numbers" lines of a KITTI calibration file, by name; other lines are kept out.
std::map<std::string, std::vector<double>> kitti_matrices(const std::string& path) {
    require_input_file<std::runtime_error>(path, "calibration file");
    std::ifstream in(path);
    if (!in) throw std::runtime_error(path + ": cannot open calibration file");
    std::map<std::string, std::vector<double>> out;
    std::string line;
    for (int number = 1; std::getline(in, line); ++number) {
        const auto colon = line.find(':');
        if (colon == std::string::npos) continue;
        const std::string name = line.substr(0, colon);
        if (name != "P2" && name != "P3" && name != "P_rect_02" && name != "P_rect_03") continue;
        std::istringstream fields(line.substr(colon + 1));
        std::vector<double> values;
        bool numbers = true;
        for (std::string token; numbers && fields >> token;) {
            const std::optional<double> v = parse_number(token);
            numbers = v.has_value();
            if (numbers) values.push_back(*v);
        }
        if (!numbers || values.size() != 12)
            throw std::runtime_error(path + ":" + std::to_string(number) + ": " + name + " needs 12 numbers (a 3x4 matrix)");
        for (double x : values)
            if (!std::isfinite(x)) throw std::runtime_error(path + ":" + std::to_string(number) + ": " + name + " is not finite");
        out[name == "P_rect_02" ? "P2" : name == "P_rect_03" ? "P3" : name] = values;
    }
    return out;
}

StereoCalibration read_kitti(const std::string& path) {
    const auto m = kitti_matrices(path);
    if (!m.count("P2") || !m.count("P3"))
        throw std::runtime_error(path + ": a KITTI stereo calibration needs the P2 and P3 lines (colour pair)");
    double left[12], right[12];
    for (int k = 0; k < 12; ++k) left[k] = m.at("P2")[static_cast<std::size_t>(k)], right[k] = m.at("P3")[static_cast<std::size_t>(k)];
    return calibration_from_projections(left, right, path);
}

double yaml_number(const YAML::Node& node, const char* key, const std::string& path) {
    if (!node[key]) throw std::runtime_error(path + ": stereo calibration needs '" + key + "'");
    double v = 0.0;
    if (!YAML::convert<double>::decode(node[key], v) || !std::isfinite(v))
        throw std::runtime_error(path + ": '" + key + "' must be a finite number");
    return v;
}

StereoCalibration read_yaml(const std::string& path) {
    require_input_file<std::runtime_error>(path, "calibration file");
    YAML::Node root;
    try {
        root = YAML::LoadFile(path);
    } catch (const YAML::BadFile&) {
        throw std::runtime_error(path + ": cannot open calibration file");
    } catch (const YAML::Exception& e) {
        throw std::runtime_error(path + ": not valid YAML (" + std::string(e.what()) + ")");
    }
    if (!root.IsMap()) throw std::runtime_error(path + ": a stereo calibration YAML must be a mapping");
    StereoCalibration c;
    c.source = path;
    c.fx_px = yaml_number(root, "fx", path);
    c.fy_px = yaml_number(root, "fy", path);
    c.cx_px = yaml_number(root, "cx", path);
    c.cy_px = yaml_number(root, "cy", path);
    c.baseline_m = yaml_number(root, "baseline", path);
    if (!(c.fx_px > 0.0 && c.fy_px > 0.0)) throw std::runtime_error(path + ": fx and fy must be > 0 px");
    if (!(c.baseline_m > 0.0))
        throw std::runtime_error(path + ": the baseline must be > 0 m, got " + number_text(c.baseline_m));
    if (const YAML::Node e = root["extrinsics"]) {
        if (!e.IsMap()) throw std::runtime_error(path + ": 'extrinsics' must be a mapping of x_m, y_m, z_m, roll_rad, pitch_rad, yaw_rad");
        c.extrinsics = Extrinsics{yaml_number(e, "x_m", path),      yaml_number(e, "y_m", path),
                                  yaml_number(e, "z_m", path),      yaml_number(e, "roll_rad", path),
                                  yaml_number(e, "pitch_rad", path), yaml_number(e, "yaw_rad", path)};
    }
    return c;
}

}  // namespace

StereoCalibration calibration_from_projections(const double (&left)[12], const double (&right)[12],
                                               const std::string& source) {
    StereoCalibration c;
    c.source = source;
    c.fx_px = left[0];
    c.fy_px = left[5];
    c.cx_px = left[2];
    c.cy_px = left[6];
    if (!(c.fx_px > 0.0 && c.fy_px > 0.0))
        throw std::invalid_argument(source + ": the left projection's focal lengths must be > 0 px");
    // P = K·[I | t]: P[0,3] = fx·t_x. The baseline is the difference of the two cameras' offsets, not the right
    // camera's alone (KITTI's colour cameras both sit beside the reference camera 0).
    c.baseline_m = (left[3] - right[3]) / c.fx_px;
    if (!(c.baseline_m > 0.0))
        throw std::invalid_argument(source + ": the baseline (P_left[0,3] - P_right[0,3]) / fx must be > 0 m, got " +
                                    number_text(c.baseline_m) + " (left and right swapped?)");
    return c;
}

StereoCalibration read_stereo_calibration(const std::string& path) {
    try {
        if (ends_with(path, ".yaml") || ends_with(path, ".yml")) return read_yaml(path);
        return read_kitti(path);
    } catch (const std::invalid_argument& e) {
        throw std::runtime_error(e.what());
    }
}

Extrinsics stereo_camera_pose(const Config& config, const StereoCalibration& calib) {
    if (config.extrinsics || config.sensor_height) return effective_extrinsics(config);
    if (calib.extrinsics) return *calib.extrinsics;
    throw std::invalid_argument(calib.source + ": the camera's pose is unknown: give the sensor height or extrinsics "
                                "(--sensor-height / --extrinsics), or an 'extrinsics' block in a calibration YAML");
}

}  // namespace roadpreview
