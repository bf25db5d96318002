// SPDX-License-Identifier: BSD-3-Clause
// What the commands that stream lines to -o share: a run that writes nothing leaves no empty output file behind.
#pragma once

#include <filesystem>
#include <fstream>
#include <iostream>
#include <stdexcept>
#include <string>
#include <utility>

namespace roadpreview::cli {

/// Removes `path` when it is a regular file holding nothing; no-op for "" (stdout) and anything else — a symbolic
/// link included (-o /dev/stdout, or a link to a file the user keeps: the link itself would go).
inline void remove_if_empty(const std::string& path) {
    namespace fs = std::filesystem;
    std::error_code ec;
    if (!path.empty() && fs::symlink_status(path, ec).type() == fs::file_type::regular && fs::file_size(path, ec) == 0)
        fs::remove(path, ec);
}

/// The stream a command writes its lines to: the file `path`, or stdout for "". On leaving its scope — a finished
/// run, an error, a failure before the first line — the file is closed, and removed if nothing was written to it.
class OutputFile {
public:
    explicit OutputFile(std::string path) : path_(std::move(path)) {
        if (path_.empty()) return;
        file_.open(path_);
        if (!file_) throw std::runtime_error(path_ + ": cannot open the output file for writing");
    }
    OutputFile(const OutputFile&) = delete;
    OutputFile& operator=(const OutputFile&) = delete;
    ~OutputFile() {
        if (path_.empty()) return;
        file_.close();
        remove_if_empty(path_);
    }
    std::ostream& stream() { return path_.empty() ? std::cout : file_; }
    /// Flushes, and names the output in the error when the stream failed (a full disk shows here).
    void check_written() {
        stream().flush();
        if (!stream()) throw std::runtime_error((path_.empty() ? "stdout" : path_) + ": write failed");
    }

private:
    std::string path_;
    std::ofstream file_;
};

}  // namespace roadpreview::cli
