// SPDX-License-Identifier: BSD-3-Clause
// Frame files whose headers lie, raw float32 layouts, PLY clouds and sequence breaks in file lists.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>

#include <roadpreview/io/readers.hpp>

namespace rp = roadpreview;
namespace fs = std::filesystem;

namespace {

fs::path scratch(const std::string& name) {
    const fs::path dir = fs::temp_directory_path() / "roadpreview_cloud_files_test";
    fs::create_directories(dir);
    return dir / name;
}

std::string written(const std::string& name, const std::string& bytes) {
    const fs::path p = scratch(name);
    std::ofstream(p, std::ios::binary) << bytes;
    return p.string();
}

std::string error_of(const std::string& path, int columns = 0) {
    try {
        rp::read_frame(path, columns);
    } catch (const std::runtime_error& e) {
        return e.what();
    }
    return "";
}

std::string pcd_header(const std::string& width, const std::string& points, const std::string& data) {
    return "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH " + width +
           "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + points + "\nDATA " + data + "\n";
}

void expect_error(const std::string& path, const std::string& words) {
    const std::string err = error_of(path);
    EXPECT_NE(err.find(path), std::string::npos) << err;
    EXPECT_NE(err.find(words), std::string::npos) << err;
}

}  // namespace

TEST(CloudFiles, PcdHeaderClaimingMorePointsThanTheFileHoldsFailsBeforeAllocating) {
    const std::string header = pcd_header("200000000", "200000000", "binary");
    const std::string path = written("liar.pcd", header + std::string(200 - header.size(), '\0'));
    expect_error(path, "declares 200000000 points of 12 bytes");
}

TEST(CloudFiles, NegativeAndHugeWidthsAreHeaderErrors) {
    expect_error(written("negative.pcd", pcd_header("-5", "5", "binary") + std::string(60, '\0')), "WIDTH");
    expect_error(written("huge.pcd", pcd_header("4e9", "4000000000", "binary") + std::string(60, '\0')), "WIDTH");
    expect_error(written("mismatch.pcd", pcd_header("4", "5", "binary") + std::string(60, '\0')), "POINTS = 5");
}

TEST(CloudFiles, ZeroPlaceholdersOfACloudAreNoReturns) {
    // An organized cloud's driver writes (0, 0, 0) where no return came back: its rows stay, as NaN. A point with
    // one or two coordinates 0 is a point.
    const std::string header = pcd_header("3", "3", "ascii");
    const auto f = rp::read_frame(written("placeholders.pcd", header + "0 0 0\n0 0 1\n1 0 0\n"));
    ASSERT_EQ(f.points.rows(), 3);
    EXPECT_TRUE(f.points.row(0).head<3>().array().isNaN().all());
    EXPECT_EQ(f.points(1, 2), 1.0f);
    EXPECT_EQ(f.points(2, 0), 1.0f);
}

