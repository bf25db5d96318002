// SPDX-License-Identifier: BSD-3-Clause
// Sensor layout and calibration files (YAML), docs/method.md §11.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <initializer_list>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string_view>

#include <yaml-cpp/yaml.h>

#include "roadpreview/range_sensor/range_sensor.hpp"

#include "core/input_file.hpp"
#include "core/text.hpp"

namespace roadpreview {
namespace {

constexpr double kMaxSensorOffsetM = 20.0;  // a point sensor's place on the vehicle, m
constexpr double kMaxLatencyS = 1.0;        // a sensor's processing latency (b1), s: milliseconds in practice

double finite_field(const YAML::Node& node, const char* key, const std::string& where, std::optional<double> fallback) {
    if (!node[key]) {
        if (fallback) return *fallback;
        throw std::runtime_error(where + ": missing field '" + key + "'");
    }
    const double v = node[key].as<double>();
    if (std::isnan(v) || (std::isinf(v) && !fallback)) throw std::runtime_error(where + ": field '" + key
        + "' is not finite");
    return v;
}

// A misspelt field (pitch_degree, temprature_c) would leave its default standing, silently.
void refuse_unknown_fields(const YAML::Node& node, std::initializer_list<std::string_view> keys,
                           const std::string& where) {
    if (!node.IsMap()) throw std::runtime_error(where + ": expected a mapping of fields");
    for (const auto& field : node) {
        const auto key = field.first.as<std::string>();
        if (std::find(keys.begin(), keys.end(), key) == keys.end())
            throw std::runtime_error(where + ": unknown field '" + key + "'");
    }
}

RangeSensor sensor_from(const YAML::Node& node, const std::string& where) {
    RangeSensor s;
    if (!node["id"]) throw std::runtime_error(where + ": missing field 'id'");
    s.id = node["id"].as<std::string>();
    const std::string at = where + " (sensor '" + s.id + "')";
    refuse_unknown_fields(node, {"id", "kind", "wheel", "x_m", "y_m", "height_m", "pitch_deg", "beam_half_angle_deg",
                                 "min_count", "max_count", "max_distance_m"}, at);
    const std::string kind = node["kind"] ? node["kind"].as<std::string>() : "";
    if (kind != "ultrasonic" && kind != "laser") throw std::runtime_error(at
        + ": kind must be ultrasonic or laser, got '" + kind + "'");
    s.kind = kind == "ultrasonic" ? RangeKind::Ultrasonic : RangeKind::Laser;
    const std::string wheel = node["wheel"] ? node["wheel"].as<std::string>() : "";
    if (wheel != "left" && wheel != "right") throw std::runtime_error(at + ": wheel must be left or right, got '"
        + wheel + "'");
    s.wheel = wheel == "left" ? Wheel::Left : Wheel::Right;
    s.x_m = finite_field(node, "x_m", at, std::nullopt);
    s.y_m = finite_field(node, "y_m", at, std::nullopt);
    s.height_m = finite_field(node, "height_m", at, std::nullopt);
    s.pitch_deg = finite_field(node, "pitch_deg", at, 0.0);
    s.beam_half_angle_deg = finite_field(node, "beam_half_angle_deg", at,
        s.kind == RangeKind::Laser ? std::optional(0.0) : std::nullopt);
    s.min_count = finite_field(node, "min_count", at, 0.0);
    s.max_count = finite_field(node, "max_count", at, s.max_count);
    s.max_distance_m = finite_field(node, "max_distance_m", at, s.max_distance_m);
    // Ahead of a wheel on a vehicle: metres, not kilometres (a sensor 1e6 m ahead wrote a window per reading).
    if (!(std::abs(s.x_m) <= kMaxSensorOffsetM && std::abs(s.y_m) <= kMaxSensorOffsetM))
        throw std::runtime_error(at + ": x_m and y_m must lie within ±" + number_text(kMaxSensorOffsetM) + " m");
    if (!(s.height_m > 0 && s.height_m <= kMaxSensorOffsetM))
        throw std::runtime_error(at + ": height_m must be > 0 and at most " + number_text(kMaxSensorOffsetM) + " m");
    if (!(s.max_distance_m > 0)) throw std::runtime_error(at + ": max_distance_m must be > 0");
    if (!(std::abs(s.pitch_deg) < 60)) throw std::runtime_error(at + ": pitch_deg must lie within ±60°");
    if (!(s.beam_half_angle_deg >= 0 && s.beam_half_angle_deg < 45))
        throw std::runtime_error(at + ": beam_half_angle_deg must lie in [0, 45)");
    if (!(s.min_count <= s.max_count)) throw std::runtime_error(at + ": min_count must not exceed max_count");
    return s;
}

YAML::Node distance_node(const DistanceCalibration& d) {
    YAML::Node n;
    n["a1"] = d.a1;
    n["a2"] = d.a2;
    n["temperature_c"] = d.temperature_c;
    n["rms_m"] = d.rms_m;
    n["r_squared"] = d.r_squared;
    n["used"] = d.used;
    n["rejected"] = d.rejected;
    n["a1_sigma"] = d.a1_sigma;
    n["a2_sigma"] = d.a2_sigma;
    return n;
}

DistanceCalibration distance_from(const YAML::Node& n, const std::string& where) {
    refuse_unknown_fields(n, {"a1", "a2", "temperature_c", "rms_m", "r_squared", "used", "rejected", "a1_sigma",
                              "a2_sigma"}, where);
    DistanceCalibration d;
    d.a1 = finite_field(n, "a1", where, std::nullopt);
    d.a2 = finite_field(n, "a2", where, std::nullopt);
    d.temperature_c = finite_field(n, "temperature_c", where, 20.0);
    d.rms_m = finite_field(n, "rms_m", where, 0.0);
    d.r_squared = finite_field(n, "r_squared", where, 0.0);
    d.used = static_cast<std::int64_t>(finite_field(n, "used", where, 0.0));
    d.rejected = static_cast<std::int64_t>(finite_field(n, "rejected", where, 0.0));
    d.a1_sigma = finite_field(n, "a1_sigma", where, 0.0);
    d.a2_sigma = finite_field(n, "a2_sigma", where, 0.0);
    if (const std::string why = implausible(d); !why.empty()) throw std::runtime_error(where + ": " + why);
    return d;
}

YAML::Node offset_node(const OffsetCalibration& o) {
    YAML::Node n;
    n["b1_s"] = o.b1_s;
    n["b2_m"] = o.b2_m;
    n["b1_sigma_s"] = o.b1_sigma_s;
    n["b2_sigma_m"] = o.b2_sigma_m;
    n["b1_xcorr_s"] = o.b1_xcorr_s;
    n["b2_xcorr_m"] = o.b2_xcorr_m;
    for (const RunShift& r : o.runs) {
        YAML::Node run;
        run["source"] = r.source;
        run["speed_mps"] = r.speed_mps;
        run["shift_m"] = r.shift_m;
        run["shift_sigma_m"] = r.shift_sigma_m;
        run["z_offset_m"] = r.z_offset_m;
        run["rms_m"] = r.rms_m;
        run["xcorr_shift_m"] = r.xcorr_shift_m;
        run["samples"] = r.samples;
        n["runs"].push_back(run);
    }
    return n;
}

OffsetCalibration offset_from(const YAML::Node& n, const std::string& where) {
    refuse_unknown_fields(n, {"b1_s", "b2_m", "b1_sigma_s", "b2_sigma_m", "b1_xcorr_s", "b2_xcorr_m", "runs"}, where);
    OffsetCalibration o;
    o.b1_s = finite_field(n, "b1_s", where, std::nullopt);
    o.b2_m = finite_field(n, "b2_m", where, std::nullopt);
    // A latency of seconds is milliseconds written as seconds (every sample then lands behind the axle and is lost)
    if (!(std::abs(o.b1_s) <= kMaxLatencyS))
        throw std::runtime_error(where + ": b1_s, the sensor's latency, must lie within ±" + number_text(kMaxLatencyS) +
                                 " s, got " + number_text(o.b1_s) + " (milliseconds given as seconds?)");
    if (!(std::abs(o.b2_m) <= kMaxSensorOffsetM))
        throw std::runtime_error(where + ": b2_m must lie within ±" + number_text(kMaxSensorOffsetM) + " m, got " +
                                 number_text(o.b2_m));
    o.b1_sigma_s = finite_field(n, "b1_sigma_s", where, 0.0);
    o.b2_sigma_m = finite_field(n, "b2_sigma_m", where, 0.0);
    o.b1_xcorr_s = finite_field(n, "b1_xcorr_s", where, 0.0);
    o.b2_xcorr_m = finite_field(n, "b2_xcorr_m", where, 0.0);
    for (const YAML::Node& run : n["runs"]) {
        refuse_unknown_fields(run, {"source", "speed_mps", "shift_m", "shift_sigma_m", "z_offset_m", "rms_m",
                                    "xcorr_shift_m", "samples"}, where + ".runs");
        RunShift r;
        r.source = run["source"] ? run["source"].as<std::string>() : "";
        r.speed_mps = finite_field(run, "speed_mps", where, std::nullopt);
        r.shift_m = finite_field(run, "shift_m", where, std::nullopt);
        r.shift_sigma_m = finite_field(run, "shift_sigma_m", where, 0.0);
        r.z_offset_m = finite_field(run, "z_offset_m", where, 0.0);
        r.rms_m = finite_field(run, "rms_m", where, 0.0);
        r.xcorr_shift_m = finite_field(run, "xcorr_shift_m", where, 0.0);
        r.samples = static_cast<std::int64_t>(finite_field(run, "samples", where, 0.0));
        o.runs.push_back(r);
    }
    return o;
}

}  // namespace

double speed_of_sound_mps(double temperature_c) { return 331.3 * std::sqrt(1.0 + temperature_c / 273.15); }

std::vector<RangeSensor> read_range_layout(const std::string& path) {
    require_input_file<std::runtime_error>(path, "sensor layout");
    std::vector<RangeSensor> layout;
    try {
        const YAML::Node root = YAML::LoadFile(path);
        const YAML::Node sensors = root["sensors"];
        if (!sensors || !sensors.IsSequence() || sensors.size() == 0)
            throw std::runtime_error(path + ": expected a non-empty list 'sensors'");
        std::set<std::string> ids;
        for (std::size_t i = 0; i < sensors.size(); ++i) {
            layout.push_back(sensor_from(sensors[i], path + ": sensors[" + std::to_string(i) + "]"));
            if (!ids.insert(layout.back().id).second) throw std::runtime_error(path + ": sensor id '"
                + layout.back().id + "' appears twice");
        }
    } catch (const YAML::Exception& e) {
        throw std::runtime_error(path + ": not a valid sensor layout (" + e.what() + ")");
    }
    return layout;
}

double distance_of_count(const DistanceCalibration& cal, double count, double temperature_c) {
    if (std::isnan(temperature_c)) return cal.a1 * count + cal.a2;
    return cal.a1 * count * speed_of_sound_mps(temperature_c) / speed_of_sound_mps(cal.temperature_c) + cal.a2;
}

const DistanceCalibration* RangeCalibration::distance_for(const std::string& id) const {
    const auto it = sensors.find(id);
    if (it != sensors.end() && it->second.distance) return &*it->second.distance;
    return distance ? &*distance : nullptr;
}

const OffsetCalibration* RangeCalibration::offset_for(const std::string& id) const {
    const auto it = sensors.find(id);
    return it != sensors.end() && it->second.offset ? &*it->second.offset : nullptr;
}

RangeCalibration read_range_calibration(const std::string& path) {
    require_input_file<std::runtime_error>(path, "calibration");
    RangeCalibration cal;
    try {
        const YAML::Node root = YAML::LoadFile(path);
        if (!root.IsMap()) throw std::runtime_error(path + ": expected a mapping with 'distance' and/or 'sensors'");
        refuse_unknown_fields(root, {"distance", "sensors"}, path);
        if (root["distance"]) cal.distance = distance_from(root["distance"], path + ": distance");
        for (const auto& item : root["sensors"]) {
            const std::string id = item.first.as<std::string>();
            const std::string where = path + ": sensors." + id;
            refuse_unknown_fields(item.second, {"distance", "offset"}, where);
            SensorCalibration s;
            if (item.second["distance"]) s.distance = distance_from(item.second["distance"], where + ".distance");
            if (item.second["offset"]) s.offset = offset_from(item.second["offset"], where + ".offset");
            cal.sensors[id] = s;
        }
    } catch (const YAML::Exception& e) {
        throw std::runtime_error(path + ": not a valid calibration file (" + e.what() + ")");
    }
    return cal;
}

std::string range_calibration_to_yaml(const RangeCalibration& cal) {
    YAML::Node root;
    if (cal.distance) root["distance"] = distance_node(*cal.distance);
    for (const auto& [id, s] : cal.sensors) {
        YAML::Node n;
        if (s.distance) n["distance"] = distance_node(*s.distance);
        if (s.offset) n["offset"] = offset_node(*s.offset);
        root["sensors"][id] = n;
    }
    YAML::Emitter out;
    out.SetDoublePrecision(12);
    out << root;
    return std::string(out.c_str()) + "\n";
}

void write_range_calibration(const RangeCalibration& cal, const std::string& path) {
    std::ofstream out(path);
    if (!out) throw std::runtime_error(path + ": cannot write the calibration file");
    out << "# roadpreview range sensor calibration: d = a1*c + a2 (m), sample x = b1*v + b2 (m ahead of the axle)\n"
        << range_calibration_to_yaml(cal);
    out.flush();  // a full disk shows here, not in the destructor
    if (!out) throw std::runtime_error(path + ": write failed");
}

}  // namespace roadpreview
