// SPDX-License-Identifier: BSD-3-Clause
// Roadside files out and camera detections in: JSON lines per cycle, GeoJSON, detections CSV/JSON
// (docs/output.md, "Roadside").
#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "core/csv.hpp"
#include "core/input_file.hpp"
#include "core/text.hpp"
#include "roadpreview/roadside/processor.hpp"

namespace roadpreview::roadside {
namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

double rounded(double v, double unit) { return std::round(v / unit) * unit; }

nlohmann::json object_json(const OutputObject& o) {
    nlohmann::json mbr_site = nlohmann::json::array(), mbr_wgs84 = nlohmann::json::array();
    for (int k = 0; k < 4; ++k) {
        mbr_site.push_back({rounded(o.mbr_site[k][0], 1e-3), rounded(o.mbr_site[k][1], 1e-3)});
        mbr_wgs84.push_back({rounded(o.mbr_wgs84[k].lat_deg, 1e-9), rounded(o.mbr_wgs84[k].lon_deg, 1e-9)});
    }
    return {{"id", o.id},
            {"class", o.cls},
            {"score", rounded(o.score, 1e-3)},
            {"source", o.source},
            {"x_m", rounded(o.x_m, 1e-3)},
            {"y_m", rounded(o.y_m, 1e-3)},
            {"lat_deg", rounded(o.position.lat_deg, 1e-9)},
            {"lon_deg", rounded(o.position.lon_deg, 1e-9)},
            {"length_m", rounded(o.length_m, 1e-3)},
            {"width_m", rounded(o.width_m, 1e-3)},
            {"mbr_site_m", mbr_site},
            {"mbr_wgs84_deg", mbr_wgs84},
            {"vx_mps", rounded(o.vx_mps, 1e-3)},
            {"vy_mps", rounded(o.vy_mps, 1e-3)},
            {"speed_mps", rounded(o.speed_mps, 1e-3)},
            {"heading_deg", rounded(o.heading_rad * kRadToDeg, 1e-2)},
            {"points", o.points},
            {"age_s", rounded(o.age_s, 1e-3)},
            {"since_measured_s", rounded(o.since_measured_s, 1e-3)}};
}

}  // namespace

std::string cycle_to_json(const Cycle& c) {
    nlohmann::json objects = nlohmann::json::array(), scanners = nlohmann::json::array();
    for (const auto& o : c.objects) objects.push_back(object_json(o));
    for (const auto& s : c.scanners)
        scanners.push_back({{"name", s.name}, {"scans", s.scans}, {"active", s.active},
                            {"last_scan_s", s.last_scan_s < 0 ? nlohmann::json() : nlohmann::json(rounded(s.last_scan_s, 1e-6))},
                            {"invalid_ranges", s.invalid_ranges}});
    return nlohmann::json{{"t_s", rounded(c.t_s, 1e-6)},
                          {"scan_objects", c.scan_objects},
                          {"objects", objects},
                          {"scanners", scanners},
                          {"process_ms", rounded(c.process_ms, 1e-3)}}
        .dump();
}

std::string cycles_to_geojson(const std::vector<Cycle>& cycles) {
    nlohmann::json features = nlohmann::json::array();
    for (const auto& c : cycles)
        for (const auto& o : c.objects) {
            nlohmann::json props = object_json(o);
            props["t_s"] = rounded(c.t_s, 1e-6);
            props.erase("mbr_site_m");
            props.erase("mbr_wgs84_deg");
            features.push_back({{"type", "Feature"},
                                {"geometry", {{"type", "Point"}, {"coordinates", {o.position.lon_deg, o.position.lat_deg}}}},
                                {"properties", props}});
            nlohmann::json ring = nlohmann::json::array();  // GeoJSON: lon, lat; the ring closes on its first corner
            for (int k = 0; k <= 4; ++k) ring.push_back({o.mbr_wgs84[k % 4].lon_deg, o.mbr_wgs84[k % 4].lat_deg});
            props["geometry_of"] = "mbr";
            features.push_back({{"type", "Feature"},
                                {"geometry", {{"type", "Polygon"}, {"coordinates", {ring}}}},
                                {"properties", props}});
        }
    return nlohmann::json{{"type", "FeatureCollection"}, {"features", features}}.dump();
}