TEST(CloudFiles, UnknownPcdHeaderLinesAreErrorsNotPclCrashes) {
    // PCL stops at such a line and reads the data without fields (a null dereference; found by fuzzing).
    const std::string header = pcd_header("2", "2", "binary");
    const std::size_t fields = header.find("FIELDS");
    const std::string junk = header.substr(0, fields) + "VIEWPOI 0.7\n" + header.substr(fields);
    expect_error(written("junk.pcd", junk + std::string(24, '\0')), "unknown line 'VIEWPOI 0.7'");
    EXPECT_EQ(rp::read_frame(written("fine.pcd", header + std::string(24, '\0'))).points.rows(), 2);
    // PCL throws exceptions of its own for a TYPE letter or size it does not know.
    std::string bad_type = header;
    bad_type.replace(bad_type.find("TYPE F F F"), 10, "TYPE F 1F F");
    expect_error(written("type.pcd", bad_type + std::string(24, '\0')), "TYPE '1F'");
    std::string bad_size = header;
    bad_size.replace(bad_size.find("SIZE 4 4 4"), 10, "SIZE 4 3 4");
    expect_error(written("size.pcd", bad_size + std::string(24, '\0')), "TYPE 'F' and SIZE 3");
    // A control character in a header line: PCL read past the fields (a crash under ASan; found by fuzzing).
    std::string control = header;
    control.replace(control.find("FIELDS x"), 8, std::string("FIELDS x\x14\0", 10));
    expect_error(written("control.pcd", control + std::string(24, '\0')), "holds a control character");
    // PCL reads on past DATA while lines look like header lines: binary data beginning "COLUMNS…" redefined the
    // fields and PCL read out of bounds (an ASan SEGV; found by fuzzing). A comment-like start is harmless.
    expect_error(written("columns.pcd", header + "COLUMNS~\x97SB\n" + std::string(11, '\0')),
                 "the bytes after the DATA line begin like a 'COLUMNS' line");
    expect_error(written("points.pcd", header + "#\nPOINTS 9\n" + std::string(12, '\0')), "begin like a 'POINTS' line");
    EXPECT_EQ(rp::read_frame(written("hash.pcd", header + "#\n" + std::string(22, '\0'))).points.rows(), 2);
    // A second FIELDS line: PCL adds its fields to the first's and read past them (an ASan SEGV; found by fuzzing).
    const std::string twice = header.substr(0, fields) + "FIELDS a b c d e\n" + header.substr(fields);
    expect_error(written("twice.pcd", twice + std::string(24, '\0')), "a second FIELDS line");
    expect_error(written("heights.pcd", header.substr(0, fields) + "HEIGHT 1\n" + header.substr(fields) +
                                            std::string(24, '\0')),
                 "a second HEIGHT line");
    // A header line of blanks only: PCL dereferenced a null pointer (a crash of the CLI; found by fuzzing). A blank
    // line of a CRLF file is one. An empty line PCL skips, and so do we.
    for (const std::string blank : {" ", "\t", "\r"})
        expect_error(written("blank.pcd", header.substr(0, fields) + blank + "\n" + header.substr(fields) +
                                              std::string(24, '\0')),
                     "a line of only spaces, tabs or a carriage return before DATA");
    EXPECT_EQ(rp::read_frame(written("empty_line.pcd", header.substr(0, fields) + "\n" + header.substr(fields) +
                                                           std::string(24, '\0')))
                  .points.rows(),
              2);
}

// Fields PCL would read as what they are not (found by fuzzing): without a TYPE line every field is a 4-byte float
// to PCL whatever its SIZE (a SIZE of 1 or 2 read past the data), and x, y, z of another type (8-byte doubles)
// were left unread, every point 0.
TEST(CloudFiles, PcdFieldsMustBeWhatPclReadsThemAs) {
    const std::string untyped = "VERSION 0.7\nFIELDS x y z\nSIZE 4 1 1\nWIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA binary\n";
    expect_error(written("untyped.pcd", untyped + std::string(12, '\1')),
                 "without a TYPE line PCL reads every field as a 4-byte float, but field 2 has SIZE 1");
    const std::string floats = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA binary\n";
    const float xyz[3] = {1.5f, -2.0f, 3.25f};
    const std::string xyz_bytes(reinterpret_cast<const char*>(xyz), sizeof xyz);
    const rp::Frame f = rp::read_frame(written("untyped_floats.pcd", floats + xyz_bytes));
    ASSERT_EQ(f.points.rows(), 1);
    EXPECT_EQ(f.points(0, 2), 3.25f);
    std::string doubles = pcd_header("1", "1", "binary");
    doubles.replace(doubles.find("SIZE 4 4 4"), 10, "SIZE 8 8 8");
    expect_error(written("doubles.pcd", doubles + std::string(24, '\1')), "the 'x' field is not a 4-byte float");
}

