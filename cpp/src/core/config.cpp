// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/core/config.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <utility>

// Type errors then name the offending field (/track_width); the setting is part of nlohmann's ABI tag.
#define JSON_DIAGNOSTICS 1
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "core/input_file.hpp"
#include "core/text.hpp"
#include "core/without_exceptions.hpp"

namespace roadpreview {

using nlohmann::json;

NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(Extrinsics, x_m, y_m, z_m, roll_rad, pitch_rad, yaw_rad)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(PathConfig, straight_radius_m, stopped_speed_mps)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(ProfileConfig, preview_length_m, ds_m, max_gap_m, level, level_local,
                                                level_band_m, beam_sigma_deg, beam_sigmas_deg)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(RoughnessConfig, band_min_cpm, band_max_cpm, min_length_m,
                                                min_cycles, min_band_points, noise_aware, min_resolved_fraction)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(ObstaclesConfig, enabled, voxel_m, cluster_tolerance_m,
                                                min_cluster_points, max_cluster_points, ground_search_m,
                                                safety_margin_m, min_height_m, clearance_m)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(IriConfig, min_length_m, min_backed_fraction)

const char* to_string(GroundMethod method) {
    switch (method) {
        case GroundMethod::Pca: return "pca";
        case GroundMethod::Ransac: return "ransac";
        case GroundMethod::Zones: return "zones";
    }
    return "?";
}

void to_json(json& j, const GroundMethod& m) { j = to_string(m); }
void from_json(const json& j, GroundMethod& m) {
    const auto name = j.get<std::string>();
    for (const GroundMethod candidate : {GroundMethod::Pca, GroundMethod::Ransac, GroundMethod::Zones})
        if (name == to_string(candidate)) return void(m = candidate);
    throw std::invalid_argument("ground.method must be \"pca\", \"ransac\" or \"zones\", got \"" + name + "\"");
}
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(GroundConfig, method, roi_x_min_m, roi_x_max_m, roi_y_abs_max_m,
                                                pca_iterations, pca_threshold_m, max_depth_m, ransac_distance_m,
                                                ransac_max_iterations, ransac_seed, max_tilt_deg,
                                                zone_ring_edges_m, zone_sectors, zone_root_m, zone_min_points, zone_seed_points,
                                                zone_max_step_m, zone_max_flatness_m, zone_min_breadth_m)

const char* to_string(FusionMethod method) {
    switch (method) {
        case FusionMethod::None: return "none";
        case FusionMethod::Ema: return "ema";
        case FusionMethod::Kalman: return "kalman";
    }
    return "?";
}

void to_json(json& j, const FusionMethod& m) { j = to_string(m); }
void from_json(const json& j, FusionMethod& m) {
    const auto name = j.get<std::string>();
    for (const FusionMethod candidate : {FusionMethod::None, FusionMethod::Ema, FusionMethod::Kalman})
        if (name == to_string(candidate)) return void(m = candidate);
    throw std::invalid_argument("fusion.method must be \"none\", \"ema\" or \"kalman\", got \"" + name + "\"");
}
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(FusionConfig, method, alpha, cell_m, map_length_m, point_noise_m,
                                                frame_rate_hz, max_time_gap_s, behind_m, align,
                                                align_tilt_sigma, align_excess_half_width_m)

NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(StereoConfig, min_disparity, num_disparities, block_size, p1, p2,
                                                disp12_max_diff, pre_filter_cap, uniqueness_ratio,
                                                speckle_window_size, speckle_range, mode, threads,
                                                disparity_sigma_px, error_correlation_along_px,
                                                error_correlation_across_px, max_depth_m, road_rise_m)

void to_json(json& j, const Config& c) {
    j = json{{"sensor_height", c.sensor_height ? json(*c.sensor_height) : json(nullptr)},
             {"extrinsics", c.extrinsics ? json(*c.extrinsics) : json(nullptr)},
             {"track_width", c.track_width},
             {"tire_width", c.tire_width},
             {"threads", c.threads},
             {"ground", c.ground},
             {"path", c.path},
             {"profile", c.profile},
             {"roughness", c.roughness},
             {"obstacles", c.obstacles},
             {"iri", c.iri},
             {"fusion", c.fusion},
             {"stereo", c.stereo}};
}

void from_json(const json& j, Config& c) {
    const Config defaults;
    if (j.contains("sensor_height") && !j["sensor_height"].is_null()) c.sensor_height = j["sensor_height"].get<double>();
    if (j.contains("extrinsics") && !j["extrinsics"].is_null()) c.extrinsics = j["extrinsics"].get<Extrinsics>();
    c.track_width = j.value("track_width", defaults.track_width);
    c.tire_width = j.value("tire_width", defaults.tire_width);
    c.threads = j.value("threads", defaults.threads);
    c.ground = j.value("ground", defaults.ground);
    c.path = j.value("path", defaults.path);
    c.profile = j.value("profile", defaults.profile);
    c.roughness = j.value("roughness", defaults.roughness);
    c.obstacles = j.value("obstacles", defaults.obstacles);
    c.iri = j.value("iri", defaults.iri);
    c.fusion = j.value("fusion", defaults.fusion);
    c.stereo = j.value("stereo", defaults.stereo);
}

namespace {

// What a field of the defaults' JSON type needs, or empty when `value` has it. Null stands for "not set" in
// the optional fields only (sensor_height, extrinsics).
// Integer fields take whole numbers within their type (int, or std::uint32_t where the defaults hold an unsigned):
// nlohmann casts a number to an integer unchecked, undefined for 1e83 into an int.
std::pair<double, double> integer_range(const json& known) {
    if (known.is_number_unsigned()) return {0.0, std::numeric_limits<std::uint32_t>::max()};
    return {std::numeric_limits<int>::min(), std::numeric_limits<int>::max()};
}

bool fits_integer(const json& value, const json& known) {
    const auto [lo, hi] = integer_range(known);
    const double v = value.is_number() ? value.get<double>() : std::nan("");
    return v == std::floor(v) && v >= lo && v <= hi;
}

std::string range_text(const json& known) {
    const auto [lo, hi] = integer_range(known);
    return "from " + std::to_string(static_cast<long long>(lo)) + " to " + std::to_string(static_cast<long long>(hi));
}

std::string type_problem(const json& value, const json& known, bool optional) {
    if (value.is_null()) return optional ? "" : "must not be null";
    if (known.is_number_integer()) return fits_integer(value, known) ? "" : "must be a whole number " + range_text(known);
    if (known.is_array() && !known.empty() && known[0].is_number_integer() && value.is_array())
        for (const json& v : value)
            if (!fits_integer(v, known[0])) return "must hold whole numbers " + range_text(known[0]);
    if ((known.is_number() || known.is_null()) && !value.is_number()) return "must be a number";
    if (known.is_boolean() && !value.is_boolean()) return "must be true or false";
    if (known.is_string() && !value.is_string()) return "must be a string";
    if (known.is_object() && !value.is_object()) return "must be an object of fields";
    return {};
}

// Unknown keys are almost always typos; the defaults' own JSON is the list of known ones and their types (a
// wrong type would otherwise surface as nlohmann's "[json.exception.type_error.302]" without the field's name).
void check_fields(const json& given, const json& known, const std::string& where) {
    if (!given.is_object()) throw std::invalid_argument(where + " must be a JSON object");
    for (const auto& [key, value] : given.items()) {
        if (!known.contains(key)) throw std::invalid_argument("unknown config field " + where + "." + key);
        const bool optional = where == "config" && (key == "sensor_height" || key == "extrinsics");
        if (auto problem = type_problem(value, known[key], optional); !problem.empty())
            throw std::invalid_argument(where + "." + key + " " + problem + ", got " + value.dump());
        if (value.is_object()) check_fields(value, known[key], where + "." + key);
    }
}

// nlohmann's messages start with "[json.exception.parse_error.101] "; the rest says what and where.
std::string json_message(const json::exception& e) {
    const std::string what = e.what();
    const auto end = what.find("] ");
    return what.rfind("[json.exception.", 0) == 0 && end != std::string::npos ? what.substr(end + 2) : what;
}

void require(bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument("invalid config: " + what);
}

bool positive(double v) { return std::isfinite(v) && v > 0.0; }

void validate_zones(const GroundConfig& g) {
    const auto& edges = g.zone_ring_edges_m;
    require(edges.size() >= 2 && edges.size() <= 1001, "ground.zone_ring_edges_m must hold 2 to 1001 edges");
    require(edges.front() >= 0.0, "ground.zone_ring_edges_m must start at >= 0 m");
    for (std::size_t i = 0; i + 1 < edges.size(); ++i)
        require(std::isfinite(edges[i + 1]) && edges[i] < edges[i + 1], "ground.zone_ring_edges_m must ascend");
    require(g.zone_sectors.size() + 1 == edges.size(), "ground.zone_sectors needs one count per ring");
    for (const int s : g.zone_sectors) require(s >= 1 && s <= 100000, "ground.zone_sectors must be in [1, 100000]");
    // Each patch holds a plane and its scratch: 1000 rings of 100000 sectors asked for gigabytes per frame.
    std::int64_t patches = 0;
    for (const int s : g.zone_sectors) patches += s;
    require(patches <= 1000000, "ground.zone_sectors must sum to at most 1000000 patches");
    require(positive(g.zone_root_m), "ground.zone_root_m must be > 0");
    require(g.zone_min_points >= 3, "ground.zone_min_points must be >= 3");
    require(g.zone_seed_points >= 1, "ground.zone_seed_points must be >= 1");
    require(positive(g.zone_max_step_m), "ground.zone_max_step_m must be > 0");
    require(positive(g.zone_max_flatness_m), "ground.zone_max_flatness_m must be > 0");
    require(std::isfinite(g.zone_min_breadth_m) && g.zone_min_breadth_m >= 0.0,
            "ground.zone_min_breadth_m must be >= 0");
}

// Config files written before the tilt limit applied to every method name it ransac_max_tilt_deg.
void migrate_old_names(json& j) {
    if (!j.is_object() || !j.contains("ground") || !j["ground"].is_object()) return;
    json& g = j["ground"];
    if (!g.contains("ransac_max_tilt_deg")) return;
    if (g.contains("max_tilt_deg"))
        throw std::invalid_argument("set ground.max_tilt_deg or its old name ground.ransac_max_tilt_deg, not both");
    g["max_tilt_deg"] = g["ransac_max_tilt_deg"];
    g.erase("ransac_max_tilt_deg");
}

void validate_stereo(const StereoConfig& s) {
    require(s.num_disparities >= 16 && s.num_disparities % 16 == 0, "stereo.num_disparities must be a positive multiple of 16");
    require(s.block_size >= 1 && s.block_size % 2 == 1 && s.block_size <= 255, "stereo.block_size must be odd, 1..255");
    require(s.p1 >= 0 && s.p2 > s.p1, "stereo.p1 must be >= 0 and stereo.p2 > stereo.p1");
    require(s.pre_filter_cap >= 1 && s.uniqueness_ratio >= 0 && s.speckle_window_size >= 0 && s.speckle_range >= 0,
            "stereo.pre_filter_cap must be >= 1; uniqueness_ratio, speckle_window_size and speckle_range >= 0");
    require(s.mode == "sgbm" || s.mode == "hh" || s.mode == "sgbm_3way" || s.mode == "hh4",
            "stereo.mode must be \"sgbm\", \"hh\", \"sgbm_3way\" or \"hh4\", got \"" + s.mode + "\"");
    require(s.threads >= 0, "stereo.threads must be >= 0");
    require(positive(s.disparity_sigma_px), "stereo.disparity_sigma_px must be > 0");
    require(s.error_correlation_along_px >= 0.0 && s.error_correlation_along_px <= 1e4 &&
                s.error_correlation_across_px >= 0.0 && s.error_correlation_across_px <= 1e4,
            "stereo.error_correlation_along_px and error_correlation_across_px must be within 0..10000");
    require(positive(s.max_depth_m), "stereo.max_depth_m must be > 0");
    require(std::isfinite(s.road_rise_m), "stereo.road_rise_m must be finite");
}

}  // namespace

bool beam_errors_counted(const ProfileConfig& p) {
    return p.beam_sigma_deg > 0.0 ||
           std::any_of(p.beam_sigmas_deg.begin(), p.beam_sigmas_deg.end(), [](double s) { return s > 0.0; });
}

void validate(const Config& c) {
    require(!(c.sensor_height && c.extrinsics), "set sensor_height or extrinsics, not both");
    if (c.sensor_height)
        require(std::isfinite(*c.sensor_height) && *c.sensor_height > 0.0 && *c.sensor_height <= kMaxSensorHeightM,
                "sensor_height must be above 0 and at most " + std::to_string(static_cast<int>(kMaxSensorHeightM)) +
                    " m (the sensor's height above the ground), got " + number_text(*c.sensor_height));
    if (c.extrinsics) {  // a sensor on a vehicle: metres from its base origin, angles of a turn at most
        const Extrinsics& e = *c.extrinsics;
        for (double v : {e.x_m, e.y_m, e.z_m})
            require(std::abs(v) <= kMaxMountingOffsetM, "extrinsics: x, y and z must be within ±" +
                                                            number_text(kMaxMountingOffsetM) + " m, got " + number_text(v));
        for (double v : {e.roll_rad, e.pitch_rad, e.yaw_rad})
            require(std::abs(v) <= 2.0 * M_PI, "extrinsics: roll, pitch and yaw must be within ±2π rad, got " +
                                                   number_text(v));
    }
    require(positive(c.track_width), "track_width must be > 0 m");
    require(positive(c.tire_width), "tire_width must be > 0 m");
    require(c.tire_width < c.track_width, "tire_width must be smaller than track_width");
    require(c.threads >= 1 && c.threads <= kMaxThreads,
            "threads must be between 1 and " + std::to_string(kMaxThreads) + ", got " + std::to_string(c.threads));

    const GroundConfig& g = c.ground;
    // An enum set from an integer (a cast, a config of another version) names no method: it would run one unsaid.
    const auto value = [](auto method) { return ", got the value " + std::to_string(static_cast<int>(method)); };
    require(std::string_view(to_string(g.method)) != "?", "ground.method must be pca, ransac or zones" + value(g.method));
    require(std::string_view(to_string(c.fusion.method)) != "?",
            "fusion.method must be none, ema or kalman" + value(c.fusion.method));
    require(std::isfinite(g.roi_x_min_m) && std::isfinite(g.roi_x_max_m) && g.roi_x_min_m < g.roi_x_max_m,
            "ground.roi_x_min_m must be < ground.roi_x_max_m");
    require(positive(g.roi_y_abs_max_m), "ground.roi_y_abs_max_m must be > 0");
    // Wheels that start beside the region roll where it holds no point: every class would be declined, unsaid.
    require((c.track_width + c.tire_width) / 2.0 <= g.roi_y_abs_max_m,
            "the wheels (track_width " + number_text(c.track_width) + " m, tire_width " + number_text(c.tire_width) +
                " m) must lie within the region of interest's half width ground.roi_y_abs_max_m (" +
                number_text(g.roi_y_abs_max_m) + " m)");
    require(g.pca_iterations >= 1 && g.pca_iterations <= kMaxFitIterations,
            "ground.pca_iterations must be in [1, " + std::to_string(kMaxFitIterations) + "]");
    // A histogram of heights a quarter of it apart finds the root's slab: 1 µm asked for 160 million bins a frame.
    require(std::isfinite(g.pca_threshold_m) && g.pca_threshold_m >= 0.001,
            "ground.pca_threshold_m must be >= 0.001 m");
    require(positive(g.max_depth_m), "ground.max_depth_m must be > 0");
    require(positive(g.ransac_distance_m), "ground.ransac_distance_m must be > 0");
    require(positive(g.max_tilt_deg) && g.max_tilt_deg < 90.0, "ground.max_tilt_deg must be in (0, 90)");
    require(g.ransac_max_iterations >= 1 && g.ransac_max_iterations <= kMaxRansacIterations,
            "ground.ransac_max_iterations must be in [1, " + std::to_string(kMaxRansacIterations) + "]");
    validate_zones(g);

    require(positive(c.path.straight_radius_m), "path.straight_radius_m must be > 0");
    require(std::isfinite(c.path.stopped_speed_mps) && c.path.stopped_speed_mps >= 0.0,
            "path.stopped_speed_mps must be >= 0");

    const ProfileConfig& p = c.profile;
    require(positive(p.ds_m), "profile.ds_m must be > 0");
    require(positive(p.preview_length_m) && p.preview_length_m >= p.ds_m,
            "profile.preview_length_m must be >= profile.ds_m");
    require(p.preview_length_m / p.ds_m <= 1e6, "profile.preview_length_m / profile.ds_m must be <= 1e6 bins");
    require(std::isfinite(p.max_gap_m) && p.max_gap_m >= 0.0, "profile.max_gap_m must be >= 0");
    require(std::isfinite(p.level_band_m) && p.level_band_m >= 0.5, "profile.level_band_m must be >= 0.5");
    require(std::isfinite(p.beam_sigma_deg) && p.beam_sigma_deg >= 0.0 && p.beam_sigma_deg <= 10.0,
            "profile.beam_sigma_deg must be in [0, 10]");
    require(p.beam_sigmas_deg.size() <= kMaxBeams, "profile.beam_sigmas_deg may list at most " +
                                                      std::to_string(kMaxBeams) + " beams, got " +
                                                      std::to_string(p.beam_sigmas_deg.size()));
    for (std::size_t b = 0; b < p.beam_sigmas_deg.size(); ++b)
        require(std::isfinite(p.beam_sigmas_deg[b]) && p.beam_sigmas_deg[b] >= 0.0 && p.beam_sigmas_deg[b] <= 10.0,
                "profile.beam_sigmas_deg[" + std::to_string(b) + "] must be in [0, 10], got " +
                    number_text(p.beam_sigmas_deg[b]));

    const RoughnessConfig& r = c.roughness;
    require(positive(r.band_min_cpm) && std::isfinite(r.band_max_cpm) && r.band_min_cpm < r.band_max_cpm,
            "roughness.band_min_cpm must be > 0 and < roughness.band_max_cpm");
    require(positive(r.min_length_m), "roughness.min_length_m must be > 0");
    require(std::isfinite(r.min_cycles) && r.min_cycles >= 1.0, "roughness.min_cycles must be >= 1");
    require(r.min_band_points >= 2, "roughness.min_band_points must be >= 2");

    const ObstaclesConfig& o = c.obstacles;
    require(std::isfinite(o.voxel_m) && (o.voxel_m == 0.0 || o.voxel_m >= 0.01),
            "obstacles.voxel_m must be 0 (no voxels) or >= 0.01");
    require(std::isfinite(o.cluster_tolerance_m) && o.cluster_tolerance_m >= 0.01,
            "obstacles.cluster_tolerance_m must be >= 0.01 m");
    require(o.min_cluster_points >= 1, "obstacles.min_cluster_points must be >= 1");
    require(o.max_cluster_points >= o.min_cluster_points,
            "obstacles.max_cluster_points must be >= obstacles.min_cluster_points");
    require(std::isfinite(o.safety_margin_m) && o.safety_margin_m >= 0.0, "obstacles.safety_margin_m must be >= 0");
    require(std::isfinite(o.ground_search_m) && o.ground_search_m >= 0.0, "obstacles.ground_search_m must be >= 0");
    require(std::isfinite(o.min_height_m), "obstacles.min_height_m must be finite");
    require(std::isfinite(o.clearance_m) && o.clearance_m > o.min_height_m,
            "obstacles.clearance_m must be finite and > obstacles.min_height_m");

    require(std::isfinite(r.min_resolved_fraction) && r.min_resolved_fraction > 0.0 && r.min_resolved_fraction <= 1.0,
            "roughness.min_resolved_fraction must be in (0, 1]");

    require(std::isfinite(c.iri.min_length_m) && c.iri.min_length_m >= 0.0, "iri.min_length_m must be >= 0");
    require(std::isfinite(c.iri.min_backed_fraction) && c.iri.min_backed_fraction >= 0.0 &&
                c.iri.min_backed_fraction <= 1.0,
            "iri.min_backed_fraction must be in [0, 1]");

    const FusionConfig& f = c.fusion;
    require(std::isfinite(f.alpha) && f.alpha > 0.0 && f.alpha <= 1.0, "fusion.alpha must be in (0, 1]");
    require(std::isfinite(f.cell_m) && f.cell_m >= 0.01 && f.cell_m <= 10.0, "fusion.cell_m must be in [0.01, 10] m");
    require(std::isfinite(f.map_length_m) && f.map_length_m > 0.0 && f.map_length_m / f.cell_m <= 4000.0,
            "fusion.map_length_m must be > 0 and <= 4000 cells");
    // The map must hold the profiles ahead in every heading and those behind: a rule of the fusion only.
    require(f.method == FusionMethod::None || f.map_length_m >= 2.0 * (p.preview_length_m + f.behind_m),
            "fusion.map_length_m (" + number_text(f.map_length_m) + " m) must be >= 2 x (profile.preview_length_m + "
            "fusion.behind_m) = " + number_text(2.0 * (p.preview_length_m + f.behind_m)) + " m with fusion on");
    require(positive(f.point_noise_m), "fusion.point_noise_m must be > 0");
    require(std::isfinite(f.frame_rate_hz) && f.frame_rate_hz >= 0.01 && f.frame_rate_hz <= 10000.0,
            "fusion.frame_rate_hz must be in [0.01, 10000]");
    require(positive(f.max_time_gap_s), "fusion.max_time_gap_s must be > 0");
    require(std::isfinite(f.behind_m) && f.behind_m >= 0.0, "fusion.behind_m must be >= 0");
    require(std::isfinite(f.align_tilt_sigma) && f.align_tilt_sigma >= 1e-9 && f.align_tilt_sigma <= 1.0,
            "fusion.align_tilt_sigma must be in [1e-9, 1] rad");
    require(positive(f.align_excess_half_width_m), "fusion.align_excess_half_width_m must be > 0");
    validate_stereo(c.stereo);
}

Status check_config(const Config& cfg) noexcept { return without_exceptions([&] { validate(cfg); }); }

Extrinsics effective_extrinsics(const Config& c) {
    if (c.extrinsics) return *c.extrinsics;
    Extrinsics e;
    if (c.sensor_height) e.z_m = *c.sensor_height;
    return e;
}

Config config_from_json(const std::string& text, const std::string& source) {
    try {
        json j = json::parse(text);
        migrate_old_names(j);
        Config known;
        known.extrinsics = Extrinsics{};  // so the nested extrinsics keys are known too
        check_fields(j, json(known), "config");
        Config cfg = j.get<Config>();
        validate(cfg);
        return cfg;
    } catch (const json::exception& e) {
        throw std::invalid_argument(source + ": " + json_message(e));
    } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(source + ": " + e.what());
    }
}

