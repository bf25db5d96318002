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
}

TEST(CloudFiles, AsciiPcdLinesMustBeNumbers) {
    const std::string good = written("good.pcd", pcd_header("2", "2", "ascii") + "1 2 3\n4 5.5 nan\n");
    const rp::Frame f = rp::read_frame(good);
    ASSERT_EQ(f.points.rows(), 2);
    EXPECT_FLOAT_EQ(f.points(1, 1), 5.5f);
    expect_error(written("words.pcd", pcd_header("2", "2", "ascii") + "1 2 3\nfoo bar baz\n"), "'foo bar baz'");
    expect_error(written("short.pcd", pcd_header("3", "3", "ascii") + "1 2 3\n4 5 6\n"), "holds 2 lines");
    expect_error(written("columns.pcd", pcd_header("1", "1", "ascii") + "1 2\n"), "not 3 numbers");
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
