// Velodyne: the bundled recordings' models, sweeps and returns; known answers on hand-made packets for the
// geometry, the azimuth interpolation, the sweep cut, HDL-64E calibration files and dual-return packets.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>

#include <roadpreview/io/readers.hpp>
#include <roadpreview/io/velodyne.hpp>

namespace rp = roadpreview;

namespace {

const std::string kVelodyne = std::string(ROADPREVIEW_TEST_DATA) + "/velodyne/";
constexpr double kPi = 3.14159265358979323846;

struct Summary {
    std::string model;
    std::size_t sweeps = 0, complete = 0;
    Eigen::Index points = 0;
};

Summary summarize(const std::string& pcap, const rp::SourceOptions& o = {}) {
    auto source = rp::open_frames({kVelodyne + pcap}, o);
    Summary s;
    while (auto f = source->next()) {
        ++s.sweeps;
        s.complete += f->diagnostics.complete;
        s.points += f->points.rows();
        EXPECT_EQ(f->point_times.size(), static_cast<std::size_t>(f->points.rows()));
        if (!f->point_times.empty()) {
            EXPECT_GE(*std::min_element(f->point_times.begin(), f->point_times.end()), 0.0f);
            EXPECT_LT(*std::max_element(f->point_times.begin(), f->point_times.end()), 0.2f);
        }
    }
    s.model = source->info().sensor_model;
    return s;
}

// A VLP-16 packet: block b at azimuth az0 + b·step (0.01°), every channel at `raw` (2 mm units).
std::vector<std::uint8_t> vlp16_packet(int az0, int step, std::uint16_t raw, std::uint32_t time_us,
                                       std::uint8_t mode = 0x37, std::uint8_t product = 0x22) {
    std::vector<std::uint8_t> p(1206, 0);
    for (int b = 0; b < 12; ++b) {
        std::uint8_t* block = &p[100 * b];
        const std::uint16_t flag = 0xEEFF, az = static_cast<std::uint16_t>((az0 + b * step) % 36000);
        std::memcpy(block, &flag, 2);
        std::memcpy(block + 2, &az, 2);
        for (int c = 0; c < 32; ++c) {
            std::memcpy(block + 4 + 3 * c, &raw, 2);
            block[4 + 3 * c + 2] = static_cast<std::uint8_t>(c);
        }
    }
    std::memcpy(&p[1200], &time_us, 4);
    p[1204] = mode;
    p[1205] = product;
    return p;
}

}  // namespace

TEST(Velodyne, BundledRecordingsDecodeWithTheirModelsAndEveryReturn) {
    // Returns (channels with a distance) from the shared data README: 31630 and 19579.
    Summary s = summarize("velodyne_example.pcap");
    EXPECT_EQ(s.model, "VLP-16");
    EXPECT_EQ(s.points, 31630);
    EXPECT_EQ(s.sweeps, 2u);  // 1.11 rotations: the cut at 0° splits them in two partial sweeps
    s = summarize("velodyne_vlp16.pcap");  // its factory byte says HDL-32E; the firing timing says VLP-16
    EXPECT_EQ(s.model, "VLP-16");
    EXPECT_EQ(s.points, 19579);
    s = summarize("hdl32_example.pcap");  // 5.7 rotations
    EXPECT_EQ(s.model, "HDL-32E");
    EXPECT_EQ(s.points, 252057);
    EXPECT_EQ(s.sweeps, 7u);
    EXPECT_EQ(s.complete, 5u);
    s = summarize("velodyne_vlp32.pcap");  // HDL-32E data despite its name, 0.6 rotation
    EXPECT_EQ(s.model, "HDL-32E");
    EXPECT_EQ(s.sweeps, 2u);  // crosses the cut angle once
}