// A score votes for its class: 0 voted nothing (a matched box left its track unclassed), 1e308 summed to an
// infinite vote and a null score in the output.
void check_detection(const CameraDetection& d, const std::string& where) {
    const std::pair<const char*, double> fields[] = {{"t", d.t_s}, {"x", d.x_px}, {"y", d.y_px}, {"w", d.w_px},
                                                     {"h", d.h_px}, {"score", d.score}};
    for (const auto& [name, v] : fields)
        if (!std::isfinite(v)) throw std::runtime_error(where + ": detection " + name + " is not a finite number");
    if (d.w_px <= 0 || d.h_px <= 0) throw std::runtime_error(where + ": detection box w and h must be > 0");
    if (d.cls.empty()) throw std::runtime_error(where + ": empty class");
    if (!(d.score > 0.0 && d.score <= 1.0))
        throw std::runtime_error(where + ": detection score must be in (0, 1], got " + number_text(d.score));
}

namespace {

CameraDetection detection_from_json(const nlohmann::json& j, const std::string& where) {
    try {
        CameraDetection d{j.at("t").get<double>(), j.at("x").get<double>(), j.at("y").get<double>(),
                          j.at("w").get<double>(), j.at("h").get<double>(), j.at("class").get<std::string>(),
                          j.value("score", 1.0)};
        check_detection(d, where);
        return d;
    } catch (const nlohmann::json::exception& e) {
        throw std::runtime_error(where + ": detection needs t, x, y, w, h, class[, score] (" + e.what() + ")");
    }
}

}  // namespace

std::vector<CameraDetection> read_detections(const std::string& path) {
    require_input_file<std::runtime_error>(path, "detections");
    std::ifstream in(path);
    if (!in) throw std::runtime_error(path + ": cannot open the detections");
    std::vector<CameraDetection> out;
    std::string line;
    const bool json = path.size() > 5 && (path.substr(path.size() - 5) == ".json" || path.substr(path.size() - 6) == ".jsonl");
    if (json && path.substr(path.size() - 5) == ".json") {
        nlohmann::json doc;
        try {
            doc = nlohmann::json::parse(in);
        } catch (const nlohmann::json::exception& e) {
            throw std::runtime_error(path + ": not JSON (" + e.what() + ")");
        }
        if (!doc.is_array()) throw std::runtime_error(path + ": expected a JSON array of detections");
        for (std::size_t i = 0; i < doc.size(); ++i) out.push_back(detection_from_json(doc[i], path + "#" + std::to_string(i)));
        return out;
    }
    csv::Header header;
    for (std::int64_t number = 1; std::getline(in, line); ++number) {
        if (csv::skipped(line)) continue;
        const std::string where = path + ":" + std::to_string(number);
        if (json) {
            try {
                out.push_back(detection_from_json(nlohmann::json::parse(line), where));
            } catch (const nlohmann::json::exception& e) {  // parse_error; out_of_range for 1e400
                throw std::runtime_error(where + ": not JSON (" + e.what() + ")");
            }
            continue;
        }
        const auto cells = csv::split(line);
        if (header.empty()) {
            header = csv::Header(cells, {"t", "x", "y", "w", "h", "class", "score"}, where);
            continue;
        }
        CameraDetection d;
        d.t_s = csv::finite_cell(cells, header.at("t"), where, "t");
        d.x_px = csv::finite_cell(cells, header.at("x"), where, "x");
        d.y_px = csv::finite_cell(cells, header.at("y"), where, "y");
        d.w_px = csv::finite_cell(cells, header.at("w"), where, "w");
        d.h_px = csv::finite_cell(cells, header.at("h"), where, "h");
        d.score = csv::finite_cell(cells, header.at("score"), where, "score");
        d.cls = header.at("class") < cells.size() ? cells[header.at("class")] : "";
        check_detection(d, where);
        out.push_back(d);
    }
    return out;
}

void write_detections_csv(const std::vector<CameraDetection>& detections, const std::string& path) {
    std::ofstream out(path);
    if (!out) throw std::runtime_error(path + ": cannot write the detections");
    out.precision(std::numeric_limits<double>::max_digits10);
    out << "t,x,y,w,h,class,score\n";
    for (const auto& d : detections)
        out << d.t_s << ',' << d.x_px << ',' << d.y_px << ',' << d.w_px << ',' << d.h_px << ',' << d.cls << ','
            << d.score << '\n';
    out.flush();  // a full disk shows here, not in the destructor
    if (!out) throw std::runtime_error(path + ": cannot write the detections");
}

}  // namespace roadpreview::roadside