TEST(CloudFiles, AsciiPcdLinesMustBeNumbers) {
    const std::string good = written("good.pcd", pcd_header("2", "2", "ascii") + "1 2 3\n4 5.5 nan\n");
    const rp::Frame f = rp::read_frame(good);
    ASSERT_EQ(f.points.rows(), 2);
    EXPECT_FLOAT_EQ(f.points(1, 1), 5.5f);
    expect_error(written("words.pcd", pcd_header("2", "2", "ascii") + "1 2 3\nfoo bar baz\n"), "'foo bar baz'");
    expect_error(written("short.pcd", pcd_header("3", "3", "ascii") + "1 2 3\n4 5 6\n"), "holds 2 lines");
    expect_error(written("ascii_columns.pcd", pcd_header("1", "1", "ascii") + "1 2\n"), "not 3 numbers");
}

TEST(CloudFiles, CompressedPcdSizesAreChecked) {
    std::string sizes(8, '\0');
    const std::uint32_t compressed = 1000000, raw = 24;
    std::memcpy(sizes.data(), &compressed, 4);
    std::memcpy(sizes.data() + 4, &raw, 4);
    expect_error(written("lzf.pcd", pcd_header("2", "2", "binary_compressed") + sizes + "abc"), "runs past the end");
}

TEST(CloudFiles, RawFloat32FilesTakeAColumnCount) {
    std::string bytes;
    for (float v : {1.f, 2.f, 3.f, 9.f, 7.f, 4.f, 5.f, 6.f, 8.f, 7.f})
        bytes.append(reinterpret_cast<const char*>(&v), sizeof v);
    const std::string path = written("sweep.pcd.bin", bytes);
    EXPECT_EQ(rp::raw_columns(path), 5);  // nuScenes
    EXPECT_EQ(rp::raw_columns(scratch("000000.bin").string()), 4);
    const rp::Frame f = rp::read_frame(path);
    ASSERT_EQ(f.points.rows(), 2);
    EXPECT_FLOAT_EQ(f.points(1, 0), 4.f);
    EXPECT_FLOAT_EQ(f.points(1, 3), 8.f);  // intensity; the fifth column (ring) is dropped
    const rp::Frame xyz = rp::read_frame(written("xyz.bin", bytes.substr(0, 24)), 3);
    ASSERT_EQ(xyz.points.rows(), 2);
    EXPECT_FLOAT_EQ(xyz.points(1, 2), 4.f);
    EXPECT_FLOAT_EQ(xyz.points(1, 3), 0.f);
    EXPECT_NE(error_of(path, 4).find("multiple of 16"), std::string::npos);
}

TEST(CloudFiles, PlyVertexCountIsCheckedAgainstTheFile) {
    expect_error(written("liar.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 200000000\n"
                                     "property float x\nproperty float y\nproperty float z\nend_header\n" +
                                         std::string(24, '\0')),
                 "200000000 vertices");
    const rp::Frame f = rp::read_frame(written("two.ply", "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n"
                                                          "property float y\nproperty float z\nend_header\n"
                                                          "1 2 3\n4 5 6\n"));
    ASSERT_EQ(f.points.rows(), 2);
    EXPECT_FLOAT_EQ(f.points(1, 2), 6.f);
}

std::string ply(const std::string& format, const std::string& elements) {
    return "ply\n" + format + elements + "end_header\n";
}

const std::string kVertices2 = "element vertex 2\nproperty float x\nproperty float y\nproperty float z\n";

