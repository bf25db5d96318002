// SPDX-License-Identifier: BSD-3-Clause
// Roadside scan decoders: SICK CoLa-B telegrams from the real captures (counts from the shared data README),
// CoLa-A against CoLa-B on the same scan, CARMEN and CSV readers, and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

#include "roadpreview/roadside/sick.hpp"

namespace rs = roadpreview::roadside;
namespace fs = std::filesystem;

namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

fs::path shared_data() {
    if (const char* env = std::getenv("ROADPREVIEW_SHARED_DATA")) return env;
    return fs::path(ROADPREVIEW_SOURCE_DIR).parent_path() / "shared" / "data";
}

fs::path sick_file(const std::string& name) { return shared_data() / "laserscan2d" / "sick_scan_xd" / name; }

#define REQUIRE_FILE(p)                                                        \
    if (!fs::exists(p)) GTEST_SKIP() << (p) << " absent (shared data not here)"

std::string write_file(const std::string& name, const std::string& text) {
    const fs::path dir = fs::temp_directory_path() / "roadpreview_roadside_test";
    fs::create_directories(dir);
    std::ofstream(dir / name, std::ios::binary) << text;
    return (dir / name).string();
}

// The n-th LMDscandata telegram of the LMS1xx dump (CoLa-B), from 0.
std::vector<std::uint8_t> lms111_scan(int n) {
    for (const auto& t : rs::read_sick_json(sick_file("20210302_lms111.pcapng.json").string()))
        if (rs::decode_sick_telegram(t.bytes.data(), t.bytes.size(), t.where) && n-- == 0) return t.bytes;
    return {};
}

std::vector<std::uint8_t> first_lms111_scan() { return lms111_scan(0); }

std::string hex(std::uint32_t v) {
    std::ostringstream s;
    s << std::uppercase << std::hex << v;
    return s.str();
}

std::uint32_t float_bits(float f) {
    std::uint32_t u;
    std::memcpy(&u, &f, 4);
    return u;
}

// The same scan as a CoLa-A telegram, written field by field from the decoded CoLa-B one.
std::vector<std::uint8_t> as_cola_a(const rs::SickScanTelegram& t) {
    std::ostringstream s;
    s << "\x02sSN LMDscandata " << hex(t.version) << ' ' << hex(t.device_number) << ' ' << hex(t.serial_number) << ' '
      << hex(t.device_status[0]) << ' ' << hex(t.device_status[1]) << ' ' << hex(t.telegram_counter) << ' '
      << hex(t.scan_counter) << ' ' << hex(t.time_since_startup_us) << ' ' << hex(t.time_of_transmission_us) << ' '
      << "0 0 " << hex(t.output_status[0]) << " 0 0 " << hex(t.scan_frequency) << ' ' << hex(t.measurement_frequency)
      << " 0 " << t.channels16.size();
    for (const auto& c : t.channels16) {
        s << ' ' << c.name << ' ' << hex(float_bits(c.scale)) << ' ' << hex(float_bits(c.offset)) << ' '
          << hex(static_cast<std::uint32_t>(c.start_angle)) << ' ' << hex(c.step) << ' ' << hex(static_cast<std::uint32_t>(c.data.size()));
        for (auto v : c.data) s << ' ' << hex(v);
    }
    s << " 0 0 0 0 1 7B2 1 1 2 37 22 D90A8 0\x03";
    const std::string text = s.str();
    return {text.begin(), text.end()};
}

}  // namespace

TEST(SickDecoder, Lms111JsonDumpMatchesTheReadme) {
    const auto path = sick_file("20210302_lms111.pcapng.json");
    REQUIRE_FILE(path);
    const auto telegrams = rs::read_sick_json(path.string());
    EXPECT_EQ(telegrams.size(), 277u);
    rs::SickDecodeCounts counts;
    const auto scans = rs::scans_from_telegrams(telegrams, false, &counts);
    // Three scan telegrams (counters 18, 34 and 50) are their scan again, byte for byte, 3 ms later: dropped.
    EXPECT_EQ(counts.scans, 172);
    EXPECT_EQ(counts.repeated, 3);
    EXPECT_EQ(counts.bad, 0);
    ASSERT_EQ(scans.size(), 172u);
    EXPECT_EQ(scans.front().counter, 4);
    EXPECT_EQ(scans.back().counter, 175);
    for (std::size_t i = 1; i < scans.size(); ++i) EXPECT_EQ(scans[i].counter, scans[i - 1].counter + 1);
    for (const auto& s : scans) {
        ASSERT_EQ(s.ranges_m.size(), 541u);
        EXPECT_TRUE(s.intensities.empty());  // DIST1 only
        EXPECT_NEAR(s.start_angle_rad, -135.0 * kDeg, 1e-9);  // −45° in SICK's convention (90° ahead)
        EXPECT_NEAR(s.angle_rad(540), 135.0 * kDeg, 1e-9);
    }
    // First scan's first ranges (mm in the telegram): 93, 80, 86, 89, 82.
    const float first[] = {0.093f, 0.080f, 0.086f, 0.089f, 0.082f};
    for (int i = 0; i < 5; ++i) EXPECT_FLOAT_EQ(scans[0].ranges_m[i], first[i]);
    const auto t = rs::decode_sick_telegram(first_lms111_scan().data(), first_lms111_scan().size(), "first");
    ASSERT_TRUE(t);
    EXPECT_EQ(t->serial_number, 18090362u);
    EXPECT_DOUBLE_EQ(t->scan_frequency_hz(), 50.0);
    EXPECT_EQ(t->measurement_frequency, 360u);  // 36 kHz
    ASSERT_TRUE(t->time);
    EXPECT_EQ(t->time->year, 1970);
}

