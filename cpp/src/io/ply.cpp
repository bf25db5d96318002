// SPDX-License-Identifier: BSD-3-Clause
// PLY clouds (ascii, binary little and big endian) through PCL's PLY reader. The header is checked line by line
// first: PCL takes element counts and obj_info dimensions on trust (it sizes its buffers from them) and, built
// with assertions as Debian ships it, aborts on a vertex that does not fit its buffer (fuzz findings).
#include "io/cloud_files.hpp"

#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <vector>

#include <pcl/io/ply_io.h>

#include "core/text.hpp"

namespace roadpreview {
namespace {

constexpr std::size_t kMaxHeaderLines = 10000;
// PCL keeps counts and dimensions as 32-bit numbers (obj_info ones through atoi: signed).
constexpr std::uint64_t kMaxCount = std::numeric_limits<std::uint32_t>::max();
constexpr std::uint64_t kMaxDimension = std::numeric_limits<std::int32_t>::max();

struct PlyElement {
    std::string name;
    std::uint64_t count = 0;
    std::uint64_t binary_bytes = 0;  // per entry; a list counts as its length field only
    std::uint64_t values = 0;        // per entry: scalars and lists (an ASCII value takes at least 2 bytes)
    std::set<std::string> properties;
};

struct PlyHeader {
    std::string format;  // ascii, binary_little_endian or binary_big_endian
    std::vector<PlyElement> elements;
    // The cloud's width and height as PCL sets them: obj_info num_cols and num_rows, unless the vertex element
    // comes while either is 0 (then its count × 1). PCL allocates width × height vertices.
    std::uint64_t width = 0, height = 0;
    std::uint64_t data_start = 0;

    const PlyElement* element(const std::string& name) const {
        for (const PlyElement& e : elements)
            if (e.name == name) return &e;
        return nullptr;
    }
};

std::uint64_t type_bytes(const std::string& type) {
    static const std::map<std::string, std::uint64_t> kBytes = {
        {"char", 1}, {"uchar", 1}, {"int8", 1}, {"uint8", 1}, {"short", 2}, {"ushort", 2}, {"int16", 2},
        {"uint16", 2}, {"int", 4}, {"uint", 4}, {"int32", 4}, {"uint32", 4}, {"float", 4}, {"float32", 4},
        {"double", 8}, {"float64", 8}};
    const auto it = kBytes.find(type);
    return it == kBytes.end() ? 0 : it->second;
}

bool is_list_length_type(const std::string& type) {
    return type == "uchar" || type == "uint8" || type == "ushort" || type == "uint16" || type == "uint" ||
           type == "uint32";
}

// One header line, its number and text for the messages.
struct Line {
    const std::string& path;
    std::size_t number;
    const std::string& text;

