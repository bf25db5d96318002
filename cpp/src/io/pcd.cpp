// SPDX-License-Identifier: BSD-3-Clause
// PCD files through PCL's reader. PCL sizes its buffers from the header's WIDTH × HEIGHT × point size and
// turns an unparsable ASCII value into 0, so the header and the data are checked against the file first.
#include "io/cloud_files.hpp"

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <set>
#include <vector>

#include <pcl/common/io.h>
#include <pcl/console/print.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include "core/text.hpp"

namespace roadpreview {
namespace {

constexpr std::size_t kMaxHeaderBytes = 1 << 20;
// LZF encodes at most 264 repeated bytes in a 3-byte back reference: no stream inflates by more than ~90×.
constexpr std::uint64_t kMaxLzfRatio = 100;
constexpr std::uint64_t kMaxValuesPerField = 1 << 16;  // descriptors (e.g. FPFH's 33) stay far below

struct PcdHeader {
    std::uint64_t width = 0, height = 1, points = 0;
    bool has_width = false, has_points = false;
    std::uint64_t point_bytes = 0;  // Σ SIZE × COUNT
    std::uint64_t values = 0;       // Σ COUNT: numbers per ASCII line
    std::string data;               // ascii, binary or binary_compressed
    std::uint64_t data_start = 0;   // byte offset of the data
};

// A header count: decimal digits only, below 2^32 as PCL stores it (no sign, exponent or fraction).
std::uint64_t header_count(const std::string& path, const std::string& key, const std::string& text) {
    const auto v = whole_number(text, std::numeric_limits<std::uint32_t>::max());
    if (!v) fail_file(path, "PCD header " + key + " must be a whole number from 0 to 4294967295, got '" + text + "'");
    return *v;
}

// PCL 1.13 stops reading a header at the first line it does not know and then dereferences a null pointer
// reading the data: such a line is refused here (exact keywords; PCL would also take "FIELDSX" for FIELDS).
bool is_header_keyword(const std::string& word) {
    static const std::set<std::string> kKeywords = {"VERSION", "FIELDS", "COLUMNS", "SIZE", "TYPE", "COUNT",
                                                    "WIDTH", "HEIGHT", "VIEWPOINT", "POINTS", "DATA"};
    return kKeywords.count(word) > 0;
}

// TYPE gives one of I, U, F per field with a size PCL knows for it (PCL throws its own exceptions otherwise).
void check_types(const std::string& path, const std::vector<std::string>& types,
                 const std::vector<std::uint64_t>& sizes) {
    if (types.size() != sizes.size())
        fail_file(path, "PCD header: TYPE must give one letter per field (" + std::to_string(sizes.size()) +
                            " FIELDS)");
    for (std::size_t i = 0; i < types.size(); ++i) {
        const std::uint64_t n = sizes[i];
        const bool integer = types[i] == "I" || types[i] == "U";
        const bool ok = types[i] == "F" ? (n == 4 || n == 8) : integer && (n == 1 || n == 2 || n == 4 || n == 8);
        if (!ok)
            fail_file(path, "PCD header: field " + std::to_string(i + 1) + " has TYPE '" + types[i] + "' and SIZE " +
                                std::to_string(n) + " (F: 4 or 8 bytes; I, U: 1, 2, 4 or 8)");
    }
}

void read_sizes(const std::string& path, const std::vector<std::string>& w, std::vector<std::uint64_t>& out) {
    out.clear();
    for (std::size_t i = 1; i < w.size(); ++i) out.push_back(header_count(path, w[0], w[i]));
}

PcdHeader scan_header(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) fail_file(path, "cannot open file");
    PcdHeader h;
    std::vector<std::uint64_t> sizes, counts;
    std::vector<std::string> types;
    bool has_types = false;
    std::size_t fields = 0;
    std::set<std::string> seen;
    for (std::string line; std::getline(in, line);) {
        if (static_cast<std::size_t>(in.tellg()) > kMaxHeaderBytes) break;
        const auto w = header_words(line);
        // PCL skips an empty line but crashes on one of blanks only, as a CRLF file's blank line "\r" (found by
        // fuzzing: a null dereference in pcl::PCDReader::read).
        if (w.empty() && !line.empty())
            fail_file(path, "PCD header: a line of only spaces, tabs or a carriage return before DATA (PCL cannot "
                            "read such a header; make the line empty or remove it)");
        if (w.empty() || w[0][0] == '#') continue;
        if (holds_control_character(line))  // PCL reads such a header out of bounds (found by fuzzing)
            fail_file(path, "PCD header: line '" + w[0] + " …' holds a control character (the header is text)");
        if (!is_header_keyword(w[0]))
            fail_file(path, "PCD header: unknown line '" + line.substr(0, 80) + "' before DATA");
        // PCL adds a second FIELDS line's fields to the first's and reads past its offsets (found by fuzzing).
        if (!seen.insert(w[0]).second) fail_file(path, "PCD header: a second " + w[0] + " line (each keyword once)");
        if (w[0] == "FIELDS" || w[0] == "COLUMNS") {
            fields = w.size() - 1;
            // PCL reads the first field of a name twice and leaves the second unread: y came from z's column.
            const std::set<std::string> names(w.begin() + 1, w.end());
            if (names.size() != fields) fail_file(path, "PCD header: a field named twice in '" + line.substr(0, 80) + "'");
        }
        if (w[0] == "SIZE") read_sizes(path, w, sizes);
        if (w[0] == "COUNT") read_sizes(path, w, counts);
        if (w[0] == "TYPE") types.assign(w.begin() + 1, w.end()), has_types = true;
        if (w[0] == "WIDTH" && w.size() > 1) h.width = header_count(path, "WIDTH", w[1]), h.has_width = true;
        if (w[0] == "HEIGHT" && w.size() > 1) h.height = header_count(path, "HEIGHT", w[1]);
        if (w[0] == "POINTS" && w.size() > 1) h.points = header_count(path, "POINTS", w[1]), h.has_points = true;
        if (w[0] != "DATA") continue;
        h.data = w.size() > 1 ? w[1] : "";
        h.data_start = static_cast<std::uint64_t>(in.tellg());
        break;
    }
    if (h.data.empty() || fields == 0) fail_file(path, "not a PCD file (no valid header with FIELDS and DATA)");
    if (sizes.size() != fields || (!counts.empty() && counts.size() != fields))
        fail_file(path, "PCD header: SIZE and COUNT must give one number per field (" + std::to_string(fields) +
                            " FIELDS)");
    if (has_types) check_types(path, types, sizes);
    for (std::size_t i = 0; i < fields && !has_types; ++i)  // PCL reads 4 bytes of each: past the data (fuzzing)
        if (sizes[i] != 4)
            fail_file(path, "PCD header: without a TYPE line PCL reads every field as a 4-byte float, but field " +
                                std::to_string(i + 1) + " has SIZE " + std::to_string(sizes[i]));
    for (std::size_t i = 0; i < fields; ++i) {
        const std::uint64_t count = counts.empty() ? 1 : counts[i];
        if (sizes[i] > 8 || count > kMaxValuesPerField)
            fail_file(path, "PCD header: field " + std::to_string(i + 1) + " has SIZE " + std::to_string(sizes[i]) +
                                " and COUNT " + std::to_string(count) + " (at most 8 bytes and " +
                                std::to_string(kMaxValuesPerField) + " values)");
        h.point_bytes += sizes[i] * count;
        h.values += count;
    }
    if (!h.has_points) h.points = h.width * h.height;
    if (!h.has_width) h.width = h.points, h.height = 1;
    if (h.width * h.height != h.points)
        fail_file(path, "PCD header: WIDTH × HEIGHT = " + std::to_string(h.width * h.height) + " but POINTS = " +
                            std::to_string(h.points));
    return h;
}

std::string declared(const PcdHeader& h) {
    return "its header declares " + std::to_string(h.points) + " points of " + std::to_string(h.point_bytes) +
           " bytes";
}

bool is_number(const std::string& token) { return parse_number(token).has_value(); }

// Every data line holds exactly `values` numbers, and there is one line per declared point.
void check_ascii(const std::string& path, const PcdHeader& h) {
    std::ifstream in(path, std::ios::binary);
    in.seekg(static_cast<std::streamoff>(h.data_start));
    std::uint64_t lines = 0, line_number = 0;
    for (std::string line; std::getline(in, line);) {
        ++line_number;
        const auto w = header_words(line);
        if (w.empty()) continue;
        bool ok = w.size() == h.values;
        for (std::size_t i = 0; ok && i < w.size(); ++i) ok = is_number(w[i]);
        if (!ok)
            fail_file(path, "PCD data line " + std::to_string(line_number) + " after the header is not " +
                                std::to_string(h.values) + " numbers: '" + line.substr(0, 80) + "'");
        if (++lines > h.points) break;
    }
    if (lines != h.points)
        fail_file(path, declared(h) + " but its ASCII data holds " +
                            (lines > h.points ? "more" : std::to_string(lines)) + " lines");
}

// PCL's header reader does not stop at DATA: it goes on through lines that begin like a comment or VERSION and
// takes a line that begins like another keyword ("COLUMNS…", "POINTS…", prefixes are enough) as header, so the
// first bytes of binary data can redefine the fields it then reads the data by (found by fuzzing).
void check_after_data(const std::string& path, const PcdHeader& h) {
    static const char* const kRedefining[] = {"FIELDS", "COLUMNS", "SIZE", "TYPE", "COUNT", "WIDTH",
                                              "HEIGHT", "VIEWPOINT", "POINTS", "DATA"};
    std::ifstream in(path, std::ios::binary);
    in.seekg(static_cast<std::streamoff>(h.data_start));
    for (std::string line; std::getline(in, line);) {
        if (line.empty()) continue;
        const auto w = header_words(line);
        if (w.empty()) return;
        if (w[0][0] == '#' || w[0].rfind("VERSION", 0) == 0) continue;
        for (const char* keyword : kRedefining)
            if (w[0].rfind(keyword, 0) == 0)
                fail_file(path, std::string("PCD data: the bytes after the DATA line begin like a '") + keyword +
                                    "' line, which PCL would read as part of the header");
        return;
    }
}

void check_against_file(const std::string& path, const PcdHeader& h) {
    check_after_data(path, h);
    const std::uint64_t size = file_size(path);
    const std::uint64_t available = size > h.data_start ? size - h.data_start : 0;
    if (h.data == "ascii") return check_ascii(path, h);
    if (h.point_bytes == 0) fail_file(path, "PCD header: the fields' SIZE × COUNT add up to 0 bytes per point");
    const std::uint64_t max_points = available / h.point_bytes;
    if (h.data == "binary") {
        if (h.points > max_points)
            fail_file(path, declared(h) + " (" + std::to_string(h.points * h.point_bytes) +
                                " bytes) but the file holds " + std::to_string(available) + " bytes of data");
        return;
    }
    if (h.data != "binary_compressed") fail_file(path, "PCD header: unknown DATA type '" + h.data + "'");
    std::uint32_t sizes[2] = {0, 0};  // compressed, uncompressed (little endian, as PCL writes them)
    std::ifstream in(path, std::ios::binary);
    in.seekg(static_cast<std::streamoff>(h.data_start));
    if (available < 8 || !in.read(reinterpret_cast<char*>(sizes), sizeof sizes))
        fail_file(path, "PCD binary_compressed data is missing its sizes");
    if (sizes[0] > available - 8)
        fail_file(path, "PCD compressed data of " + std::to_string(sizes[0]) + " bytes runs past the end of the file");
    if (sizes[1] != h.points * h.point_bytes || sizes[1] > kMaxLzfRatio * sizes[0] + 64)
        fail_file(path, declared(h) + " but its compressed data unpacks to " + std::to_string(sizes[1]) + " bytes");
}

}  // namespace

