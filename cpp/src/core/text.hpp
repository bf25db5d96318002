// SPDX-License-Identifier: BSD-3-Clause
// Internal: numbers in messages and in text inputs. std::to_string prints a double as %f: "0.100000", and 1e300 as
// 301 digits; strtod reads by the process's locale (under a decimal comma "1.5" is 1 and ".5" is left over) and
// takes hexadecimal ("0x10" is 16).
#pragma once

#include <charconv>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>

namespace roadpreview {

/// A number for a message, to `digits` significant digits: 0.1 stays "0.1", 1e300 "1e+300".
inline std::string number_text(double v, int digits = 6) {
    std::ostringstream out;
    out.precision(digits);
    out << v;
    return out.str();
}

/// The number a whole token spells in decimal notation — an optional sign, digits with an optional point, an
/// optional exponent; or inf / nan — whatever the locale; nullopt for anything else (hexadecimal, a decimal comma,
/// spaces, nothing).
inline std::optional<double> parse_number(std::string_view token) {
    if (token.size() > 1 && token[0] == '+' && token[1] != '-' && token[1] != '+') token.remove_prefix(1);
    double v = 0.0;
    const char* end = token.data() + token.size();
    const auto [stop, error] = std::from_chars(token.data(), end, v, std::chars_format::general);
    if (token.empty() || error != std::errc() || stop != end) return std::nullopt;
    return v;
}

}  // namespace roadpreview