TEST(SickDecoder, Lms511JsonDumpMatchesTheReadme) {
    const auto path = sick_file("20210302_lms511.pcapng.json");
    REQUIRE_FILE(path);
    rs::SickDecodeCounts counts;
    const auto scans = rs::scans_from_telegrams(rs::read_sick_json(path.string()), false, &counts);
    EXPECT_EQ(counts.telegrams, 277);
    ASSERT_EQ(scans.size(), 174u);
    EXPECT_EQ(scans.front().counter, 54484);
    EXPECT_EQ(scans.back().counter, 54657);
    ASSERT_EQ(scans[0].ranges_m.size(), 1141u);
    ASSERT_EQ(scans[0].intensities.size(), 1141u);  // RSSI1
    EXPECT_NEAR(scans[0].start_angle_rad, -95.0 * kDeg, 1e-9);
    EXPECT_NEAR(scans[0].step_rad, 0.1667 * kDeg, 1e-9);
    EXPECT_FLOAT_EQ(scans[0].ranges_m[0], 1.305f);
    float lo = 1e9f, hi = 0.0f;
    for (const auto& s : scans)
        for (float r : s.ranges_m)
            if (std::isfinite(r)) lo = std::min(lo, r), hi = std::max(hi, r);
    EXPECT_FLOAT_EQ(lo, 0.420f);  // DIST1 420–2919 mm
    EXPECT_FLOAT_EQ(hi, 2.919f);
    // 25 Hz: the scans are 40 ms apart on the capture clock, after the latency correction too.
    std::vector<double> dt;
    for (std::size_t i = 1; i < scans.size(); ++i) dt.push_back(scans[i].time_s - scans[i - 1].time_s);
    std::nth_element(dt.begin(), dt.begin() + dt.size() / 2, dt.end());
    EXPECT_NEAR(dt[dt.size() / 2], 0.040, 0.002);
}

TEST(SickDecoder, PcapngTcpStreamsMatchTheReadme) {
    const auto path = sick_file("example.pcapng");
    REQUIRE_FILE(path);
    rs::SickDecodeCounts counts;
    const auto scans = rs::scans_from_telegrams(rs::read_sick_pcap(path.string()), false, &counts);
    EXPECT_EQ(counts.bad, 0);
    ASSERT_EQ(scans.size(), 766u);
    EXPECT_EQ(scans.front().counter, 44981);
    EXPECT_EQ(scans.back().counter, 45746);
    for (std::size_t i = 1; i < scans.size(); ++i) ASSERT_EQ(scans[i].counter, scans[i - 1].counter + 1);
    EXPECT_EQ(scans[0].ranges_m.size(), 811u);
    EXPECT_EQ(scans[0].intensities.size(), 811u);
    EXPECT_NEAR(scans[0].start_angle_rad, -135.0 * kDeg, 1e-6);
    EXPECT_NEAR(scans.back().time_s - scans.front().time_s, 51.0, 0.1);
    const auto cut = rs::scans_from_telegrams(rs::read_sick_pcap(sick_file("test.pcapng").string()), false);
    ASSERT_EQ(cut.size(), 16u);
    EXPECT_EQ(cut.front().counter, 44981);
    EXPECT_EQ(cut.back().counter, 44996);
    EXPECT_EQ(cut[3].ranges_m, scans[3].ranges_m);  // a byte prefix of the same stream
}