Frame read_pcd(const std::string& path) {
    check_against_file(path, scan_header(path));
    return read_cloud(path, "PCD", [&](pcl::PCLPointCloud2& blob) { return pcl::PCDReader().read(path, blob); });
}

Frame read_cloud(const std::string& path, const char* kind, const std::function<int(pcl::PCLPointCloud2&)>& read) {
    pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);  // errors are reported by our exception
    pcl::PCLPointCloud2 blob;
    if (read(blob) < 0) fail_file(path, std::string("not a readable ") + kind + " file (corrupt header or data)");
    for (const char* axis : {"x", "y", "z"}) {
        const int field = pcl::getFieldIndex(blob, axis);
        if (field < 0) fail_file(path, std::string("the cloud has no '") + axis + "' field");
        // PCL's conversion leaves a field of another type unread: the points would all be 0 (8-byte doubles too).
        if (blob.fields[static_cast<std::size_t>(field)].datatype != pcl::PCLPointField::FLOAT32)
            fail_file(path, std::string("the '") + axis + "' field is not a 4-byte float (PCD: TYPE F, SIZE 4; " +
                                "PLY: float or float32), which is what the reader takes");
    }
    const std::size_t expected = static_cast<std::size_t>(blob.width) * blob.height * blob.point_step;
    if (blob.data.size() != expected)  // a PLY camera element or range grid can set other dimensions
        fail_file(path, "the cloud's data (" + std::to_string(blob.data.size()) + " bytes) is not the " +
                            std::to_string(blob.width) + " × " + std::to_string(blob.height) + " points of " +
                            std::to_string(blob.point_step) + " bytes its header declares");
    Frame f;
    f.source = path;
    if (expected == 0) return f;  // PCL's conversion would bind a reference to the first of no points
    pcl::PointCloud<pcl::PointXYZI> cloud;
    pcl::fromPCLPointCloud2(blob, cloud);
    const bool has_intensity = pcl::getFieldIndex(blob, "intensity") >= 0;
    f.points.resize(static_cast<Eigen::Index>(cloud.size()), 4);
    constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
    for (std::size_t i = 0; i < cloud.size(); ++i) {
        const auto& p = cloud[i];
        // Exactly (0, 0, 0) is no return: drivers write it where PCL writes NaN (an organized cloud keeps every
        // row), and no sensor measures its own origin. Read as a point, it was a ground at the sensor.
        const bool placeholder = p.x == 0.0f && p.y == 0.0f && p.z == 0.0f;
        f.points.row(static_cast<Eigen::Index>(i)) << (placeholder ? kNaN : p.x), (placeholder ? kNaN : p.y),
            (placeholder ? kNaN : p.z), has_intensity ? p.intensity : 0.0f;
    }
    return f;
}

}  // namespace roadpreview