std::string config_to_json(const Config& cfg) { return json(cfg).dump(); }

namespace {

// A config holds a few hundred values; aliases may repeat a node, and aliases of aliases double it at every level:
// ten levels of "billion laughs" are a billion values from a few lines. Beyond this many, the file is refused.
constexpr std::size_t kMaxYamlValues = 100'000;

// YAML scalars carry no type; read them as JSON would (bool, integer, number), quoted ones as strings. `budget`:
// the values still allowed.
json yaml_to_json(const YAML::Node& node, std::size_t& budget) {
    if (budget-- == 0)
        throw std::invalid_argument("more than " + std::to_string(kMaxYamlValues) +
                                    " values (aliases repeating a node over and over?)");
    switch (node.Type()) {
        case YAML::NodeType::Sequence: {
            json out = json::array();
            for (const auto& item : node) out.push_back(yaml_to_json(item, budget));
            return out;
        }
        case YAML::NodeType::Map: {
            json out = json::object();
            for (const auto& kv : node) out[kv.first.as<std::string>()] = yaml_to_json(kv.second, budget);
            return out;
        }
        case YAML::NodeType::Scalar: {
            if (node.Tag() == "!") return node.Scalar();
            bool b;
            long long i;
            double d;
            if (YAML::convert<bool>::decode(node, b)) return b;
            if (YAML::convert<long long>::decode(node, i)) return i;
            if (YAML::convert<double>::decode(node, d)) return d;
            return node.Scalar();
        }
        default:
            return nullptr;
    }
}

bool is_yaml(const std::string& path) {
    const auto dot = path.find_last_of('.');
    const std::string ext = dot == std::string::npos ? "" : path.substr(dot);
    return ext == ".yaml" || ext == ".yml";
}

}  // namespace

Config config_from_file(const std::string& path) {
    require_input_file<std::invalid_argument>(path, "config file");
    std::ifstream in(path);
    if (!in) throw std::invalid_argument(path + ": cannot open config file");
    std::stringstream text;
    text << in.rdbuf();
    if (!is_yaml(path)) return config_from_json(text.str(), path);
    std::string json_text;
    try {
        std::size_t budget = kMaxYamlValues;
        json_text = yaml_to_json(YAML::Load(text.str()), budget).dump();
    } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(path + ": not a config: " + e.what());
    } catch (const YAML::Exception& e) {
        throw std::invalid_argument(path + ": not valid YAML: " + e.what());
    } catch (const nlohmann::json::type_error&) {  // dump() meets a string that is not UTF-8
        throw std::invalid_argument(path + ": not valid YAML: the text is not UTF-8");
    }
    return config_from_json(json_text, path);
}

}  // namespace roadpreview
