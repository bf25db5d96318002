// SPDX-License-Identifier: BSD-3-Clause
// Option checks shared by the CLI's commands. CLI11's own PositiveNumber and Range print their bounds as doubles'
// extremes ("4.9e-324 to 1.8e308", a 309-digit number) and Range includes its lower bound, which the config then
// refuses after the parse (exit 1, not a usage error): these say the range as the help does.
#pragma once

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include <CLI/CLI.hpp>

namespace roadpreview::cli {

/// A command line that asks for what cannot be done: the CLI prints it and exits 2, as for CLI11's own parse errors,
/// before any input is read.
struct UsageError : std::invalid_argument {
    using std::invalid_argument::invalid_argument;
};

/// A finite number > 0.
inline CLI::Validator positive_finite() {
    return CLI::Validator(
        [](std::string& text) -> std::string {
            double v = 0.0;
            if (!CLI::detail::lexical_cast(text, v) || !std::isfinite(v) || v <= 0.0)
                return "expected a number > 0, got " + text;
            return {};
        },
        "> 0");
}

/// A number in (lo, hi], or in [lo, hi] when `lo_included`.
inline CLI::Validator above_and_at_most(double lo, double hi, bool lo_included = false) {
    char range[64];
    std::snprintf(range, sizeof range, "%c%g, %g]", lo_included ? '[' : '(', lo, hi);
    return CLI::Validator(
        [=](std::string& text) -> std::string {
            double v = 0.0;
            if (!CLI::detail::lexical_cast(text, v) || !((lo_included ? v >= lo : v > lo) && v <= hi))
                return std::string("expected a number in ") + range + ", got " + text;
            return {};
        },
        std::string(range));
}

}  // namespace roadpreview::cli
