#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include <roadpreview/io/readers.hpp>

namespace rp = roadpreview;
namespace fs = std::filesystem;

namespace {

const std::string kData = ROADPREVIEW_TEST_DATA;

fs::path scratch(const std::string& name) {
    const fs::path dir = fs::temp_directory_path() / "roadpreview_io_test";
    fs::create_directories(dir);
    return dir / name;
}

void write_bytes(const fs::path& p, const std::string& bytes) { std::ofstream(p, std::ios::binary) << bytes; }

std::string error_of(const std::string& path) {
    try {
        rp::read_frame(path);
    } catch (const std::runtime_error& e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST(Io, ReadsAKittiScan) {
    const rp::Frame f = rp::read_frame(kData + "/semantickitti/000000.bin");
    EXPECT_EQ(f.points.rows(), 124668);  // data README: 124668 points
    EXPECT_EQ(f.source, kData + "/semantickitti/000000.bin");
}

TEST(Io, ReadsACompressedOrganizedPcd) {
    const rp::Frame f = rp::read_frame(kData + "/pcd/patchwork_128ring_000000.pcd");
    EXPECT_EQ(f.points.rows(), 240000);  // 1875 × 128, organized
}

TEST(Io, TruncatedBinNamesTheFileAndTheProblem) {
    const fs::path p = scratch("truncated.bin");
    write_bytes(p, std::string(16 * 10 + 7, '\0'));
    const std::string err = error_of(p.string());
    EXPECT_NE(err.find(p.string()), std::string::npos) << err;
    EXPECT_NE(err.find("multiple of 16"), std::string::npos) << err;
}

TEST(Io, CorruptPcdIsAnErrorNotACrash) {
    const fs::path garbage = scratch("garbage.pcd");
    write_bytes(garbage, "this is not a point cloud\n\x01\x02\x03");
    EXPECT_NE(error_of(garbage.string()).find("garbage.pcd"), std::string::npos);

    // A real header whose binary data stops early.
    std::ifstream in(kData + "/pcd/patchwork_128ring_000000.pcd", std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), {});
    const fs::path cut = scratch("cut.pcd");
    write_bytes(cut, bytes.substr(0, bytes.size() / 2));
    EXPECT_NE(error_of(cut.string()).find("cut.pcd"), std::string::npos);
}

TEST(Io, MissingPathsAndUnsupportedTypesAreErrors) {
    EXPECT_NE(error_of("/nonexistent/x.bin").find("no such file"), std::string::npos);
    const fs::path txt = scratch("points.txt");
    write_bytes(txt, "1 2 3\n");
    EXPECT_NE(error_of(txt.string()).find("unsupported"), std::string::npos);
    EXPECT_THROW(rp::expand_inputs({"/nonexistent/dir"}), std::runtime_error);
}

TEST(Io, DirectoriesExpandToTheirFramesSortedByName) {
    const auto files = rp::expand_inputs({kData + "/semantickitti"});
    ASSERT_EQ(files.size(), 4u);
    EXPECT_TRUE(std::is_sorted(files.begin(), files.end()));
    EXPECT_EQ(fs::path(files[0]).filename(), "000000.bin");
    const fs::path empty = scratch("empty_dir");
    fs::create_directories(empty);
    EXPECT_THROW(rp::expand_inputs({empty.string()}), std::runtime_error);
}

// open_frames refuses what it cannot read before reading: no inputs, a negative column count; recordings of two
// kinds of sensor are named by kind (a Velodyne's model is not known before its first packet: no blank for it).
TEST(Io, OpenFramesRefusesNoInputsNegativeColumnsAndMixedSensors) {
    try {
        rp::open_frames({});
        ADD_FAILURE() << "no inputs were taken";
    } catch (const std::invalid_argument& e) {
        EXPECT_STREQ(e.what(), "open_frames: no inputs given (files, folders or recordings)");
    }
    rp::SourceOptions negative;
    negative.columns = -3;
    const std::string kitti = kData + "/semantickitti/000000.bin";
    try {
        rp::open_frames({kitti}, negative);
        ADD_FAILURE() << "columns -3 was taken";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(kitti + ": columns must be 0"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("got -3"), std::string::npos) << e.what();
    }
    const std::string ouster = kData + "/ouster/OS-1-128_v2.3.0_1024x10_lb_n3.pcap";
    const std::string velodyne = kData + "/velodyne/velodyne_vlp16.pcap";
    auto source = rp::open_frames({ouster, velodyne});
    try {
        while (source->next()) {
        }
        ADD_FAILURE() << "an Ouster and a Velodyne recording were read as one drive";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(velodyne + ": holds velodyne pcap data but " + ouster + " holds ouster pcap OS-1-128"),
                  std::string::npos) << e.what();
    }
}
