// SPDX-License-Identifier: BSD-3-Clause
// Internal: whether a path names a file the readers can read to its end. A directory gives a parser's puzzling
// message, a device (/dev/zero) never ends and a FIFO blocks until a writer comes: none is an input.
#pragma once

#include <filesystem>
#include <string>
#include <system_error>

namespace roadpreview {

/// Why `path` is no input file ("no such file", "a directory, not a file", "not a regular file"), or empty when
/// it is a regular file (or a link to one).
inline std::string not_an_input_file(const std::string& path) {
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::file_status status = fs::status(path, ec);
    if (!fs::exists(status)) return "no such file";
    if (fs::is_directory(status)) return "a directory, not a file";
    if (!fs::is_regular_file(status)) return "not a regular file (a device or a pipe is no input)";
    return {};
}

/// Throws Error(path + ": " + reason + ...) when `path` is no input file; `what` names the input ("config file").
template <class Error>
void require_input_file(const std::string& path, const char* what) {
    if (const std::string why = not_an_input_file(path); !why.empty())
        throw Error(path + ": cannot read the " + what + ": " + why);
}

}  // namespace roadpreview
