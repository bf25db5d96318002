// SPDX-License-Identifier: BSD-3-Clause
// The file parsers read paths, so each fuzz input is written to a scratch file first (one per process, in
// the fuzzer's working directory, reused for every input).
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iterator>
#include <stdexcept>
#include <string>

#include <unistd.h>

#include <roadpreview/io/readers.hpp>

namespace roadpreview_fuzz {

/// Writes `data` to a file named scratch_<pid><suffix> and returns its path.
inline std::string scratch_file(const std::uint8_t* data, std::size_t size, const std::string& suffix) {
    static const std::string base = "scratch_" + std::to_string(getpid());
    const std::string path = base + suffix;
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) std::perror(("scratch_file: " + path).c_str()), std::abort();
    if (size && std::fwrite(data, 1, size, f) != size) std::perror(("scratch_file: " + path).c_str()), std::abort();
    std::fclose(f);
    return path;
}

/// The process's open file descriptors.
inline std::ptrdiff_t open_descriptors() {
    return std::distance(std::filesystem::directory_iterator("/proc/self/fd"), std::filesystem::directory_iterator{});
}

/// Runs `parse`; the errors a parser documents (std::runtime_error for bad files, std::invalid_argument for bad
/// values) are expected. Anything else is a finding for libFuzzer: a crash, a sanitizer report, an exception of
/// another type (std::bad_alloc from a size taken on trust, a library's internal exception), or files left open
/// (on an error path, a descriptor per bad file: a long-lived process runs out). Descriptors are counted against
/// the first input's with some room, which a library opening a file once for good may take.
template <typename Parse>
void expect_clean_errors(Parse parse) {
    static const std::ptrdiff_t first = open_descriptors();
    try {
        parse();
    } catch (const std::runtime_error&) {
    } catch (const std::invalid_argument&) {
    }
    if (open_descriptors() > first + 32) std::fputs("the parsers leave files open\n", stderr), std::abort();
}

/// Reads `data` as a frame file with the reader `suffix` picks (".pcd", ".ply"); a frame with more points than
/// the file has bytes must have been refused.
inline void read_cloud_file(const std::uint8_t* data, std::size_t size, const std::string& suffix) {
    const std::string path = scratch_file(data, size, suffix);
    expect_clean_errors([&] {
        const roadpreview::Frame frame = roadpreview::read_frame(path);
        if (frame.points.rows() > static_cast<Eigen::Index>(size)) std::abort();
    });
}

}  // namespace roadpreview_fuzz