TEST(Velodyne, TheModelOptionOverridesThePacketsAndItsChoiceIsReported) {
    rp::SourceOptions o;
    o.sensor_model = "hdl-32e";
    auto source = rp::open_frames({kVelodyne + "velodyne_vlp16.pcap"}, o);
    source->next();
    EXPECT_EQ(source->info().sensor_model, "HDL-32E");
    auto detected = rp::open_frames({kVelodyne + "velodyne_vlp16.pcap"});
    detected->next();
    ASSERT_FALSE(detected->info().notes.empty());
    EXPECT_NE(detected->info().notes[0].find("HDL-32E"), std::string::npos);
    EXPECT_NE(detected->info().notes[0].find("decoded as VLP-16"), std::string::npos);
    o.sensor_model = "VLP-64";
    EXPECT_THROW(rp::open_frames({kVelodyne + "velodyne_vlp16.pcap"}, o), std::invalid_argument);
}

TEST(Velodyne, CompleteSweepsCoverOneTurnWhateverTheCutAngle) {
    for (double cut : {0.0, 90.0, 271.5}) {
        rp::SourceOptions o;
        o.cut_angle_deg = cut;
        auto source = rp::open_frames({kVelodyne + "hdl32_example.pcap"}, o);
        while (auto f = source->next()) {
            if (!f->diagnostics.complete) continue;
            // Azimuth of each point in the manual's convention (clockwise from ahead), relative to the cut.
            double lo = 360, hi = 0;
            for (Eigen::Index i = 0; i < f->points.rows(); ++i) {
                const double az = std::atan2(-f->points(i, 1), f->points(i, 0)) * 180 / kPi;
                const double rel = std::fmod(az - cut + 720.0, 360.0);
                lo = std::min(lo, rel);
                hi = std::max(hi, rel);
            }
            EXPECT_LT(lo, 0.5) << cut;
            EXPECT_GT(hi, 359.5) << cut;
        }
    }
}

TEST(Velodyne, Vlp16GeometryAndAzimuthInterpolation) {
    rp::VelodyneDecoder d(rp::VelodyneModel::Vlp16, rp::default_velodyne_calibration(rp::VelodyneModel::Vlp16));
    std::vector<rp::Frame> done;
    const auto p = vlp16_packet(9000, 40, 5000, 0);  // 10 m at 90° (to the right), 0.4° per block
    d.add_packet(p.data(), p.size(), 100.0, done);
    EXPECT_TRUE(done.empty());
    const auto f = d.finish();
    ASSERT_TRUE(f);
    ASSERT_EQ(f->points.rows(), 12 * 32);
    EXPECT_EQ(*f->timestamp, 100.0);
    // Channel k of sequence q in block b fires at 110.592 b + 55.296 q + 2.304 k µs.
    const double vert[16] = {-15, 1, -13, 3, -11, 5, -9, 7, -7, 9, -5, 11, -3, 13, -1, 15};
    for (int b : {0, 5}) {
        for (int q : {0, 1}) {
            for (int k : {0, 7, 15}) {
                const Eigen::Index i = b * 32 + q * 16 + k;
                const double az = (90.0 + 0.4 * b + 0.4 * (55.296 * q + 2.304 * k) / 110.592) * kPi / 180;
                const double v = vert[k] * kPi / 180;
                EXPECT_NEAR(f->points(i, 0), 10.0 * std::cos(v) * std::cos(az), 1e-4);
                EXPECT_NEAR(f->points(i, 1), -10.0 * std::cos(v) * std::sin(az), 1e-4);
                EXPECT_NEAR(f->points(i, 2), 10.0 * std::sin(v), 1e-4);
                EXPECT_NEAR(f->point_times[static_cast<std::size_t>(i)], 1e-6 * (110.592 * b + 55.296 * q + 2.304 * k), 1e-7);
                EXPECT_EQ(f->points(i, 3), static_cast<float>(q * 16 + k));
            }
        }
    }
}

TEST(Velodyne, SweepsAreCutWhereTheAzimuthCrossesTheCutAngle) {
    rp::VelodyneDecoder d(rp::VelodyneModel::Vlp16, rp::default_velodyne_calibration(rp::VelodyneModel::Vlp16), 10.0);
    std::vector<rp::Frame> done;
    // Packets of 12 blocks at 0.4°: from 5.2° on, block 12 of the first packet crosses 10°.
    int az = 520;
    for (int i = 0; i < 3; ++i, az += 480) {
        const auto p = vlp16_packet(az, 40, 5000, static_cast<std::uint32_t>(1327 * i));
        d.add_packet(p.data(), p.size(), i, done);
    }
    ASSERT_EQ(done.size(), 1u);
    EXPECT_FALSE(done[0].diagnostics.complete);  // began with the file
    // Firings before 10°: blocks at 5.2 … 9.6° (12 blocks) carry sequences whose azimuth is < 10°.
    EXPECT_EQ(done[0].points.rows() % 16, 0);
    EXPECT_GT(done[0].points.rows(), 0);
    EXPECT_EQ(done[0].points.rows() + d.finish()->points.rows(), 3 * 12 * 32);
}

