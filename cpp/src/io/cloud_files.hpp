// SPDX-License-Identifier: BSD-3-Clause
// Point cloud files, one frame each: raw float32 arrays (KITTI .bin, nuScenes .pcd.bin), PCD and PLY. Every
// reader checks the sizes a header declares against the file before it allocates anything.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "roadpreview/io/frame_source.hpp"

namespace pcl {
struct PCLPointCloud2;
}

namespace roadpreview {

[[noreturn]] void fail_file(const std::string& path, const std::string& what);

/// Raw little-endian float32 values, `columns` per point: x, y, z, then intensity (0 when columns == 3).
Frame read_raw_float32(const std::string& path, int columns);

/// PCD (ascii, binary, binary_compressed) through PCL's reader, after checking its header against the file.
Frame read_pcd(const std::string& path);

/// PLY (ascii, binary little or big endian) through PCL's reader, after checking its header against the file.
Frame read_ply(const std::string& path);

/// x, y, z and intensity (0 without that field) of the cloud `read` (a PCL reader, < 0 on failure) gets from
/// the `kind` ("PCD", "PLY") file `path`; PCL's own console messages are silenced (our exception says it).
Frame read_cloud(const std::string& path, const char* kind, const std::function<int(pcl::PCLPointCloud2&)>& read);

/// Size of a file in bytes; throws naming the file when it cannot be read.
std::uint64_t file_size(const std::string& path);

/// The whitespace-separated words of a header line.
std::vector<std::string> header_words(const std::string& line);

/// A header line holding a control character other than tab and carriage return: PCL's readers read such
/// headers out of bounds (found by fuzzing), so both PCD and PLY headers refuse them.
bool holds_control_character(const std::string& line);

/// `text` as a decimal whole number up to `max`: digits only (no sign, exponent or fraction); nullopt else.
std::optional<std::uint64_t> whole_number(const std::string& text, std::uint64_t max);

}  // namespace roadpreview
