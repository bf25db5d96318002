// SPDX-License-Identifier: BSD-3-Clause
// A run's output lines back into what RouteBuilder::add reads, so a drive can be stitched after the fact from
// its JSON lines (roadpreview batch reads them from its Parquet parts).
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "roadpreview/route/route.hpp"

namespace roadpreview {
namespace {

using json = nlohmann::json;

[[noreturn]] void fail(const std::string& where, const std::string& what) {
    throw std::invalid_argument(where + ": " + what);
}

const json& member(const json& object, const char* key, const std::string& where) {
    if (!object.is_object() || !object.contains(key)) fail(where, std::string("the output line has no '") + key + "'");
    return object.at(key);
}

double number_or_nan(const json& v, const std::string& where) {
    if (v.is_null()) return std::numeric_limits<double>::quiet_NaN();
    if (!v.is_number()) fail(where, "expected a number or null, got " + v.dump());
    return v.get<double>();
}

std::vector<double> numbers(const json& v, const std::string& where) {
    if (!v.is_array()) fail(where, "expected an array");
    std::vector<double> out;
    out.reserve(v.size());
    for (const json& x : v) out.push_back(number_or_nan(x, where));
    return out;
}

// A member that may be absent or null (the reference reads lines the same lenient way).
const json* optional_member(const json& object, const char* key) {
    if (!object.is_object() || !object.contains(key) || object.at(key).is_null()) return nullptr;
    return &object.at(key);
}

Profile profile_from(const json& p, const std::string& where) {
    Profile out;
    out.s = numbers(member(p, "s", where), where + " s");
    out.z = numbers(member(p, "z", where), where + " z");
    out.spread = numbers(member(p, "spread", where), where + " spread");
    for (const json& c : member(p, "count", where)) {
        if (!c.is_number_integer() || c.get<std::int64_t>() < 0 || c.get<std::int64_t>() > std::numeric_limits<std::int32_t>::max())
            fail(where, "count must hold whole numbers from 0 to 2147483647, got " + c.dump());
        out.count.push_back(c.get<std::int32_t>());
    }
    if (out.z.size() != out.s.size() || out.count.size() != out.s.size() || out.spread.size() != out.s.size())
        fail(where, "s, z, count and spread differ in length");
    if (const json* blocked = optional_member(p, "blocked")) {  // lines of older runs may lack it, or leave it empty
        if (!blocked->is_array() || (!blocked->empty() && blocked->size() != out.s.size()))
            fail(where, "blocked must be an array of true/false as long as s");
        for (const json& b : *blocked) {
            if (!b.is_boolean()) fail(where, "blocked must hold true or false, got " + b.dump());
            out.blocked.push_back(b.get<bool>() ? 1 : 0);
        }
    }
    return out;
}

// The status whose text (to_string) the line's `reason` holds.
FrameStatus frame_status(const json& reason, const std::string& where) {
    const std::string text = reason.get<std::string>();
    for (const FrameStatus s : {FrameStatus::NoFinitePoints, FrameStatus::NoRoiPoints, FrameStatus::NoGround,
                                FrameStatus::TiltedGround, FrameStatus::VehicleStopped})
        if (text == to_string(s)) return s;
    fail(where, "unknown reason \"" + text + "\"");
}

}  // namespace

Result route_input_from_json(const std::string& line, const std::string& where) {
    json j;
    try {
        j = json::parse(line);
    } catch (const json::exception& e) {  // parse_error, and out_of_range for a number beyond a double (1e400)
        fail(where, std::string("not a JSON output line (") + e.what() + ")");
    }
    Result r;
    if (const json* source = optional_member(j, "source"); source && source->is_string()) r.source = source->get<std::string>();
    if (const json* t = optional_member(j, "timestamp")) r.timestamp = number_or_nan(*t, where + " timestamp");
    r.speed_mps = number_or_nan(member(member(j, "motion", where), "speed", where), where + " motion.speed");
    if (const json* reason = optional_member(j, "reason"); reason && reason->is_string()) r.status = frame_status(*reason, where);
    if (r.status != FrameStatus::Ok) return r;  // no profiles: the frame only moves the drive on
    const json* path = optional_member(j, "path");
    if (path && optional_member(*path, "icr_y")) {
        r.path.status = PathStatus::Arc;
        r.path.icr_y = number_or_nan(path->at("icr_y"), where + " path.icr_y");
        r.path.left_radius = number_or_nan(member(*path, "left_radius", where), where + " path.left_radius");
        r.path.right_radius = number_or_nan(member(*path, "right_radius", where), where + " path.right_radius");
    }
    const json& profiles = member(j, "profiles", where);
    r.left = profile_from(member(profiles, "left", where), where + " profiles.left");
    r.right = profile_from(member(profiles, "right", where), where + " profiles.right");
    return r;
}

}  // namespace roadpreview
