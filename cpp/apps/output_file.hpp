// SPDX-License-Identifier: BSD-3-Clause
// What the commands that stream lines to -o share: a run that writes nothing leaves no empty output file behind.
#pragma once

#include <filesystem>
#include <string>

namespace roadpreview::cli {

/// Removes `path` when it is a regular file holding nothing; no-op for "" (stdout) and anything else.
inline void remove_if_empty(const std::string& path) {
    namespace fs = std::filesystem;
    std::error_code ec;
    if (!path.empty() && fs::is_regular_file(path, ec) && fs::file_size(path, ec) == 0) fs::remove(path, ec);
}

}  // namespace roadpreview::cli
