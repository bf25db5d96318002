// SPDX-License-Identifier: BSD-3-Clause
// Internal: numbers in messages. std::to_string prints a double as %f: "0.100000", and 1e300 as 301 digits.
#pragma once

#include <sstream>
#include <string>

namespace roadpreview {

/// A number for a message, to `digits` significant digits: 0.1 stays "0.1", 1e300 "1e+300".
inline std::string number_text(double v, int digits = 6) {
    std::ostringstream out;
    out.precision(digits);
    out << v;
    return out.str();
}

}  // namespace roadpreview
