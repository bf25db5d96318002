// SPDX-License-Identifier: BSD-3-Clause
// The output line's JSON writer (RapidJSON's, streaming: a line holds thousands of numbers, which built as JSON
// values first cost several times their writing), and the profiles and roughness fields (docs/output.md) for
// other outputs that share the schema.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <rapidjson/stringbuffer.h>
#include <rapidjson/writer.h>

#include "roadpreview/profile/profile.hpp"

namespace roadpreview::detail {

/// Numbers as text that reads back the same double (Grisu2: at most 17 digits); strings checked to be UTF-8.
using JsonWriter = rapidjson::Writer<rapidjson::StringBuffer, rapidjson::UTF8<>, rapidjson::UTF8<>,
                                     rapidjson::CrtAllocator, rapidjson::kWriteValidateEncodingFlag>;

void write_number(JsonWriter& w, double v);  ///< null for NaN and ±Inf
void write_optional_number(JsonWriter& w, const std::optional<double>& v);
void write_numbers(JsonWriter& w, const std::vector<double>& v);
/// Throws std::runtime_error naming `what` when the text is not UTF-8.
void write_string(JsonWriter& w, const std::string& text, const char* what);
/// null for empty text, else write_string.
void write_string_or_null(JsonWriter& w, const std::string& text, const char* what);
/// The "profiles" and "roughness" fields: both wheels' profiles, then their and the vehicle's roughness.
void write_profiles_and_roughness(JsonWriter& w, const Profile& left, const Profile& right, const Roughness& vehicle);

}  // namespace roadpreview::detail
