// Ouster: every bundled recording decodes to the frame and point counts verified in the shared data README;
// metadata layouts, mismatches, missing and invalid columns, and XYZ on hand-made packets.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstring>
#include <algorithm>
#include <fstream>
#include <random>
#include <sstream>

#include <nlohmann/json.hpp>

#include <roadpreview/io/readers.hpp>
#include <roadpreview/io/ouster.hpp>
#include <roadpreview/io/pcap.hpp>

namespace rp = roadpreview;
using nlohmann::json;

namespace {

const std::string kOuster = std::string(ROADPREVIEW_TEST_DATA) + "/ouster/";

std::string slurp(const std::string& path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

std::vector<rp::Frame> all_frames(const std::string& pcap, const rp::SourceOptions& o = {}) {
    auto source = rp::open_frames({pcap}, o);
    std::vector<rp::Frame> frames;
    while (auto f = source->next()) frames.push_back(std::move(*f));
    return frames;
}

std::string error_of(const std::function<void()>& f) {
    try {
        f();
    } catch (const std::exception& e) {
        return e.what();
    }
    return "";
}

struct Recording {
    std::string pcap, meta, profile, model;
    std::vector<Eigen::Index> points;  // per frame, from the shared data README
    std::vector<std::int64_t> ids;
};

}  // namespace

TEST(Ouster, EveryBundledRecordingDecodesToTheVerifiedCounts) {
    const std::vector<Recording> recordings = {
        {"OS-1-128_v2.3.0_1024x10_lb_n3.pcap", "", "RNG15_RFL8_NIR8", "OS-1-128", {107647, 107357, 107532}, {1795, 1796, 1797}},
        {"OS-1-128_767798045_1024x10_20230712_120049.pcap", "", "FUSA_RNG15_RFL8_NIR8_DUAL", "OS-1-128", {16373}, {229}},
        {"OS-0-128-U1_v2.3.0_1024x10.pcap", "", "RNG15_RFL8_NIR8", "OS-0-128", {97299}, {1491}},
        {"OS-2-128-U1_v2.3.0_1024x10.pcap", "", "RNG19_RFL8_SIG16_NIR16", "OS-2-128", {119682}, {1259}},
        {"OS-0-32-U1_v2.2.0_1024x10.pcap", "", "RNG19_RFL8_SIG16_NIR16_DUAL", "OS-0-32-U1", {21631}, {1453}},
        {"OS-1-32-G_v2.1.1_1024x10.pcap", "", "LEGACY", "OS-1-32-G", {27310}, {638}},
        {"OS-2-32-U0_v2.0.0_1024x10.pcap", "", "LEGACY", "OS-2-32-U0", {28541}, {5424}},
        {"OS-1-64_1024x10_fw20.pcap", "OS-1-64_sensor_config_reduced.json", "LEGACY", "", {16749}, {189}},
        {"rust-lidar-utils/ouster_example.pcap", "", "LEGACY", "", {12783, 58797, 20690}, {12072, 12073, 12074}},
    };
    for (const Recording& r : recordings) {
        SCOPED_TRACE(r.pcap);
        rp::SourceOptions o;
        if (!r.meta.empty()) o.meta = kOuster + r.meta;
        auto source = rp::open_frames({kOuster + r.pcap}, o);
        std::vector<Eigen::Index> points;
        std::vector<std::int64_t> ids;
        while (auto f = source->next()) {
            points.push_back(f->points.rows());
            ids.push_back(f->frame_id);
            EXPECT_EQ(f->point_times.size(), static_cast<std::size_t>(f->points.rows()));
            EXPECT_TRUE(f->timestamp.has_value());
        }
        EXPECT_EQ(points, r.points);
        EXPECT_EQ(ids, r.ids);
        EXPECT_EQ(source->info().profile, r.profile);
        if (!r.model.empty()) {
            EXPECT_EQ(source->info().sensor_model, r.model);
        }
        EXPECT_EQ(source->info().lidar_port, 7502);
    }
}

TEST(Ouster, MissingColumnsAreCountedAndTheFrameIsStillEmitted) {
    // ouster_example.pcap starts and ends inside frames: 224 and 352 of 1024 columns arrive.
    const auto frames = all_frames(kOuster + "rust-lidar-utils/ouster_example.pcap");
    ASSERT_EQ(frames.size(), 3u);
    EXPECT_EQ(frames[0].diagnostics.missing_columns, 1024 - 224);
    EXPECT_EQ(frames[1].diagnostics.missing_columns, 0);
    EXPECT_EQ(frames[2].diagnostics.missing_columns, 1024 - 352);
    EXPECT_FALSE(frames[0].diagnostics.complete);
    EXPECT_TRUE(frames[1].diagnostics.complete);
    // The capture began and ended within those frames: no packet was lost.
    EXPECT_EQ(frames[0].diagnostics.cut_columns, 1024 - 224);
    EXPECT_EQ(frames[2].diagnostics.cut_columns, 1024 - 352);
    for (const auto& f : frames) EXPECT_EQ(f.diagnostics.lost_packets, 0);
}

TEST(Ouster, ImuPacketsTravelWithTheirFrame) {
    const auto frames = all_frames(kOuster + "OS-1-128_v2.3.0_1024x10_lb_n3.pcap");
    std::size_t samples = 0;
    double a[3] = {0, 0, 0};
    for (const auto& f : frames) {
        samples += f.imu.size();
        for (const auto& s : f.imu)
            for (int k = 0; k < 3; ++k) a[k] += s.linear_acceleration[static_cast<std::size_t>(k)] / 30;
    }
    EXPECT_EQ(samples, 30u);  // the README's 30 IMU packets
    // Over 0.3 s of steady driving the accelerometer measures mostly gravity, pointing up the sensor's z axis.
    const double g = std::hypot(a[0], a[1], a[2]);
    EXPECT_GT(g, 9.0);
    EXPECT_LT(g, 12.0);
    EXPECT_GT(a[2], 0.9 * g);
}

TEST(Ouster, MetadataIsFoundNextToThePcapByName) {
    EXPECT_EQ(rp::find_ouster_metadata(kOuster + "OS-1-128_v2.3.0_1024x10_lb_n3.pcap"), kOuster + "OS-1-128_v2.3.0_1024x10.json");
    EXPECT_EQ(rp::find_ouster_metadata(kOuster + "OS-1-64_1024x10_fw20.pcap"), "");
    const std::string err = error_of([] { rp::open_frames({kOuster + "OS-1-64_1024x10_fw20.pcap"}); });
    EXPECT_NE(err.find("OS-1-64_1024x10_fw20.pcap"), std::string::npos) << err;
    EXPECT_NE(err.find("--meta"), std::string::npos) << err;
    rp::SourceOptions o;
    o.meta = kOuster + "missing.json";
    EXPECT_NE(error_of([&] { rp::open_frames({kOuster + "x.pcap"}, o); }).find("no such file"), std::string::npos);
    EXPECT_NE(error_of([&] { rp::open_frames({kOuster + "OS-1-64_1024x10_fw20.pcap"}, o); }).find("missing.json"),
              std::string::npos);
}

TEST(Ouster, NestedAndFlatLayoutsGiveTheSameMetadata) {
    const json flat = json::parse(slurp(kOuster + "OS-1-128_v2.3.0_1024x10.json"));
    json nested;
    nested["sensor_info"] = {{"prod_line", flat["prod_line"]}, {"prod_sn", flat["prod_sn"]},
                             {"initialization_id", flat["initialization_id"]}};
    nested["beam_intrinsics"] = {{"beam_altitude_angles", flat["beam_altitude_angles"]},
                                 {"beam_azimuth_angles", flat["beam_azimuth_angles"]},
                                 {"lidar_origin_to_beam_origin_mm", flat["lidar_origin_to_beam_origin_mm"]}};
    nested["lidar_intrinsics"] = {{"lidar_to_sensor_transform", flat["lidar_to_sensor_transform"]}};
    nested["imu_intrinsics"] = {{"imu_to_sensor_transform", flat["imu_to_sensor_transform"]}};
    nested["lidar_data_format"] = flat["data_format"];
    nested["config_params"] = {{"lidar_mode", flat["lidar_mode"]}, {"udp_port_lidar", flat["udp_port_lidar"]},
                               {"udp_port_imu", flat["udp_port_imu"]}};
    const rp::OusterMetadata a = rp::parse_ouster_metadata(flat.dump(), "flat.json");
    const rp::OusterMetadata b = rp::parse_ouster_metadata(nested.dump(), "nested.json");
    EXPECT_EQ(a.prod_sn, "122201000998");
    EXPECT_EQ(a.init_id, 7109750u);
    for (const auto* m : {&a, &b}) {
        EXPECT_EQ(m->prod_line, "OS-1-128");
        EXPECT_EQ(m->profile, rp::OusterProfile::Rng15Rfl8Nir8);
        EXPECT_EQ(m->columns_per_frame, 1024);
        EXPECT_EQ(m->pixels_per_column, 128);
        EXPECT_EQ(m->lidar_packet_bytes(), 8448u);
        EXPECT_DOUBLE_EQ(m->beam_to_lidar[3], 15.806);
        EXPECT_DOUBLE_EQ(m->lidar_to_sensor[11], 36.18);
        EXPECT_EQ(m->udp_port_lidar, 7502);
    }
    EXPECT_EQ(a.beam_altitude_deg, b.beam_altitude_deg);
    EXPECT_EQ(a.pixel_shift_by_row, b.pixel_shift_by_row);
    EXPECT_EQ(a.prod_sn, b.prod_sn);
    // The vendor's own nested file (firmware 3.1) with an explicit beam_to_lidar_transform.
    const auto fusa = rp::read_ouster_metadata(kOuster + "OS-1-128_767798045_1024x10_20230712_120049.json");
    EXPECT_EQ(fusa.profile, rp::OusterProfile::FusaRng15Rfl8Nir8Dual);
    EXPECT_EQ(fusa.lidar_packet_bytes(), 16640u);
    EXPECT_DOUBLE_EQ(fusa.beam_to_lidar[3], 16.721);
}

TEST(Ouster, BadMetadataNamesTheFileAndTheField) {
    json j = json::parse(slurp(kOuster + "OS-1-128_v2.3.0_1024x10.json"));
    j.erase("lidar_mode");
    std::string err = error_of([&] { rp::parse_ouster_metadata(j.dump(), "m.json"); });
    EXPECT_NE(err.find("m.json"), std::string::npos);
    EXPECT_NE(err.find("lidar_mode"), std::string::npos) << err;
    j = json::parse(slurp(kOuster + "OS-1-128_v2.3.0_1024x10.json"));
    j["beam_altitude_angles"].erase(0);
    err = error_of([&] { rp::parse_ouster_metadata(j.dump(), "m.json"); });
    EXPECT_NE(err.find("beam_altitude_angles"), std::string::npos) << err;
    j = json::parse(slurp(kOuster + "OS-1-128_v2.3.0_1024x10.json"));
    j["data_format"]["udp_profile_lidar"] = "FIVE_WORD_PIXEL";
    EXPECT_NE(error_of([&] { rp::parse_ouster_metadata(j.dump(), "m.json"); }).find("not supported"), std::string::npos);
    EXPECT_NE(error_of([&] { rp::parse_ouster_metadata("{not json", "m.json"); }).find("m.json"), std::string::npos);
    // A shift of a whole rotation or more is no sensor's (and column + shift could overflow an int).
    for (const int shift : {1024, -1024, 2147483647}) {
        j = json::parse(slurp(kOuster + "OS-1-128_v2.3.0_1024x10.json"));
        j["data_format"]["pixel_shift_by_row"][5] = shift;
        err = error_of([&] { rp::parse_ouster_metadata(j.dump(), "m.json"); });
        EXPECT_NE(err.find("m.json: pixel_shift_by_row must lie within ±1023"), std::string::npos) << err;
        EXPECT_NE(err.find("row 5"), std::string::npos) << err;
    }
}

TEST(Ouster, IntegerFieldsOutOfTheirTypeAreErrorsNotUndefinedCasts) {
    // Fuzzing found 1.9e83 in pixel_shift_by_row: nlohmann casts it to int unchecked (UBSan: not representable).
    for (const auto& [field, value] : std::vector<std::pair<std::string, json>>{
             {"pixel_shift_by_row", json::parse("1.8888888888888888e83")},
             {"pixel_shift_by_row", json(4294967296LL)},
             {"columns_per_packet", json(1e20)},
             {"columns_per_packet", json(16.5)},
             {"udp_port_lidar", json(-1e30)}}) {
        json j = json::parse(slurp(kOuster + "OS-1-128_v2.3.0_1024x10.json"));
        if (field == "pixel_shift_by_row")
            j["data_format"][field][3] = value;
        else if (field == "columns_per_packet")
            j["data_format"][field] = value;
        else
            j[field] = value;
        const std::string err = error_of([&] { rp::parse_ouster_metadata(j.dump(), "m.json"); });
        EXPECT_NE(err.find("m.json: " + field + " must hold whole numbers"), std::string::npos) << field << ": " << err;
    }
}

namespace {

// The OS1-128 recording decoded with an altered copy of its metadata.
std::string error_with_metadata(const std::function<void(json&)>& alter, const std::string& name) {
    json j = json::parse(slurp(kOuster + "OS-1-128_v2.3.0_1024x10.json"));
    alter(j);
    const std::string path = testing::TempDir() + name;
    std::ofstream(path) << j.dump();
    rp::SourceOptions o;
    o.meta = path;
    return error_of([&] { all_frames(kOuster + "OS-1-128_v2.3.0_1024x10_lb_n3.pcap", o); });
}

}  // namespace

TEST(Ouster, MetadataThatDoesNotMatchThePacketsIsAnError) {
    std::string err = error_with_metadata([](json& j) { j["data_format"]["udp_profile_lidar"] = "RNG19_RFL8_SIG16_NIR16"; },
                                          "profile.json");
    EXPECT_NE(err.find("OS-1-128_v2.3.0_1024x10_lb_n3.pcap"), std::string::npos) << err;
    EXPECT_NE(err.find("8448 bytes"), std::string::npos) << err;
    EXPECT_NE(err.find("does not match"), std::string::npos) << err;

    const auto columns = [](int n) {
        return [n](json& j) {
            j["lidar_mode"] = std::to_string(n) + "x10";
            j["data_format"]["columns_per_frame"] = n;
            j["data_format"]["column_window"] = {0, n - 1};
        };
    };
    for (int n : {512, 2048}) {  // both caught by the time between columns
        err = error_with_metadata(columns(n), "columns" + std::to_string(n) + ".json");
        EXPECT_NE(err.find("column count"), std::string::npos) << err;
    }

    err = error_with_metadata([](json& j) { j["prod_sn"] = "122201000999"; }, "serial.json");
    EXPECT_NE(err.find("another sensor"), std::string::npos) << err;
}

namespace {

// A one-packet-per-column RNG19 single-return sensor with 4 beams, for hand-made packets.
rp::OusterMetadata tiny_metadata() {
    json j = {{"lidar_mode", "512x10"},
              {"beam_altitude_angles", {30.0, 0.0, -10.0, -30.0}},
              {"beam_azimuth_angles", {0.0, 0.0, 2.0, 0.0}},
              {"lidar_origin_to_beam_origin_mm", 0.0},
              {"lidar_to_sensor_transform", {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}},
              {"data_format", {{"pixels_per_column", 4}, {"columns_per_packet", 1}, {"columns_per_frame", 512},
                               {"udp_profile_lidar", "RNG19_RFL8_SIG16_NIR16"}}}};
    return rp::parse_ouster_metadata(j.dump(), "tiny.json");
}

std::vector<std::uint8_t> tiny_packet(std::uint16_t frame_id, std::uint16_t column, std::uint32_t range_mm,
                                      std::uint16_t status = 1) {
    std::vector<std::uint8_t> p(32 + 12 + 4 * 12 + 32, 0);
    std::memcpy(&p[2], &frame_id, 2);
    const std::uint64_t ts = 1'000'000'000ull + column * 195'312ull;  // 512 columns in 0.1 s
    std::memcpy(&p[32], &ts, 8);
    std::memcpy(&p[40], &column, 2);
    std::memcpy(&p[42], &status, 2);
    for (int beam = 0; beam < 4; ++beam) std::memcpy(&p[44 + 12 * beam], &range_mm, 4);
    return p;
}

}  // namespace

TEST(Ouster, XyzFollowsTheBeamAnglesAndTheEncoderAngle) {
    rp::OusterDecoder d(tiny_metadata());
    const std::uint16_t column = 128;  // a quarter turn: encoder angle 2π − π/2
    const auto p = tiny_packet(7, column, 10000);
    d.add_packet(p.data(), p.size(), 0.0);
    const auto f = d.finish();
    ASSERT_TRUE(f);
    ASSERT_EQ(f->points.rows(), 4);
    const double pi = 3.14159265358979323846;
    const double altitudes[4] = {30.0, 0.0, -10.0, -30.0};
    const double azimuths[4] = {0.0, 0.0, 2.0, 0.0};
    for (int beam = 0; beam < 4; ++beam) {
        const double phi = altitudes[beam] * pi / 180, theta = 2 * pi * (1 - 128.0 / 512) - azimuths[beam] * pi / 180;
        EXPECT_NEAR(f->points(beam, 0), 10.0 * std::cos(theta) * std::cos(phi), 1e-5);
        EXPECT_NEAR(f->points(beam, 1), 10.0 * std::sin(theta) * std::cos(phi), 1e-5);
        EXPECT_NEAR(f->points(beam, 2), 10.0 * std::sin(phi), 1e-5);
    }
    EXPECT_EQ(f->frame_id, 7);
    EXPECT_EQ(f->diagnostics.missing_columns, 511);
    EXPECT_EQ(f->diagnostics.cut_columns, 511);  // the input began and ended within the frame
    EXPECT_EQ(f->diagnostics.lost_packets, 0);
}

TEST(Ouster, InvalidColumnsAndZeroRangesAreSkippedAndFramesSplitByFrameId) {
    rp::OusterDecoder d(tiny_metadata());
    const auto add = [&](const std::vector<std::uint8_t>& p) { return d.add_packet(p.data(), p.size(), 0.0); };
    EXPECT_FALSE(add(tiny_packet(1, 0, 5000)));
    EXPECT_FALSE(add(tiny_packet(1, 1, 5000, 0)));  // status bit clear
    EXPECT_FALSE(add(tiny_packet(1, 2, 0)));        // no returns
    const auto first = add(tiny_packet(2, 0, 5000));  // the next frame begins
    ASSERT_TRUE(first);
    EXPECT_EQ(first->points.rows(), 4);
    EXPECT_EQ(first->diagnostics.invalid_columns, 1);
    EXPECT_EQ(first->diagnostics.missing_columns, 512 - 3);
    EXPECT_EQ(d.finish()->frame_id, 2);
    EXPECT_THROW(d.add_packet(tiny_packet(2, 0, 5000).data(), 123, 0.0), std::invalid_argument);
    EXPECT_THROW(add(tiny_packet(2, 600, 5000)), std::invalid_argument);  // beyond 512 columns
}

// Pixels are made as their column arrives: what a column held in one frame, or in a copy of it later found
// invalid, must not reach the frame.
TEST(Ouster, AColumnsPointsLastOnlyAsLongAsItsLatestValidCopyInItsFrame) {
    rp::OusterDecoder d(tiny_metadata());
    const auto add = [&](const std::vector<std::uint8_t>& p) { return d.add_packet(p.data(), p.size(), 0.0); };
    add(tiny_packet(1, 0, 5000));
    add(tiny_packet(1, 1, 5000));
    add(tiny_packet(1, 1, 5000, 0));  // the same column again, its status bit clear
    const auto first = add(tiny_packet(2, 2, 7000));
    ASSERT_TRUE(first);
    EXPECT_EQ(first->points.rows(), 4);  // column 0's four beams only
    EXPECT_EQ(first->diagnostics.invalid_columns, 1);
    const auto second = d.finish();  // column 2 only: nothing of columns 0 and 1 from frame 1
    ASSERT_TRUE(second);
    ASSERT_EQ(second->points.rows(), 4);
    for (int beam = 0; beam < 4; ++beam) EXPECT_NEAR(second->points.row(beam).head<3>().norm(), 7.0, 0.05);
}

// Each column's points are placed as it arrives: a frame's packets in any order (the one holding the window's
// last column last, as it closes the frame) give the points of the recorded order, bit for bit. Their times count
// from the first packet received, so they move together by the same amount.
TEST(Ouster, APacketOrderWithinAFrameGivesTheSameFrame) {
    const std::string pcap = kOuster + "OS-1-128_v2.3.0_1024x10_lb_n3.pcap";
    const rp::OusterMetadata meta = rp::read_ouster_metadata(kOuster + "OS-1-128_v2.3.0_1024x10.json");
    std::vector<rp::UdpDatagram> packets;  // frame 1796's (the frame id: bytes 2–3 of this profile's header)
    rp::PcapReader reader(pcap);
    for (rp::UdpDatagram d; reader.next(d);)
        if (d.payload.size() == meta.lidar_packet_bytes() && d.payload[2] + 256 * d.payload[3] == 1796)
            packets.push_back(d);
    ASSERT_EQ(packets.size(), 64u);
    const auto decode = [&](const std::vector<rp::UdpDatagram>& in) {
        rp::OusterDecoder d(meta);
        std::optional<rp::Frame> f;
        for (const auto& p : in) {
            EXPECT_FALSE(f) << "the frame closed before its last packet";
            f = d.add_packet(p.payload.data(), p.payload.size(), p.timestamp);
        }
        return f;
    };
    const auto recorded = decode(packets);
    ASSERT_TRUE(recorded);
    EXPECT_EQ(recorded->points.rows(), 107357);
    std::mt19937 rng(7);
    for (int trial = 0; trial < 3; ++trial) {
        std::shuffle(packets.begin(), packets.end() - 1, rng);
        const auto shuffled = decode(packets);
        ASSERT_TRUE(shuffled);
        ASSERT_EQ(shuffled->points.rows(), recorded->points.rows());
        EXPECT_EQ(std::memcmp(shuffled->points.data(), recorded->points.data(),
                              sizeof(float) * static_cast<std::size_t>(recorded->points.size())), 0);
        EXPECT_EQ(shuffled->beams, recorded->beams);
        const float shift = shuffled->point_times[0] - recorded->point_times[0];
        double worst = 0.0;
        for (std::size_t i = 0; i < recorded->point_times.size(); ++i)
            worst = std::max(worst, std::abs(double{shuffled->point_times[i] - recorded->point_times[i] - shift}));
        EXPECT_LT(worst, 1e-6);
    }
}

// A frame's last packet swapped with the next frame's first once read as a restart: two spurious frames of one
// packet each (5 frames of 3). Late, it is counted so; a copy of a frame's closing packet is a duplicate, not a new
// frame; and the same frame again from its first column (a sensor restart, a capture of one frame looped) is a frame.
TEST(Ouster, APacketLateAcrossTheFrameBoundaryIsLateAndTheSameIdFromTheStartIsAFrame) {
    const std::string pcap = kOuster + "OS-1-128_v2.3.0_1024x10_lb_n3.pcap";
    const rp::OusterMetadata meta = rp::read_ouster_metadata(kOuster + "OS-1-128_v2.3.0_1024x10.json");
    std::vector<rp::UdpDatagram> packets;
    rp::PcapReader reader(pcap);
    for (rp::UdpDatagram d; reader.next(d);)
        if (d.payload.size() == meta.lidar_packet_bytes()) packets.push_back(d);
    ASSERT_EQ(packets.size(), 3u * 64u);
    const auto decode = [&](const std::vector<rp::UdpDatagram>& in) {
        rp::OusterDecoder d(meta);
        std::vector<rp::Frame> frames;
        for (const auto& p : in)
            if (auto f = d.add_packet(p.payload.data(), p.payload.size(), p.timestamp)) frames.push_back(std::move(*f));
        if (auto f = d.finish()) frames.push_back(std::move(*f));
        return frames;
    };
    auto swapped = packets;
    std::swap(swapped[63], swapped[64]);  // frame 1795's last packet after frame 1796's first
    const auto frames = decode(swapped);
    ASSERT_EQ(frames.size(), 3u);
    EXPECT_EQ(frames[0].diagnostics.lost_packets, 1);  // its last 16 columns never came in time
    EXPECT_EQ(frames[1].diagnostics.late_packets, 1);  // counted when the next frame is returned
    EXPECT_TRUE(frames[1].diagnostics.complete);
    auto copied = packets;
    copied.insert(copied.begin() + 64, packets[63]);  // the closing packet of frame 1795 twice
    const auto with_copy = decode(copied);
    ASSERT_EQ(with_copy.size(), 3u);
    EXPECT_EQ(with_copy[1].diagnostics.duplicate_packets, 1);
    EXPECT_EQ(with_copy[1].diagnostics.late_packets, 0);
    const std::vector<rp::UdpDatagram> one(packets.begin(), packets.begin() + 64);
    std::vector<rp::UdpDatagram> looped = one;
    looped.insert(looped.end(), one.begin(), one.end());
    const auto twice = decode(looped);
    ASSERT_EQ(twice.size(), 2u);
    EXPECT_EQ(twice[1].points.rows(), twice[0].points.rows());
    EXPECT_TRUE(twice[1].diagnostics.complete);
}

namespace {

// The region the pipeline crops to with the defaults (x 1–40 m, |y| ≤ 10 m), the sensor `height_m` up.
rp::SensorRoi default_roi(double height_m, double direction) {
    rp::Config cfg;
    cfg.sensor_height = height_m;
    return rp::sensor_roi(cfg, direction);
}

// The frame's points inside the region, in the base frame, in the frame's order.
std::vector<std::array<double, 3>> points_in(const rp::Frame& f, const rp::SensorRoi& roi) {
    const rp::RigidTransform T = rp::to_rigid_transform(roi.sensor);
    std::vector<std::array<double, 3>> in;
    for (Eigen::Index i = 0; i < f.points.rows(); ++i) {
        const double p[3] = {f.points(i, 0), f.points(i, 1), f.points(i, 2)};
        std::array<double, 3> b;
        rp::transform_point(T, p, b.data());
        if (b[0] >= roi.x_min_m && b[0] <= roi.x_max_m && std::abs(b[1]) <= roi.y_abs_max_m) in.push_back(b);
    }
    return in;
}

}  // namespace

TEST(OusterRoiColumns, TheWindowSpansTheColumnsWhoseBeamsCrossTheRegion) {
    // The tiny sensor's column v looks along 360°·(1 − v/512) (beam 2 2° less). The region behind, x ∈ [−40, −1]
    // m, |y| ≤ 10 m, spans the directions 180° ± atan2(10, 1) = 95.71°…264.29°: columns 137…375, and with beam
    // 2's offset 134…373 — the window is 134…375 (the region ahead lies across column 0: every column stays).
    rp::OusterDecoder d(tiny_metadata());
    const std::string note = d.keep_columns_reaching({default_roi(1.0, -1.0)});
    EXPECT_EQ(d.metadata().column_window, (std::array<int, 2>{134, 375}));
    EXPECT_NE(note.find("columns 134–375 decoded, 242 of the 512"), std::string::npos) << note;

    const auto add = [&](std::uint16_t id, std::uint16_t column) {
        const auto p = tiny_packet(id, column, 5000);
        return d.add_packet(p.data(), p.size(), 0.0);
    };
    for (std::uint16_t v = 0; v < 375; ++v) EXPECT_FALSE(add(1, v));
    const auto frame = add(1, 375);  // the window's last column ends the frame at once
    ASSERT_TRUE(frame);
    EXPECT_EQ(frame->points.rows(), 4 * 242);
    EXPECT_TRUE(frame->diagnostics.complete);
    for (std::uint16_t v = 376; v < 512; ++v) EXPECT_FALSE(add(1, v));  // left out, not late
    std::optional<rp::Frame> second;
    for (std::uint16_t v = 0; v < 376; ++v)
        if (auto f = add(2, v)) second = std::move(f);
    ASSERT_TRUE(second);
    EXPECT_EQ(second->frame_id, 2);
    EXPECT_EQ(second->diagnostics.late_packets, 0);
    EXPECT_FALSE(d.finish());
    rp::OusterDecoder ahead(tiny_metadata());
    EXPECT_NE(ahead.keep_columns_reaching({default_roi(1.0, 1.0)}).find("every column decoded"), std::string::npos);
    EXPECT_EQ(ahead.metadata().column_window, (std::array<int, 2>{0, 511}));
}

// Destaggering, known answer: row u's pixel of staggered column v lands at column (v + shift[u]) mod W of the
// row-major image, for shifts of either sign.
TEST(Ouster, DestaggeringPutsEachPixelAtItsColumnPlusItsRowsShift) {
    rp::OusterMetadata meta = tiny_metadata();
    meta.pixel_shift_by_row = {511, 2, -3, -511};
    rp::OusterDecoder d(meta);
    std::optional<rp::Frame> f;
    for (std::uint16_t v = 0; v < 512; ++v) {  // column v's range (1000 + v) mm tells it in the output
        const auto p = tiny_packet(1, v, 1000u + v);
        if (auto got = d.add_packet(p.data(), p.size(), 0.0)) f = std::move(got);
    }
    ASSERT_TRUE(f);
    ASSERT_EQ(f->points.rows(), 4 * 512);
    for (int u = 0; u < 4; ++u)
        for (int vd = 0; vd < 512; ++vd) {
            const Eigen::Index i = u * 512 + vd;
            const long v = std::lround(1000.0 * f->points.row(i).head<3>().cast<double>().norm()) - 1000;
            ASSERT_EQ((v + meta.pixel_shift_by_row[static_cast<std::size_t>(u)] + 512) % 512, vd) << "row " << u;
            ASSERT_EQ(f->beams[static_cast<std::size_t>(i)], u);
        }
}

// A window across column 0, on beams shifted both ways by the destaggering: in some beams' rows the window's
// destaggered columns pass the row's end. The frame holds the window's points of the whole rotation, in its order.
TEST(OusterRoiColumns, AWindowAcrossColumnZeroKeepsTheWholeRotationsOrder) {
    rp::OusterMetadata meta = tiny_metadata();
    meta.pixel_shift_by_row = {6, 2, -2, -6};
    const auto frame_of = [](rp::OusterDecoder& d, int first_column) {  // a rotation in the order the sensor sends it
        std::optional<rp::Frame> f;
        for (int k = 0; k < 512; ++k) {  // column v's range (1000 + v) mm tells it in the output
            const auto v = static_cast<std::uint16_t>((first_column + k) % 512);
            const auto p = tiny_packet(1, v, 1000u + v);
            if (auto got = d.add_packet(p.data(), p.size(), 0.0)) f = std::move(got);
        }
        return f ? f : d.finish();
    };
    rp::OusterDecoder whole(meta);
    meta.column_window = {500, 40};
    rp::OusterDecoder window(meta);
    const auto all = frame_of(whole, 0), part = frame_of(window, 500);
    ASSERT_TRUE(all && part);
    std::vector<std::array<float, 4>> want, got;
    for (Eigen::Index i = 0; i < all->points.rows(); ++i) {
        const long column = std::lround(1000.0 * all->points.row(i).head<3>().cast<double>().norm()) - 1000;
        if (column >= 500 || column <= 40)
            want.push_back({all->points(i, 0), all->points(i, 1), all->points(i, 2), all->points(i, 3)});
    }
    for (Eigen::Index i = 0; i < part->points.rows(); ++i)
        got.push_back({part->points(i, 0), part->points(i, 1), part->points(i, 2), part->points(i, 3)});
    EXPECT_EQ(want.size(), 4u * 53u);
    EXPECT_EQ(got, want);
}

TEST(OusterRoiColumns, LateAndMissingColumnsAreCountedInsideTheWindowOnly) {
    rp::OusterDecoder d(tiny_metadata());
    d.keep_columns_reaching({default_roi(1.0, -1.0)});  // columns 134–375
    const auto add = [&](std::uint16_t id, std::uint16_t column) {
        const auto p = tiny_packet(id, column, 5000);
        return d.add_packet(p.data(), p.size(), 0.0);
    };
    std::optional<rp::Frame> f;
    for (std::uint16_t v = 0; v < 512; ++v)
        if (v < 200 || v >= 260)  // 60 of the window's columns lost
            if (auto got = add(1, v)) f = std::move(got);
    ASSERT_TRUE(f);
    EXPECT_EQ(f->diagnostics.missing_columns, 60);
    EXPECT_EQ(f->diagnostics.cut_columns, 0);  // lost within the frame, though it is the input's first
    EXPECT_EQ(f->diagnostics.lost_packets, 60);  // tiny_metadata: one column per packet
    EXPECT_FALSE(add(1, 230));  // a column of the frame just returned, late
    EXPECT_FALSE(add(1, 500));  // outside the window: neither late nor missing
    for (std::uint16_t v = 134; v < 376; ++v) f = add(2, v);
    ASSERT_TRUE(f);
    EXPECT_EQ(f->diagnostics.late_packets, 1);
    EXPECT_EQ(f->diagnostics.missing_columns, 0);
}

TEST(OusterRoiColumns, ARegionNoColumnCanSeeIsAnErrorNamingTheMetadata) {
    rp::OusterMetadata meta = tiny_metadata();
    meta.column_window = {0, 100};  // the sensor sends the directions 0°…−70° only
    rp::OusterDecoder d(meta);
    const std::string err = error_of([&] { d.keep_columns_reaching({default_roi(1.0, -1.0)}); });
    EXPECT_NE(err.find("tiny.json"), std::string::npos) << err;
    EXPECT_NE(err.find("region of interest"), std::string::npos) << err;
}

TEST(OusterRoiColumns, FramesHoldEveryRegionPointOfTheWholeRotation) {
    const std::string pcap = kOuster + "OS-1-128_v2.3.0_1024x10_lb_n3.pcap";
    const rp::SensorRoi roi = default_roi(1.97, 1.0);
    rp::SourceOptions o;
    o.roi_columns = {roi};
    auto source = rp::open_frames({pcap}, o);
    const auto& notes = source->info().notes;
    ASSERT_FALSE(notes.empty());
    EXPECT_NE(notes.back().find("columns 261–763 decoded, 503 of the 1024"), std::string::npos) << notes.back();
    const auto whole = all_frames(pcap);
    std::size_t k = 0;
    while (auto f = source->next()) {
        ASSERT_LT(k, whole.size());
        SCOPED_TRACE("frame " + std::to_string(k));
        EXPECT_EQ(f->frame_id, whole[k].frame_id);
        EXPECT_TRUE(f->diagnostics.complete);
        EXPECT_LT(f->points.rows(), whole[k].points.rows() / 2);
        const auto got = points_in(*f, roi), want = points_in(whole[k], roi);
        EXPECT_GT(want.size(), 20000u);
        EXPECT_EQ(got, want);
        ++k;
    }
    EXPECT_EQ(k, whole.size());
}

TEST(OusterRoiColumns, FrameFilesCannotBeLimited) {
    rp::SourceOptions o;
    o.roi_columns = {default_roi(1.8, 1.0)};
    const std::string bin = std::string(ROADPREVIEW_TEST_DATA) + "/semantickitti/000000.bin";
    const std::string err = error_of([&] { rp::open_frames({bin}, o); });
    EXPECT_NE(err.find("000000.bin"), std::string::npos) << err;
    EXPECT_NE(err.find("region of interest"), std::string::npos) << err;
}

TEST(OusterRoiColumns, ARecordingWithoutTheRegionsColumnsIsAnErrorNotAnEmptyDrive) {
    // The bundled partial frame holds columns 0–127 only: behind the sensor.
    const std::string pcap = kOuster + "OS-1-128_767798045_1024x10_20230712_120049.pcap";
    rp::SourceOptions o;
    o.roi_columns = {default_roi(1.8, 1.0)};
    const std::string err = error_of([&] { all_frames(pcap, o); });
    EXPECT_NE(err.find(pcap), std::string::npos) << err;
    EXPECT_NE(err.find("none of its 8 lidar packets holds a column that can see the region of interest"),
              std::string::npos) << err;
    EXPECT_EQ(all_frames(pcap).size(), 1u);  // without the limit, the partial frame
}
