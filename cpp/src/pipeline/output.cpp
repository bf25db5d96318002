// SPDX-License-Identifier: BSD-3-Clause
// The JSON output line (schema in docs/output.md), written field by field in the documented order. NaN and ±Inf
// become null.
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "roadpreview/ground/mounting.hpp"
#include "pipeline/output_json.hpp"
#include "roadpreview/pipeline/pipeline.hpp"
#include "roadpreview/route/readout.hpp"

namespace roadpreview {
namespace detail {

void write_number(JsonWriter& w, double v) {
    if (std::isfinite(v))
        w.Double(v);
    else
        w.Null();
}

void write_optional_number(JsonWriter& w, const std::optional<double>& v) {
    if (v)
        write_number(w, *v);
    else
        w.Null();
}

void write_numbers(JsonWriter& w, const std::vector<double>& v) {
    w.StartArray();
    for (const double x : v) write_number(w, x);
    w.EndArray();
}

void write_string(JsonWriter& w, const std::string& text, const char* what) {
    if (w.String(text.data(), static_cast<rapidjson::SizeType>(text.size()))) return;
    std::string shown;  // the text with its bytes beyond ASCII as \xNN, so that the message itself is valid text
    for (const char c : text) {
        const auto byte = static_cast<unsigned char>(c);
        if (byte >= 0x20 && byte < 0x7f) {
            shown += c;
        } else {
            char hex[5];
            std::snprintf(hex, sizeof hex, "\\x%02x", byte);
            shown += hex;
        }
    }
    throw std::runtime_error(std::string("output line: the ") + what + " is not UTF-8 text: " + shown);
}

void write_string_or_null(JsonWriter& w, const std::string& text, const char* what) {
    if (text.empty())
        w.Null();
    else
        write_string(w, text, what);
}

}  // namespace detail

namespace {

using detail::JsonWriter;
using detail::write_number;
using detail::write_numbers;
using detail::write_optional_number;
using detail::write_string;

constexpr double kNull = std::numeric_limits<double>::quiet_NaN();  // written as null

// Obstacle geometry to 1 mm and yaw to 1 mrad keeps the lists short; both are far below the sensors' noise.
void write_rounded(JsonWriter& w, double v) { write_number(w, std::round(v * 1e3) / 1e3); }

void write_rounded3(JsonWriter& w, const Vec3& v) {
    w.StartArray();
    for (const double x : v) write_rounded(w, x);
    w.EndArray();
}

// A reason's text, null for none (""): the texts are the library's own ASCII.
void write_text_or_null(JsonWriter& w, const char* text) {
    if (*text)
        w.String(text);
    else
        w.Null();
}

// A list that may be absent (null: the stage is off), each item written by `write_item`.
template <typename T, typename WriteItem>
void write_list_or_null(JsonWriter& w, const std::optional<std::vector<T>>& items, WriteItem write_item) {
    if (!items) {
        w.Null();
        return;
    }
    w.StartArray();
    for (const T& item : *items) write_item(item);
    w.EndArray();
}

void write_path_obstacle(JsonWriter& w, const PathObstacle& o) {
    w.StartObject();
    w.Key("id"), w.Int(o.id);
    w.Key("s_start"), write_rounded(w, o.s_start);
    w.Key("s_end"), write_rounded(w, o.s_end);
    w.Key("height"), write_rounded(w, o.height);
    w.EndObject();
}

void write_cluster(JsonWriter& w, const Cluster& c) {
    w.StartObject();
    w.Key("id"), w.Int(c.id);
    w.Key("count"), w.Int(c.count);
    w.Key("centroid"), write_rounded3(w, c.centroid);
    w.Key("aabb_min"), write_rounded3(w, c.aabb_min);
    w.Key("aabb_max"), write_rounded3(w, c.aabb_max);
    w.Key("obb"), w.StartObject();
    w.Key("center"), write_rounded3(w, c.obb.center);
    w.Key("size"), write_rounded3(w, c.obb.size);
    w.Key("yaw"), write_rounded(w, c.obb.yaw);
    w.EndObject();
    w.Key("height"), write_rounded(w, c.height);
    w.Key("bottom"), write_rounded(w, c.bottom);
    w.EndObject();
}

void write_iri(JsonWriter& w, const Iri& i) {
    w.StartObject();
    w.Key("value"), write_optional_number(w, i.value);
    w.Key("length"), write_number(w, i.length_m);
    w.Key("reason"), write_text_or_null(w, to_string(i.reason));
    w.Key("backed_fraction"), write_optional_number(w, i.backed_fraction);
    w.Key("noise"), write_optional_number(w, i.noise);
    w.EndObject();
}

void write_path(JsonWriter& w, const WheelPaths& p, const std::string& yaw_rate_source) {
    const bool arc = p.status == PathStatus::Arc;
    if (!arc && yaw_rate_source.empty()) {
        w.Null();
        return;
    }
    w.StartObject();
    w.Key("icr_y"), write_number(w, arc ? p.icr_y : kNull);
    w.Key("left_radius"), write_number(w, arc ? p.left_radius : kNull);
    w.Key("right_radius"), write_number(w, arc ? p.right_radius : kNull);
    if (!yaw_rate_source.empty()) w.Key("yaw_rate_source"), write_string(w, yaw_rate_source, "yaw rate source");
    w.EndObject();
}

// The extrinsics in force, where they came from, and how the fitted ground sits in the base frame.
void write_mounting(JsonWriter& w, const Result& r) {
    const Extrinsics& e = r.extrinsics;
    w.StartObject();
    w.Key("extrinsics"), w.StartArray();
    for (const double v : {e.x_m, e.y_m, e.z_m, e.roll_rad, e.pitch_rad, e.yaw_rad}) write_number(w, v);
    w.EndArray();
    w.Key("source"), detail::write_string_or_null(w, r.mounting_source, "mounting source");
    if (r.plane) {
        const MountingCheck c = check_mounting(*r.plane);
        w.Key("ground_offset"), write_number(w, c.offset_m);
        w.Key("ground_tilt_deg"), write_number(w, c.tilt_deg);
        w.Key("disagrees"), w.Bool(c.disagrees);
    } else {
        w.Key("ground_offset"), w.Null();
        w.Key("ground_tilt_deg"), w.Null();
        w.Key("disagrees"), w.Null();
    }
    w.EndObject();
}

void write_fusion(JsonWriter& w, const std::optional<FusionStatus>& f, double time_ms, bool timing) {
    if (!f) {
        w.Null();
        return;
    }
    w.StartObject();
    w.Key("method"), w.String(to_string(f->method));
    w.Key("frames"), w.Int64(f->frames);
    w.Key("coverage"), write_number(w, f->coverage);
    w.Key("frame_coverage"), write_number(w, f->frame_coverage);
    w.Key("reset"), detail::write_string_or_null(w, f->reset, "fusion reset");
    w.Key("pose"), w.StartArray();
    for (const double v : {f->pose.x_m, f->pose.y_m, f->pose.yaw_rad}) write_number(w, v);
    w.EndArray();
    if (timing) w.Key("time_ms"), write_number(w, time_ms);
    w.EndObject();
}

void write_timing(JsonWriter& w, const TimingMs& t) {
    w.StartObject();
    w.Key("ground"), write_number(w, t.ground);
    w.Key("path"), write_number(w, t.path);
    w.Key("profile"), write_number(w, t.profile);
    w.Key("roughness"), write_number(w, t.roughness);
    w.Key("obstacles"), write_number(w, t.obstacles);
    w.Key("total"), write_number(w, t.total);
    w.EndObject();
}

void write_profile(JsonWriter& w, const Profile& p) {
    w.StartObject();
    w.Key("s0"), write_number(w, p.s0);
    w.Key("ds"), write_number(w, p.ds);
    w.Key("s"), write_numbers(w, p.s);
    w.Key("z"), write_numbers(w, p.z);
    w.Key("count"), w.StartArray();
    for (const std::int32_t c : p.count) w.Int(c);
    w.EndArray();
    w.Key("spread"), write_numbers(w, p.spread);
    w.Key("blocked"), w.StartArray();
    for (const std::uint8_t b : p.blocked) w.Bool(b != 0);
    w.EndArray();
    w.Key("obstacles"), write_list_or_null(w, p.obstacles, [&](const PathObstacle& o) { write_path_obstacle(w, o); });
    w.EndObject();
}

void write_roughness(JsonWriter& w, const Roughness& r) {
    const bool fitted = r.iso_class.has_value();
    const auto fitted_number = [&](double v) { write_number(w, fitted ? v : kNull); };
    w.StartObject();
    w.Key("class");
    if (fitted)
        w.String(&*r.iso_class, 1);
    else
        w.Null();
    w.Key("gd_n0"), fitted_number(r.gd_n0);
    w.Key("gd_n0_free"), fitted_number(r.gd_n0_free);
    w.Key("waviness"), fitted_number(r.waviness);
    w.Key("band");
    if (fitted) {
        w.StartArray();
        write_number(w, r.band_lo);
        write_number(w, r.band_hi);
        w.EndArray();
    } else {
        w.Null();
    }
    w.Key("n"), write_numbers(w, r.spectrum.n);
    w.Key("psd"), write_numbers(w, r.spectrum.psd);
    w.Key("octave_bands"), w.StartArray();
    for (std::size_t i = 0; i < r.octave_centers.size(); ++i) {
        w.StartObject();
        w.Key("center"), write_number(w, r.octave_centers[i]);
        w.Key("gd"), write_number(w, r.octave_gd[i]);
        w.EndObject();
    }
    w.EndArray();
    w.Key("reason"), write_text_or_null(w, to_string(r.reason));
    w.Key("confidence"), fitted_number(r.confidence);
    w.Key("band_limit"), write_text_or_null(w, to_string(r.band_limit));
    w.Key("backed_fraction"), write_optional_number(w, r.backed_fraction);
    w.Key("noise_floor"), write_optional_number(w, r.noise_floor);
    w.Key("noise_psd"), write_numbers(w, r.noise_psd);
    w.Key("iri"), write_iri(w, r.iri);
    w.EndObject();
}

}  // namespace

namespace detail {

void write_profiles_and_roughness(JsonWriter& w, const Profile& left, const Profile& right, const Roughness& vehicle) {
    w.Key("profiles"), w.StartObject();
    w.Key("left"), write_profile(w, left);
    w.Key("right"), write_profile(w, right);
    w.EndObject();
    w.Key("roughness"), w.StartObject();
    w.Key("left"), write_roughness(w, left.roughness);
    w.Key("right"), write_roughness(w, right.roughness);
    w.Key("vehicle"), write_roughness(w, vehicle);
    w.EndObject();
}

}  // namespace detail

namespace {

void write_readout_wheel(JsonWriter& w, const ReadoutProfile& p) {
    w.StartObject();
    w.Key("s"), detail::write_numbers(w, p.s);
    w.Key("z"), detail::write_numbers(w, p.z);
    w.Key("count"), w.StartArray();
    for (const std::int32_t c : p.count) w.Int(c);
    w.EndArray();
    w.EndObject();
}

void write_readout(JsonWriter& w, const ProfileReadout& readout) {
    w.StartObject();
    w.Key("ahead_m"), detail::write_number(w, readout.ahead_m());
    w.Key("distance_m"), detail::write_number(w, readout.distance_m());
    w.Key("left"), write_readout_wheel(w, readout.left());
    w.Key("right"), write_readout_wheel(w, readout.right());
    w.EndObject();
}

}  // namespace

std::string result_to_json(const Result& r) { return result_to_json(r, LineOptions{}); }

std::string result_to_json(const Result& r, const LineOptions& options) {
    rapidjson::StringBuffer text;
    JsonWriter w(text);
    w.StartObject();
    w.Key("frame"), w.Int64(options.frame ? *options.frame : static_cast<std::int64_t>(r.frame));
    w.Key("source"), write_string(w, r.source, "source");
    w.Key("timestamp"), write_optional_number(w, r.timestamp);
    w.Key("motion"), w.StartObject();
    w.Key("speed"), write_number(w, r.speed_mps);
    w.Key("yaw_rate"), write_number(w, r.yaw_rate_rps);
    w.Key("status"), w.String(to_string(r.path.status));
    w.EndObject();
    w.Key("points"), w.StartObject();
    w.Key("input"), w.Int64(r.points.input);
    w.Key("finite"), w.Int64(r.points.finite);
    w.Key("roi"), w.Int64(r.points.roi);
    w.Key("ground"), w.Int64(r.points.ground);
    w.EndObject();
    w.Key("ground"), w.StartObject();
    w.Key("method"), w.String(to_string(r.ground_method));
    w.Key("plane");
    if (r.plane) {
        w.StartArray();
        for (const double v : *r.plane) write_number(w, v);
        w.EndArray();
    } else {
        w.Null();
    }
    w.EndObject();
    w.Key("mounting"), write_mounting(w, r);
    w.Key("path"), write_path(w, r.path, r.yaw_rate_source);
    w.Key("obstacles"), write_list_or_null(w, r.obstacles, [&](const Cluster& c) { write_cluster(w, c); });
    detail::write_profiles_and_roughness(w, r.left, r.right, r.vehicle);
    w.Key("reason");
    if (r.status == FrameStatus::Ok)
        w.Null();
    else
        w.String(to_string(r.status));
    w.Key("fusion"), write_fusion(w, r.fusion, r.timing_ms.fusion, options.timing);
    if (options.readout) w.Key("readout"), write_readout(w, *options.readout);
    if (options.timing) w.Key("timing_ms"), write_timing(w, r.timing_ms);
    w.EndObject();
    return std::string(text.GetString(), text.GetSize());
}

}  // namespace roadpreview
