// SPDX-License-Identifier: BSD-3-Clause
// Small CSV helpers for the range sensor files: a header's named columns and finite numbers in cells.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <initializer_list>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "core/text.hpp"

namespace roadpreview::csv {

/// The line without the UTF-8 byte order mark a spreadsheet writes before a CSV's first cell.
inline std::string_view without_byte_order_mark(std::string_view line) {
    constexpr std::string_view kMark = "\xEF\xBB\xBF";
    return line.substr(0, kMark.size()) == kMark ? line.substr(kMark.size()) : line;
}

/// The line's cells, trimmed; a byte order mark before the first is dropped.
inline std::vector<std::string> split(const std::string& line) {
    std::vector<std::string> cells;
    std::stringstream in{std::string(without_byte_order_mark(line))};
    std::string cell;
    while (std::getline(in, cell, ',')) {
        const auto first = cell.find_first_not_of(" \t\r");
        const auto last = cell.find_last_not_of(" \t\r");
        cells.push_back(first == std::string::npos ? "" : cell.substr(first, last - first + 1));
    }
    if (!line.empty() && line.back() == ',') cells.emplace_back();  // getline drops a last, empty cell
    return cells;
}

/// Blank lines and '#' comments.
inline bool skipped(const std::string& line) {
    const auto first = line.find_first_not_of(" \t\r");
    return first == std::string::npos || line[first] == '#';
}

/// Column index of each required name; throws naming `where` and the missing column.
class Header {
public:
    Header() = default;
    Header(const std::vector<std::string>& cells, std::initializer_list<const char*> required, const std::string& where) {
        for (std::size_t i = 0; i < cells.size(); ++i) index_[cells[i]] = i;
        for (const char* name : required)
            if (!index_.count(name)) throw std::runtime_error(where + ": the header has no column '" + name + "'");
    }
    bool empty() const { return index_.empty(); }
    std::size_t at(const std::string& name) const { return index_.at(name); }

private:
    std::map<std::string, std::size_t> index_;
};

inline double finite_cell(const std::vector<std::string>& cells, std::size_t column, const std::string& where,
                          const char* name) {
    const std::optional<double> v = column < cells.size() ? parse_number(cells[column]) : std::nullopt;
    if (!v || !std::isfinite(*v))
        throw std::runtime_error(where + ": expected a finite number in column '" + name + "'");
    return *v;
}

}  // namespace roadpreview::csv