// A poll's answer ("sRA LMDscandata", to "sRN LMDscandata") holds the same fields as the streamed event ("sSN"): a
// scan (it was counted as "other", 277 telegrams and none a scan).
TEST(SickDecoder, APolledScanIsAScan) {
    REQUIRE_FILE(sick_file("20210302_lms111.pcapng.json"));
    auto streamed = first_lms111_scan();
    const auto b = rs::decode_sick_telegram(streamed.data(), streamed.size(), "cola-b");
    ASSERT_TRUE(b);
    std::vector<std::uint8_t> polled_b = streamed, polled_a = as_cola_a(*b);
    polled_b[8 + 1] = 'R', polled_b[8 + 2] = 'A';  // after the 8-byte CoLa-B header: "sSN" → "sRA"
    std::uint8_t checksum = 0;
    for (std::size_t i = 8; i + 1 < polled_b.size(); ++i) checksum ^= polled_b[i];
    polled_b.back() = checksum;
    polled_a[1 + 1] = 'R', polled_a[1 + 2] = 'A';  // after STX
    for (const auto* polled : {&polled_b, &polled_a}) {
        const auto t = rs::decode_sick_telegram(polled->data(), polled->size(), "polled");
        ASSERT_TRUE(t);
        EXPECT_EQ(t->scan_counter, b->scan_counter);
        EXPECT_EQ(rs::to_laser_scan(*t, "polled").ranges_m, rs::to_laser_scan(*b, "streamed").ranges_m);
    }
}

TEST(SickDecoder, ColaAGivesTheSameScanAsColaB) {
    REQUIRE_FILE(sick_file("20210302_lms111.pcapng.json"));
    const auto bytes = first_lms111_scan();
    const auto b = rs::decode_sick_telegram(bytes.data(), bytes.size(), "cola-b");
    ASSERT_TRUE(b);
    const auto ascii = as_cola_a(*b);
    const auto a = rs::decode_sick_telegram(ascii.data(), ascii.size(), "cola-a");
    ASSERT_TRUE(a);
    EXPECT_EQ(a->framing, rs::ColaFraming::A);
    EXPECT_EQ(a->scan_counter, b->scan_counter);
    EXPECT_EQ(a->serial_number, b->serial_number);
    EXPECT_EQ(a->channels16[0].start_angle, -450000);
    EXPECT_EQ(a->channels16[0].data, b->channels16[0].data);
    EXPECT_EQ(rs::to_laser_scan(*a, "a").ranges_m, rs::to_laser_scan(*b, "b").ranges_m);
    // The framer finds both framings in one stream, with garbage between them.
    rs::SickStreamFramer framer;
    std::vector<std::uint8_t> stream = {'x', 'y'};
    stream.insert(stream.end(), bytes.begin(), bytes.end());
    stream.insert(stream.end(), ascii.begin(), ascii.end());
    std::vector<std::uint8_t> frame;
    int frames = 0;
    for (std::size_t i = 0; i < stream.size(); i += 100) {
        framer.feed(stream.data() + i, std::min<std::size_t>(100, stream.size() - i));
        while (framer.next(frame)) ++frames;
    }
    EXPECT_EQ(frames, 2);
    EXPECT_EQ(framer.skipped_bytes(), 2u);
}

TEST(SickDecoder, BadTelegramsAreClearErrors) {
    REQUIRE_FILE(sick_file("20210302_lms111.pcapng.json"));
    auto bytes = first_lms111_scan();
    auto expect_error = [](const std::vector<std::uint8_t>& b, const std::string& needle) {
        try {
            rs::decode_sick_telegram(b.data(), b.size(), "telegram 7");
            ADD_FAILURE() << "no error for " << needle;
        } catch (const std::runtime_error& e) {
            EXPECT_NE(std::string(e.what()).find("telegram 7"), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
        }
    };
    auto corrupt = bytes;
    corrupt[100] ^= 0x40;
    expect_error(corrupt, "checksum");
    auto truncated = std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + 300);
    expect_error(truncated, "length field");
    // A consistent frame whose channel declares more beams than it holds: fix up length and checksum.
    auto lying = std::vector<std::uint8_t>(bytes.begin(), bytes.end() - 1);
    lying.resize(200);
    const std::uint32_t length = static_cast<std::uint32_t>(lying.size() - 8);
    for (int i = 0; i < 4; ++i) lying[4 + i] = static_cast<std::uint8_t>(length >> (24 - 8 * i));
    std::uint8_t x = 0;
    for (std::size_t i = 8; i < lying.size(); ++i) x ^= lying[i];
    lying.push_back(x);
    expect_error(lying, "truncated telegram");
    const std::string ascii = "\x02sSN LMDscandata 1 1 ZZ\x03";
    expect_error({ascii.begin(), ascii.end()}, "malformed number");
    // skip_bad counts it and goes on.
    std::vector<rs::TimedTelegram> list = {{0.0, bytes, "ok"}, {0.1, corrupt, "bad"}, {0.2, lms111_scan(1), "ok2"}};
    rs::SickDecodeCounts counts;
    EXPECT_EQ(rs::scans_from_telegrams(list, true, &counts).size(), 2u);
    EXPECT_EQ(counts.bad, 1);
    // The last scan once more is that scan received twice, not a new one.
    list.push_back({0.3, lms111_scan(1), "again"});
    EXPECT_EQ(rs::scans_from_telegrams(list, true, &counts).size(), 2u);
    EXPECT_EQ(counts.repeated, 1);
    EXPECT_THROW(rs::scans_from_telegrams(list, false), std::runtime_error);
}

