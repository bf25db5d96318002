// SPDX-License-Identifier: BSD-3-Clause
// PLY clouds (ascii, binary little and big endian) through PCL's PLY reader; the vertex count of the header is
// checked against the file first, since the reader sizes its buffer from it.
#include "io/cloud_files.hpp"

#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include <pcl/io/ply_io.h>

namespace roadpreview {
namespace {

constexpr std::size_t kMaxHeaderLines = 10000;

struct PlyHeader {
    std::string format;             // ascii, binary_little_endian or binary_big_endian
    std::uint64_t vertices = 0;
    std::uint64_t vertex_bytes = 0;  // binary: bytes per vertex; lists count as their length byte only
    std::uint64_t vertex_values = 0;
    std::uint64_t data_start = 0;
};

std::uint64_t type_bytes(const std::string& type) {
    static const std::map<std::string, std::uint64_t> kBytes = {
        {"char", 1}, {"uchar", 1}, {"int8", 1}, {"uint8", 1}, {"short", 2}, {"ushort", 2}, {"int16", 2},
        {"uint16", 2}, {"int", 4}, {"uint", 4}, {"int32", 4}, {"uint32", 4}, {"float", 4}, {"float32", 4},
        {"double", 8}, {"float64", 8}};
    const auto it = kBytes.find(type);
    return it == kBytes.end() ? 0 : it->second;
}

PlyHeader scan_header(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) fail_file(path, "cannot open file");
    std::string line;
    if (!std::getline(in, line) || line.rfind("ply", 0) != 0) fail_file(path, "not a PLY file (no 'ply' line)");
    PlyHeader h;
    std::string element;
    for (std::size_t n = 0; n < kMaxHeaderLines && std::getline(in, line); ++n) {
        std::istringstream words(line);
        std::string key, a, b;
        words >> key >> a >> b;
        if (key == "format") h.format = a;
        if (key == "element") {
            element = a;
            if (element == "vertex") {
                const bool digits =
                    !b.empty() && b.size() <= 10 && b.find_first_not_of("0123456789") == std::string::npos;
                if (!digits) fail_file(path, "PLY header: the vertex count must be a whole number, got '" + b + "'");
                h.vertices = std::stoull(b);
            }
        }
        if (key == "property" && element == "vertex") {
            const std::uint64_t bytes = type_bytes(a == "list" ? b : a);
            if (bytes == 0) fail_file(path, "PLY header: unknown property type in '" + line + "'");
            h.vertex_bytes += bytes;
            ++h.vertex_values;
        }
        if (key == "end_header") {
            h.data_start = static_cast<std::uint64_t>(in.tellg());
            return h;
        }
    }
    fail_file(path, "not a PLY file (no end_header)");
}

void check_against_file(const std::string& path, const PlyHeader& h) {
    if (h.format != "ascii" && h.format != "binary_little_endian" && h.format != "binary_big_endian")
        fail_file(path, "PLY header: unknown format '" + h.format + "'");
    if (h.vertex_values == 0) fail_file(path, "PLY header: no vertex element with properties");
    const std::uint64_t size = file_size(path);
    const std::uint64_t available = size > h.data_start ? size - h.data_start : 0;
    // An ASCII vertex takes at least one digit and one separator per value.
    const std::uint64_t min_bytes = h.format == "ascii" ? 2 * h.vertex_values : h.vertex_bytes;
    if (h.vertices > available / min_bytes)
        fail_file(path, "its header declares " + std::to_string(h.vertices) + " vertices but the file holds " +
                            std::to_string(available) + " bytes of data (at least " +
                            std::to_string(min_bytes) + " per vertex)");
}

}  // namespace

Frame read_ply(const std::string& path) {
    check_against_file(path, scan_header(path));
    return read_cloud(path, "PLY", [&](pcl::PCLPointCloud2& blob) { return pcl::PLYReader().read(path, blob); });
}

}  // namespace roadpreview