    [[noreturn]] void fail(const std::string& what) const {
        fail_file(path, "PLY header line " + std::to_string(number) + " '" + text.substr(0, 80) + "': " + what);
    }
};

void read_format(const Line& line, const std::vector<std::string>& w, PlyHeader& h) {
    if (!h.format.empty()) line.fail("a second format line");
    if (w.size() != 3) line.fail("expected 'format ascii|binary_little_endian|binary_big_endian 1.0'");
    if (w[1] != "ascii" && w[1] != "binary_little_endian" && w[1] != "binary_big_endian")
        line.fail("unknown format '" + w[1] + "' (ascii, binary_little_endian or binary_big_endian)");
    if (w[2] != "1.0") line.fail("unsupported version '" + w[2] + "' (1.0)");
    h.format = w[1];
}

void read_element(const Line& line, const std::vector<std::string>& w, PlyHeader& h) {
    if (w.size() != 3) line.fail("expected 'element NAME COUNT'");
    if (h.element(w[1])) line.fail("element '" + w[1] + "' is declared twice");
    const auto count = whole_number(w[2], kMaxCount);
    if (!count) line.fail("the count must be a whole number from 0 to " + std::to_string(kMaxCount));
    h.elements.push_back({w[1], *count, 0, 0, {}});
    if (w[1] == "vertex" && (h.width == 0 || h.height == 0)) h.width = *count, h.height = 1;
}

void read_property(const Line& line, const std::vector<std::string>& w, PlyHeader& h) {
    if (h.elements.empty()) line.fail("a property before any element");
    PlyElement& e = h.elements.back();
    const bool list = w.size() > 1 && w[1] == "list";
    if (w.size() != (list ? 5u : 3u)) line.fail("expected 'property TYPE NAME' or 'property list UINT TYPE NAME'");
    if (list && !is_list_length_type(w[2])) line.fail("a list length must be uchar, ushort or uint, got '" + w[2] + "'");
    if (list && e.name == "vertex")  // PCL sizes every vertex by the first one's lists and aborts on a longer one
        line.fail("list properties of vertices are not supported");
    const std::string& type = w[w.size() - 2];
    if (type_bytes(type) == 0) line.fail("unknown property type '" + type + "'");
    if (!e.properties.insert(w.back()).second)
        line.fail("property '" + w.back() + "' of element '" + e.name + "' is declared twice");
    e.binary_bytes += type_bytes(list ? w[2] : type);
    ++e.values;
}

// obj_info num_cols / num_rows: PCL takes them as the cloud's width and height and allocates by them.
void read_obj_info(const Line& line, const std::vector<std::string>& w, PlyHeader& h) {
    if (w.size() < 2 || (w[1] != "num_cols" && w[1] != "num_rows")) return;
    const auto v = w.size() == 3 ? whole_number(w[2], kMaxDimension) : std::nullopt;
    if (!v) line.fail(w[1] + " must be a whole number from 0 to " + std::to_string(kMaxDimension));
    (w[1] == "num_cols" ? h.width : h.height) = *v;
}

PlyHeader scan_header(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) fail_file(path, "cannot open file");
    std::string text;
    if (!std::getline(in, text) || (text != "ply" && text != "ply\r"))
        fail_file(path, "not a PLY file (the first line is not 'ply')");
    PlyHeader h;
    for (std::size_t number = 2; number <= kMaxHeaderLines && std::getline(in, text); ++number) {
        if (!text.empty() && text.back() == '\r') text.pop_back();
        const auto w = header_words(text);
        if (holds_control_character(text))
            fail_file(path, "PLY header line " + std::to_string(number) + " '" + (w.empty() ? "" : w[0]) +
                                " …' holds a control character (the header is text)");
        const Line line{path, number, text};
        // PCL reads a line's first word from its first character (a leading "\r" failed an assertion; fuzzing).
        if (!text.empty() && (text[0] == ' ' || text[0] == '\t' || text.find('\r') != std::string::npos))
            line.fail("begins with a blank or holds a carriage return before its end, which PCL cannot read");
        if (w.empty() || w[0] == "comment") continue;
        if (w[0] == "format") read_format(line, w, h);
        else if (w[0] == "element") read_element(line, w, h);
        else if (w[0] == "property") read_property(line, w, h);
        else if (w[0] == "obj_info") read_obj_info(line, w, h);
        else if (w[0] == "end_header" && w.size() == 1) {
            h.data_start = static_cast<std::uint64_t>(in.tellg());
            return h;
        } else
            line.fail("not a header line (format, element, property, comment, obj_info or end_header)");
    }
    fail_file(path, "not a PLY file (no end_header within " + std::to_string(kMaxHeaderLines) + " lines)");
}

void check_against_file(const std::string& path, const PlyHeader& h) {
    if (h.format.empty()) fail_file(path, "PLY header: no format line");
    const PlyElement* vertex = h.element("vertex");
    if (!vertex || vertex->values == 0) fail_file(path, "PLY header: no vertex element with properties");
    const std::uint64_t size = file_size(path);
    const std::uint64_t available = size > h.data_start ? size - h.data_start : 0;
    std::uint64_t needed = 0;  // counts ≤ 2^32 times ≤ 10^4 properties × 8 bytes, summed: no overflow
    for (const PlyElement& e : h.elements) {
        if (e.count > 0 && e.values == 0)  // PCL would reserve by the count of an element it reads nothing of
            fail_file(path, "PLY header: element '" + e.name + "' has " + std::to_string(e.count) +
                                " entries but no properties");
        // An ASCII value takes at least one digit and one separator.
        const std::uint64_t bytes = h.format == "ascii" ? 2 * e.values : e.binary_bytes;
        needed += e.count * bytes;
        if (needed > available)
            fail_file(path, "its header declares " + std::to_string(e.count) +
                                (&e == vertex ? std::string(" vertices") : " '" + e.name + "' entries") +
                                " but the file holds " + std::to_string(available) + " bytes of data (at least " +
                                std::to_string(bytes) + " per " + (&e == vertex ? "vertex" : "entry") +
                                (needed > e.count * bytes ? ", after the elements before it" : "") + ")");
    }
    // PCL allocates width × height vertices (obj_info can set them), writes the vertices into them, and then,
    // with a range grid, gives one point per grid entry.
    const PlyElement* grid = h.element("range_grid");
    const std::uint64_t points = grid ? grid->count : vertex->count;
    if (h.width * h.height != points || vertex->count > points)
        fail_file(path, "PLY header: the cloud is " + std::to_string(h.width) + " × " + std::to_string(h.height) +
                            " points (obj_info num_cols × num_rows, else the vertex count) but the file holds " +
                            std::to_string(vertex->count) + " vertices" +
                            (grid ? " and " + std::to_string(grid->count) + " range_grid entries" : ""));
}

// PCL reads a word that is no number in an ASCII body as NaN, and the cloud loses the point unsaid (an ASCII PCD's
// reader refuses it): every word of the body must be a number.
void check_ascii_numbers(const std::string& path, const PlyHeader& h) {
    std::ifstream in(path, std::ios::binary);
    in.seekg(static_cast<std::streamoff>(h.data_start));
    std::string line, word;
    for (std::uint64_t number = 1; std::getline(in, line); ++number) {
        std::istringstream words(line);
        while (words >> word) {
            if (!parse_number(word))
                fail_file(path, "PLY data: '" + word.substr(0, 40) + "' on data line " + std::to_string(number) +
                                    " is not a number");
        }
    }
}

}  // namespace

Frame read_ply(const std::string& path) {
    const PlyHeader header = scan_header(path);
    check_against_file(path, header);
    if (header.format == "ascii") check_ascii_numbers(path, header);
    return read_cloud(path, "PLY", [&](pcl::PCLPointCloud2& blob) { return pcl::PLYReader().read(path, blob); });
}

}  // namespace roadpreview