TEST(CarmenLog, FreiburgCampusMatchesTheReadme) {
    const auto path = shared_data() / "laserscan2d" / "carmen_freiburg_campus" / "freiburg-campus-corrected.log.gz";
    REQUIRE_FILE(path);
    bool missing = false;
    const auto scans = rs::read_carmen_log(path.string(), 5.0, 0.0, &missing);
    ASSERT_EQ(scans.size(), 2008u);
    EXPECT_TRUE(missing);  // every timestamp is 0
    EXPECT_DOUBLE_EQ(scans[10].time_s, 2.0);
    std::size_t readings = 0, no_return = 0;
    for (const auto& s : scans) {
        ASSERT_EQ(s.ranges_m.size(), 360u);
        ASSERT_TRUE(s.pose);
        readings += s.ranges_m.size();
        for (float r : s.ranges_m) no_return += !std::isfinite(r);
    }
    EXPECT_NEAR(scans[0].step_rad, 0.5 * kDeg, 1e-12);
    EXPECT_NEAR(scans[0].start_angle_rad, -90.0 * kDeg, 1e-12);
    // 25.9 % of readings are ≥ 80 m; the log's maximum is 80.99 m, so those at or beyond are no return.
    EXPECT_NEAR(static_cast<double>(no_return) / readings, 0.259, 0.01);
}

TEST(CarmenLog, AScanRateNoScannerHasIsAnErrorNamingTheLog) {  // 1e-300 Hz once timed every scan at infinity
    const auto log = write_file("rate.log", "FLASER 2 1.0 1.0 0 0 0 0 0 0 0 0 host 0\n");
    for (const double rate : {1e-300, 0.0, 1e6, std::numeric_limits<double>::quiet_NaN()}) {
        try {
            rs::read_carmen_log(log, rate);
            FAIL() << rate;
        } catch (const std::invalid_argument& e) {
            EXPECT_NE(std::string(e.what()).find("rate.log: the CARMEN scan rate must be within 0.001–100000 Hz"),
                      std::string::npos) << e.what();
        }
    }
    EXPECT_EQ(rs::read_carmen_log(log, 37.5).size(), 1u);
}

TEST(ScanCsv, ReadsScansAndRefusesBadRows) {
    const auto ok = write_file("ok.csv",
                               "t,scanner,angle_deg,range_m,intensity\n"
                               "0.0,0,-1.0,5.0,10\n0.0,0,-0.5,,0\n0.0,0,0.0,nan,0\n0.0,1,10,2.0,1\n0.0,1,11,2.5,1\n"
                               "0.1,0,-1.0,5.5,3\n");
    const auto scans = rs::read_scan_csv(ok);
    ASSERT_EQ(scans.size(), 3u);
    EXPECT_EQ(scans[0].ranges_m.size(), 3u);
    EXPECT_TRUE(std::isnan(scans[0].ranges_m[1]) && std::isnan(scans[0].ranges_m[2]));
    EXPECT_EQ(scans[1].scanner, 1);
    EXPECT_NEAR(scans[1].step_rad, 1.0 * kDeg, 1e-12);
    EXPECT_EQ(scans[2].intensities, std::vector<float>{3.0f});
    const auto uneven = write_file("uneven.csv", "t,scanner,angle_deg,range_m\n0,0,0,1\n0,0,1,1\n0,0,3,1\n");
    EXPECT_THROW(
        {
            try {
                rs::read_scan_csv(uneven);
            } catch (const std::runtime_error& e) {
                EXPECT_NE(std::string(e.what()).find("uneven.csv:4"), std::string::npos) << e.what();
                throw;
            }
        },
        std::runtime_error);
    EXPECT_THROW(rs::read_scan_csv(write_file("header.csv", "t,angle_deg,range_m\n0,0,1\n")), std::runtime_error);
    EXPECT_THROW(rs::read_scan_csv(write_file("inf.csv", "t,scanner,angle_deg,range_m\ninf,0,0,1\n")), std::runtime_error);
}
