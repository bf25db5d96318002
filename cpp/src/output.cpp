// SPDX-License-Identifier: BSD-3-Clause
// The JSON output line (schema in docs/output.md). NaN and ±Inf become null.
#include <cmath>

#include <nlohmann/json.hpp>

#include "roadpreview/pipeline.hpp"

namespace roadpreview {
namespace {

using json = nlohmann::ordered_json;  // keeps the documented field order

json number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json numbers(const std::vector<double>& v) {
    json out = json::array();
    for (double x : v) out.push_back(number(x));
    return out;
}

json profile_json(const Profile& p) {
    return {{"s0", p.s0}, {"ds", p.ds}, {"s", numbers(p.s)}, {"z", numbers(p.z)}, {"count", p.count},
            {"spread", numbers(p.spread)}};
}

json optional_number(const std::optional<double>& v) { return v ? number(*v) : json(nullptr); }

json iri_json(const Iri& i) {
    return {{"value", optional_number(i.value)}, {"length", i.length_m},
            {"reason", i.reason.empty() ? json(nullptr) : json(i.reason)}};
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
            {"reason", r.reason.empty() ? json(nullptr) : json(r.reason)},
            {"confidence", fitted ? number(r.confidence) : json(nullptr)},
            {"band_limit", r.band_limit.empty() ? json(nullptr) : json(r.band_limit)},
            {"backed_fraction", optional_number(r.backed_fraction)},
            {"noise_floor", optional_number(r.noise_floor)},
            {"noise_psd", numbers(r.noise_psd)},
            {"iri", iri_json(r.iri)}};
}

json path_json(const WheelPaths& p) {
    if (p.status != PathStatus::Arc) return nullptr;
    return {{"icr_y", p.icr_y}, {"left_radius", p.left_radius}, {"right_radius", p.right_radius}};
}

}  // namespace

std::string result_to_json(const Result& r) {
    const json line = {
        {"frame", r.frame},
        {"source", r.source},
        {"timestamp", r.timestamp ? number(*r.timestamp) : json(nullptr)},
        {"motion", {{"speed", r.speed_mps}, {"yaw_rate", r.yaw_rate_rps}, {"status", to_string(r.path.status)}}},
        {"points", {{"input", r.points.input}, {"finite", r.points.finite}, {"roi", r.points.roi},
                    {"ground", r.points.ground}}},
        {"ground", {{"method", to_string(r.ground_method)},
                    {"plane", r.plane ? json(*r.plane) : json(nullptr)}}},
        {"path", path_json(r.path)},
        {"profiles", {{"left", profile_json(r.left)}, {"right", profile_json(r.right)}}},
        {"roughness", {{"left", roughness_json(r.left.roughness)},
                       {"right", roughness_json(r.right.roughness)},
                       {"vehicle", roughness_json(r.vehicle)}}},
        {"reason", r.reason.empty() ? json(nullptr) : json(r.reason)},
        {"timing_ms", {{"ground", r.timing_ms.ground}, {"path", r.timing_ms.path}, {"profile", r.timing_ms.profile},
                       {"roughness", r.timing_ms.roughness}, {"total", r.timing_ms.total}}},
    };
    return line.dump();
}

}  // namespace roadpreview
