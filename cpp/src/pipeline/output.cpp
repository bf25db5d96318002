// SPDX-License-Identifier: BSD-3-Clause
// The JSON output line (schema in docs/output.md). NaN and ±Inf become null.
#include <cmath>

#include <nlohmann/json.hpp>

#include "roadpreview/ground/mounting.hpp"
#include "pipeline/output_json.hpp"
#include "roadpreview/pipeline/pipeline.hpp"

namespace roadpreview {
namespace {

using json = nlohmann::ordered_json;  // keeps the documented field order

json number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json numbers(const std::vector<double>& v) {
    json out = json::array();
    for (double x : v) out.push_back(number(x));
    return out;
}

// Obstacle geometry to 1 mm and yaw to 1 mrad keeps the lists short; both are far below the sensors' noise.
double rounded(double v) { return std::round(v * 1e3) / 1e3; }

json rounded3(const Vec3& v) { return {rounded(v[0]), rounded(v[1]), rounded(v[2])}; }

json flags(const std::vector<std::uint8_t>& v) {
    json out = json::array();
    for (auto f : v) out.push_back(f != 0);
    return out;
}

json path_obstacles_json(const std::optional<std::vector<PathObstacle>>& obstacles) {
    if (!obstacles) return nullptr;
    json out = json::array();
    for (const PathObstacle& o : *obstacles)
        out.push_back({{"id", o.id}, {"s_start", rounded(o.s_start)}, {"s_end", rounded(o.s_end)},
                       {"height", rounded(o.height)}});
    return out;
}

json clusters_json(const std::optional<std::vector<Cluster>>& clusters) {
    if (!clusters) return nullptr;
    json out = json::array();
    for (const Cluster& c : *clusters)
        out.push_back({{"id", c.id},
                       {"count", c.count},
                       {"centroid", rounded3(c.centroid)},
                       {"aabb_min", rounded3(c.aabb_min)},
                       {"aabb_max", rounded3(c.aabb_max)},
                       {"obb", {{"center", rounded3(c.obb.center)}, {"size", rounded3(c.obb.size)},
                                {"yaw", rounded(c.obb.yaw)}}},
                       {"height", rounded(c.height)},
                       {"bottom", rounded(c.bottom)}});
    return out;
}

json profile_json(const Profile& p) {
    return {{"s0", p.s0},          {"ds", p.ds},
            {"s", numbers(p.s)},   {"z", numbers(p.z)},
            {"count", p.count},    {"spread", numbers(p.spread)},
            {"blocked", flags(p.blocked)}, {"obstacles", path_obstacles_json(p.obstacles)}};
}

json optional_number(const std::optional<double>& v) { return v ? number(*v) : json(nullptr); }

// A reason's text, null for none ("").
json text_or_null(const char* text) { return *text ? json(text) : json(nullptr); }

json iri_json(const Iri& i) {
    return {{"value", optional_number(i.value)}, {"length", i.length_m},
            {"reason", text_or_null(to_string(i.reason))},
            {"backed_fraction", optional_number(i.backed_fraction)}};
}

json roughness_json(const Roughness& r) {
    json octaves = json::array();
    for (std::size_t i = 0; i < r.octave_centers.size(); ++i)
        octaves.push_back({{"center", r.octave_centers[i]}, {"gd", number(r.octave_gd[i])}});
    const bool fitted = r.iso_class.has_value();
    return {{"class", fitted ? json(std::string(1, *r.iso_class)) : json(nullptr)},
            {"gd_n0", fitted ? number(r.gd_n0) : json(nullptr)},
            {"gd_n0_free", fitted ? number(r.gd_n0_free) : json(nullptr)},
            {"waviness", fitted ? number(r.waviness) : json(nullptr)},
            {"band", fitted ? json::array({r.band_lo, r.band_hi}) : json(nullptr)},
            {"n", numbers(r.spectrum.n)},
            {"psd", numbers(r.spectrum.psd)},
            {"octave_bands", octaves},
            {"reason", text_or_null(to_string(r.reason))},
            {"confidence", fitted ? number(r.confidence) : json(nullptr)},
            {"band_limit", text_or_null(to_string(r.band_limit))},
            {"backed_fraction", optional_number(r.backed_fraction)},
            {"noise_floor", optional_number(r.noise_floor)},
            {"noise_psd", numbers(r.noise_psd)},
            {"iri", iri_json(r.iri)}};
}

json path_json(const WheelPaths& p, const std::string& yaw_rate_source) {
    const bool arc = p.status == PathStatus::Arc;
    if (!arc && yaw_rate_source.empty()) return nullptr;
    json out = {{"icr_y", arc ? json(p.icr_y) : json(nullptr)},
                {"left_radius", arc ? json(p.left_radius) : json(nullptr)},
                {"right_radius", arc ? json(p.right_radius) : json(nullptr)}};
    if (!yaw_rate_source.empty()) out["yaw_rate_source"] = yaw_rate_source;
    return out;
}

// The extrinsics in force, where they came from, and how the fitted ground sits in the base frame.
json mounting_json(const Result& r) {
    const Extrinsics& e = r.extrinsics;
    json out = {{"extrinsics", {e.x_m, e.y_m, e.z_m, e.roll_rad, e.pitch_rad, e.yaw_rad}},
                {"source", r.mounting_source.empty() ? json(nullptr) : json(r.mounting_source)},
                {"ground_offset", nullptr}, {"ground_tilt_deg", nullptr}, {"disagrees", nullptr}};
    if (r.plane) {
        const MountingCheck c = check_mounting(*r.plane);
        out["ground_offset"] = c.offset_m, out["ground_tilt_deg"] = c.tilt_deg, out["disagrees"] = c.disagrees;
    }
    return out;
}

json fusion_json(const std::optional<FusionStatus>& f, double time_ms, bool timing) {
    if (!f) return nullptr;
    json out = {{"method", to_string(f->method)}, {"frames", f->frames}, {"coverage", f->coverage},
                {"frame_coverage", f->frame_coverage}, {"reset", f->reset.empty() ? json(nullptr) : json(f->reset)},
                {"pose", {f->pose.x_m, f->pose.y_m, f->pose.yaw_rad}}};
    if (timing) out["time_ms"] = time_ms;
    return out;
}

}  // namespace

namespace detail {
nlohmann::ordered_json profile_to_json(const Profile& p) { return profile_json(p); }
nlohmann::ordered_json roughness_to_json(const Roughness& r) { return roughness_json(r); }
}  // namespace detail

std::string result_to_json(const Result& r) { return result_to_json(r, LineOptions{}); }

std::string result_to_json(const Result& r, const LineOptions& options) {
    json line = {
        {"frame", options.frame ? *options.frame : static_cast<std::int64_t>(r.frame)},
        {"source", r.source},
        {"timestamp", r.timestamp ? number(*r.timestamp) : json(nullptr)},
        {"motion", {{"speed", r.speed_mps}, {"yaw_rate", r.yaw_rate_rps}, {"status", to_string(r.path.status)}}},
        {"points", {{"input", r.points.input}, {"finite", r.points.finite}, {"roi", r.points.roi},
                    {"ground", r.points.ground}}},
        {"ground", {{"method", to_string(r.ground_method)},
                    {"plane", r.plane ? json(*r.plane) : json(nullptr)}}},
        {"mounting", mounting_json(r)},
        {"path", path_json(r.path, r.yaw_rate_source)},
        {"obstacles", clusters_json(r.obstacles)},
        {"profiles", {{"left", profile_json(r.left)}, {"right", profile_json(r.right)}}},
        {"roughness", {{"left", roughness_json(r.left.roughness)},
                       {"right", roughness_json(r.right.roughness)},
                       {"vehicle", roughness_json(r.vehicle)}}},
        {"reason", r.status == FrameStatus::Ok ? json(nullptr) : json(to_string(r.status))},
        {"fusion", fusion_json(r.fusion, r.timing_ms.fusion, options.timing)},
    };
    if (options.timing)
        line["timing_ms"] = {{"ground", r.timing_ms.ground}, {"path", r.timing_ms.path}, {"profile", r.timing_ms.profile},
                             {"roughness", r.timing_ms.roughness}, {"obstacles", r.timing_ms.obstacles},
                             {"total", r.timing_ms.total}};
    return line.dump();
}

}  // namespace roadpreview