TEST(CloudFiles, DuplicatedOrGarbledPlyHeaderLinesAreErrorsNotPclCrashes) {
    const std::string ascii = "format ascii 1.0\n", data = "1 2 3\n4 5 6\n";
    // The fuzz finding: two vertex elements, one of 0 vertices; PCL bound a reference into an empty cloud.
    const std::string empty_vertex = "element vertex 0\nproperty float x\nproperty float y\nproperty float z\n";
    expect_error(written("twice.ply", ply(ascii, empty_vertex + kVertices2) + data),
                 "line 7 'element vertex 2': element 'vertex' is declared twice");
    expect_error(written("twice_b.ply", ply(ascii, kVertices2 + empty_vertex) + data),
                 "line 7 'element vertex 0': element 'vertex' is declared twice");
    EXPECT_EQ(rp::read_frame(written("fine.ply", ply(ascii, kVertices2) + data)).points.rows(), 2);
    // A line beginning with a carriage return: PCL failed an assertion on "\robj_info" (found by fuzzing).
    expect_error(written("cr.ply", ply(ascii, kVertices2 + "\robj_info\n") + data),
                 "begins with a blank or holds a carriage return before its end");
    expect_error(written("indented.ply", ply(ascii, " " + kVertices2) + data), "begins with a blank");
    // The format line: missing, garbled, twice.
    expect_error(written("no_format.ply", ply("", kVertices2) + data), "PLY header: no format line");
    expect_error(written("short_format.ply", ply("format ascii\n", kVertices2) + data),
                 "line 2 'format ascii': expected 'format ascii|binary_little_endian|binary_big_endian 1.0'");
    expect_error(written("binary.ply", ply("format binary 1.0\n", kVertices2) + data), "unknown format 'binary'");
    expect_error(written("version.ply", ply("format ascii 2.0\n", kVertices2) + data), "unsupported version '2.0'");
    expect_error(written("two_formats.ply", ply(ascii + ascii, kVertices2) + data), "line 3 'format ascii 1.0': a second");
    // Counts that are negative, not numbers, or beyond PCL's 32 bits.
    for (const std::string count : {"-2", "2x", "0x10", "4294967296", "+2"}) {
        std::string elements = kVertices2;
        elements.replace(elements.find(" 2\n"), 2, " " + count);
        expect_error(written("count.ply", ply(ascii, elements) + data),
                     "'element vertex " + count + "': the count must be a whole number from 0 to 4294967295");
    }
    // A control character in a header line (as the PCD finding), an unknown line, a property without element.
    expect_error(written("control.ply", ply(ascii, kVertices2 + std::string("property float i\x14\0\n", 19)) + data),
                 "line 7 'property …' holds a control character");
    expect_error(written("unknown.ply", ply(ascii, "elemnt vertex 2\n" + kVertices2) + data),
                 "line 3 'elemnt vertex 2': not a header line");
    expect_error(written("orphan.ply", ply(ascii, "property float x\n" + kVertices2) + data), "a property before any element");
    expect_error(written("same_property.ply", ply(ascii, kVertices2 + "property float x\n") + data),
                 "property 'x' of element 'vertex' is declared twice");
    expect_error(written("list.ply", ply(ascii, kVertices2 + "property list float int i\n") + data),
                 "a list length must be uchar, ushort or uint, got 'float'");
}