TEST(Velodyne, DualReturnPacketsGiveTheLastReturn) {
    rp::VelodyneDecoder d(rp::VelodyneModel::Vlp16, rp::default_velodyne_calibration(rp::VelodyneModel::Vlp16));
    std::vector<rp::Frame> done;
    auto p = vlp16_packet(0, 0, 5000, 0, 0x39);
    for (int b = 0; b < 12; b += 2) {  // pairs share an azimuth; odd blocks (strongest) at another range
        const std::uint16_t az = static_cast<std::uint16_t>(40 * b);
        std::memcpy(&p[100 * b + 2], &az, 2);
        std::memcpy(&p[100 * (b + 1) + 2], &az, 2);
        for (int c = 0; c < 32; ++c) {
            const std::uint16_t other = 2500;
            std::memcpy(&p[100 * (b + 1) + 4 + 3 * c], &other, 2);
        }
    }
    d.add_packet(p.data(), p.size(), 0.0, done);
    const auto f = d.finish();
    ASSERT_EQ(f->points.rows(), 6 * 32);
    for (Eigen::Index i = 0; i < f->points.rows(); ++i) EXPECT_NEAR(f->points.row(i).head<3>().norm(), 10.0, 1e-4);
}

TEST(Velodyne, Hdl64eUsesItsCalibrationFile) {
    EXPECT_THROW(rp::default_velodyne_calibration(rp::VelodyneModel::Hdl64e), std::invalid_argument);
    const std::string path = testing::TempDir() + "hdl64.yaml";
    {
        std::ofstream y(path);
        y << "distance_resolution: 0.002\nnum_lasers: 64\nlasers:\n";
        for (int id = 0; id < 64; ++id)
            y << "- {laser_id: " << id << ", rot_correction: " << (id == 40 ? 0.1 : 0.0) << ", vert_correction: "
              << (id == 40 ? -0.2 : 0.0) << ", dist_correction: 0.5, vert_offset_correction: 0.1, "
              << "horiz_offset_correction: 0.0}\n";
    }
    const rp::VelodyneCalibration c = rp::read_velodyne_calibration(path);
    ASSERT_EQ(c.lasers.size(), 64u);
    rp::VelodyneDecoder d(rp::VelodyneModel::Hdl64e, c);
    auto p = vlp16_packet(0, 0, 0, 0, 0x37, 0x00);
    for (int b = 1; b < 12; b += 2) {
        const std::uint16_t lower = 0xDDFF;
        std::memcpy(&p[100 * b], &lower, 2);
    }
    const std::uint16_t raw = 5000;  // laser 32 + 8 = 40: the 9th channel of a lower block
    std::memcpy(&p[100 * 1 + 4 + 3 * 8], &raw, 2);
    std::vector<rp::Frame> done;
    d.add_packet(p.data(), p.size(), 0.0, done);
    const auto f = d.finish();
    ASSERT_EQ(f->points.rows(), 1);
    // distance 10 + 0.5 m; azimuth 0 − 0.1 rad; elevation −0.2 rad; the beam origin 0.1 m up.
    const double r = 10.5, a = -0.1, v = -0.2;
    const double xy = r * std::cos(v) - 0.1 * std::sin(v);
    EXPECT_NEAR(f->points(0, 0), xy * std::cos(a), 1e-4);
    EXPECT_NEAR(f->points(0, 1), -xy * std::sin(a), 1e-4);
    EXPECT_NEAR(f->points(0, 2), r * std::sin(v) + 0.1 * std::cos(v), 1e-4);
    EXPECT_THROW(rp::VelodyneDecoder(rp::VelodyneModel::Vlp16, c), std::invalid_argument);  // 64 lasers ≠ 16
}

TEST(Velodyne, BadPacketsAreErrorsNotCrashes) {
    rp::VelodyneDecoder d(rp::VelodyneModel::Vlp16, rp::default_velodyne_calibration(rp::VelodyneModel::Vlp16));
    std::vector<rp::Frame> done;
    auto p = vlp16_packet(0, 40, 5000, 0);
    EXPECT_THROW(d.add_packet(p.data(), 1205, 0.0, done), std::invalid_argument);
    p[500] = 0x12;  // block 5's flag
    EXPECT_THROW(d.add_packet(p.data(), p.size(), 0.0, done), std::invalid_argument);
}

namespace {

rp::SensorRoi roi_ahead(double x_m, double height_m) {
    rp::Config cfg;
    cfg.extrinsics = rp::Extrinsics{x_m, 0.0, height_m, 0.0, 0.0, 0.0};
    return rp::sensor_roi(cfg, 1.0);
}

}  // namespace

TEST(VelodyneRoiColumns, TheSweepEndsWhereTheRegionHasBeenScanned) {
    // A VLP-16 (no azimuth offsets) at the base origin sees the region x ∈ [1, 40] m, |y| ≤ 10 m within
    // atan2(10, 1) = 84.29° of ahead: the first firing azimuth past that arc, clockwise, is 84.3°.
    const rp::VelodyneCalibration vlp16 = rp::default_velodyne_calibration(rp::VelodyneModel::Vlp16);
    const auto cut = rp::velodyne_cut_after({roi_ahead(0.0, 1.8)}, vlp16);
    ASSERT_TRUE(cut);
    EXPECT_DOUBLE_EQ(*cut, 84.3);
    // A sensor 5 m behind the base origin sees it within atan2(10, 6) = 59.04° of ahead.
    EXPECT_DOUBLE_EQ(*rp::velodyne_cut_after({roi_ahead(-5.0, 1.8)}, vlp16), 59.1);
    // Inside the region (its edge x = 1 m), every azimuth can see it: no cut is better than another.
    EXPECT_FALSE(rp::velodyne_cut_after({roi_ahead(1.0, 1.8)}, vlp16));
}

TEST(VelodyneRoiColumns, EverySweepHoldsTheRegionWholeAndEndsAfterIt) {
    rp::SourceOptions o;
    o.roi_columns = {roi_ahead(0.0, 1.8)};
    auto source = rp::open_frames({kVelodyne + "hdl32_example.pcap"}, o);
    int complete = 0;
    while (auto f = source->next()) {
        if (!f->diagnostics.complete) continue;
        ++complete;
        // The region's points are the sweep's last: none before the sweep's middle, and the last of all among them.
        float first_in = 1e9f, last_in = 0.0f, last = 0.0f;
        for (Eigen::Index i = 0; i < f->points.rows(); ++i) {
            const float t = f->point_times[static_cast<std::size_t>(i)];
            last = std::max(last, t);
            if (f->points(i, 0) >= 1.0f && f->points(i, 0) <= 40.0f && std::abs(f->points(i, 1)) <= 10.0f)
                first_in = std::min(first_in, t), last_in = std::max(last_in, t);
        }
        EXPECT_GT(first_in, 0.4f * last);
        EXPECT_GT(last_in, 0.99f * last);
    }
    EXPECT_GT(complete, 3);
    const auto& notes = source->info().notes;
    EXPECT_TRUE(std::any_of(notes.begin(), notes.end(),
                            [](const std::string& n) { return n.find("sweeps end at 84.3°") != std::string::npos; }));
}

TEST(VelodyneRoiColumns, ARegionNoAzimuthCanSeeIsAnError) {
    // A spinning sensor sees every direction; only lasers without a direction (a broken calibration) see none.
    rp::VelodyneCalibration broken = rp::default_velodyne_calibration(rp::VelodyneModel::Vlp16);
    for (auto& laser : broken.lasers) laser.vert_correction = std::nan("");
    EXPECT_THROW(rp::velodyne_cut_after({roi_ahead(0.0, 1.8)}, broken), std::invalid_argument);
}