TEST(CloudFiles, PlyCountsAndDimensionsAreCheckedAgainstTheFile) {
    const std::string binary = "format binary_little_endian 1.0\n", data(24, '\0');
    // Every element's entries must fit in the file, not only the vertices' (PCL reserves by a range_grid count).
    expect_error(written("grid.ply", ply(binary, kVertices2 + "element range_grid 4000000000\n"
                                                              "property list uchar int vertex_indices\n") + data),
                 "declares 4000000000 'range_grid' entries but the file holds 24 bytes of data (at least 1 per entry, "
                 "after the elements before it)");
    expect_error(written("empty_element.ply", ply(binary, "element junk 4000000000\n" + kVertices2) + data),
                 "element 'junk' has 4000000000 entries but no properties");
    // obj_info num_cols × num_rows replaces the vertex count as the size PCL allocates.
    expect_error(written("dims.ply", ply(binary, "obj_info num_cols 100000\nobj_info num_rows 100000\n" + kVertices2) + data),
                 "the cloud is 100000 × 100000 points (obj_info num_cols × num_rows, else the vertex count) but the "
                 "file holds 2 vertices");
    // After the vertex element obj_info still sets the width (PCL then allocates 2000000000 × 1 vertices).
    expect_error(written("dims_after.ply", ply(binary, kVertices2 + "obj_info num_cols 2000000000\n") + data),
                 "the cloud is 2000000000 × 1 points");
    // More vertices than the width × height PCL allocates (with a range grid of as many entries): PCL's build
    // with assertions aborted on the vertex past the end (a fuzz finding).
    const std::string grid = "element range_grid 1\nproperty list uchar int vertex_indices\n";
    expect_error(written("grid_short.ply", ply(binary, "obj_info num_cols 1\nobj_info num_rows 1\n" + kVertices2 + grid) +
                                              data + std::string("\1\0\0\0\0", 5)),
                 "the cloud is 1 × 1 points (obj_info num_cols × num_rows, else the vertex count) but the file holds "
                 "2 vertices and 1 range_grid entries");
    // Lists in vertices: PCL sizes every vertex by the first one's lists and aborted on a longer one.
    expect_error(written("vertex_list.ply", ply(binary, kVertices2 + "property list uchar float extra\n") + data),
                 "line 7 'property list uchar float extra': list properties of vertices are not supported");
    expect_error(written("dims_minus.ply", ply(binary, "obj_info num_cols -1\n" + kVertices2) + data),
                 "line 3 'obj_info num_cols -1': num_cols must be a whole number from 0 to 2147483647");
    // As PCL writes them (obj_info dimensions, an empty face element), and with no vertices: an empty frame.
    const rp::Frame pcl_written = rp::read_frame(written(
        "pcl.ply", ply(binary, "comment PCL generated\nobj_info num_cols 2\nobj_info num_rows 1\n" + kVertices2 +
                                   "element face 0\nproperty list uchar int vertex_indices\n") + data));
    EXPECT_EQ(pcl_written.points.rows(), 2);
    const std::string grid2 = "element range_grid 2\nproperty list uchar int vertex_indices\n";
    const rp::Frame organized = rp::read_frame(written(
        "organized.ply", ply(binary, "obj_info num_cols 1\nobj_info num_rows 2\n" + kVertices2 + grid2) + data +
                             std::string("\1\1\0\0\0\1\0\0\0\0", 10)));
    EXPECT_EQ(organized.points.rows(), 2);
    const std::string none = "element vertex 0\nproperty float x\nproperty float y\nproperty float z\n";
    EXPECT_EQ(rp::read_frame(written("none.ply", ply(binary, none))).points.rows(), 0);
}

TEST(CloudFiles, SequenceBreaks) {
    std::int64_t step = 0;
    const auto check = [&](const std::string& a, const std::string& b) { return rp::sequence_break(a, b, step); };
    EXPECT_EQ(check("a/000001.bin", "a/000002.bin"), "");
    EXPECT_EQ(step, 1);
    EXPECT_EQ(check("a/000002.bin", "a/000005.bin"), "");  // two frames dropped
    EXPECT_EQ(check("a/000005.bin", "a/000009.bin"), "frame number 5 → 9");
    EXPECT_EQ(step, 0);
    EXPECT_EQ(check("a/000009.bin", "a/000000.bin"), "frame number 9 → 0");  // numbering starts again
    EXPECT_EQ(check("a/000009.bin", "b/000010.bin"), "another folder");
    EXPECT_EQ(check("a/000002.bin", "a/spvnas_000000.bin"), "another file name pattern");
    EXPECT_EQ(check("a/scan_7.pcd", "a/scan_8.pcd"), "");
    EXPECT_EQ(check("a/scan.0008.ply", "a/scan.0009.ply"), "");
    step = 0;  // nuScenes names carry microseconds: steps of about 50,000
    EXPECT_EQ(check("a/n015__LIDAR_TOP__1532402927647951.pcd.bin", "a/n015__LIDAR_TOP__1532402927697951.pcd.bin"), "");
    EXPECT_EQ(check("a/n015__LIDAR_TOP__1532402927697951.pcd.bin", "a/n015__LIDAR_TOP__1532402927748120.pcd.bin"), "");
    EXPECT_EQ(step, 50000);
}
