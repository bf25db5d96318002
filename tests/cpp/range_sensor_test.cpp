// SPDX-License-Identifier: BSD-3-Clause
// Point range sensors: calibration known answers, streamed readings and their errors, placement, windows.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>

#include "roadpreview/range_sensor/range_sensor.hpp"

namespace rp = roadpreview;
namespace fs = std::filesystem;

namespace {

std::string write_file(const std::string& name, const std::string& text) {
    const fs::path dir = fs::temp_directory_path() / "roadpreview_range_sensor_test";
    fs::create_directories(dir);
    const fs::path p = dir / name;
    std::ofstream(p) << text;
    return p.string();
}

std::vector<rp::RangeSensor> one_laser(double x_m = 0.5, double height_m = 0.3) {
    rp::RangeSensor s;
    s.id = "l1";
    s.kind = rp::RangeKind::Laser;
    s.x_m = x_m;
    s.y_m = 0.8;
    s.height_m = height_m;
    s.max_count = 1000;
    return {s};
}

// A bench-like profile: a triangle and an arc on flat ground, sampled every mm over [−1, 5] m.
rp::ReferenceProfile bench_like() {
    rp::ReferenceProfile ref;
    for (double x = -1.0; x <= 5.0; x += 0.001) {
        double z = 0.0;
        if (x > 1.0 && x < 1.3) z = 0.04 * (x - 1.0) / 0.3;
        if (x >= 1.3 && x < 1.35) z = 0.04 * (1.35 - x) / 0.05;
        if (std::abs(x - 2.5) < 0.2) z = 0.03 * std::cos(M_PI * (x - 2.5) / 0.4);
        ref.x_m.push_back(x);
        ref.z_m.push_back(z);
    }
    return ref;
}

double ref_at(const rp::ReferenceProfile& ref, double x) {
    const auto i = static_cast<std::size_t>(std::lround((x - ref.x_m.front()) / 0.001));
    return ref.z_m[std::min(i, ref.z_m.size() - 1)];
}

// Exact samples of a run at speed v whose readings lie `shift` ahead of where the axle was.
std::vector<rp::RangeSample> run_over(const rp::ReferenceProfile& ref, double v, double shift) {
    std::vector<rp::RangeSample> out;
    for (double axle = -0.5; axle < 3.5; axle += 0.004) {
        rp::RangeSample s;
        s.s_m = axle;
        s.z_m = ref_at(ref, axle + shift);
        s.speed_mps = v;
        out.push_back(s);
    }
    return out;
}

// A run's sample positions and heights, as register_run takes them.
struct RunXz {
    std::vector<double> x, z;
};
RunXz xz_of(const std::vector<rp::RangeSample>& samples) {
    RunXz out;
    for (const auto& s : samples) {
        out.x.push_back(s.s_m);
        out.z.push_back(s.z_m);
    }
    return out;
}

}  // namespace

TEST(RangeSensor, SpeedOfSound) {
    EXPECT_NEAR(rp::speed_of_sound_mps(0.0), 331.3, 1e-12);
    EXPECT_NEAR(rp::speed_of_sound_mps(20.0), 343.2, 0.05);
}

TEST(RangeSensor, DistanceCalibrationExactAndOutlier) {
    std::vector<double> c, d;
    for (int i = 0; i < 50; ++i) {
        c.push_back(800 + 40.0 * i);
        d.push_back(1.716e-4 * c.back() + 0.005);
    }
    rp::DistanceCalibration cal = rp::calibrate_distance(c, d);
    EXPECT_NEAR(cal.a1, 1.716e-4, 1e-12);
    EXPECT_NEAR(cal.a2, 0.005, 1e-9);
    EXPECT_EQ(cal.rejected, 0);
    EXPECT_NEAR(cal.r_squared, 1.0, 1e-12);
    d[7] += 0.05;  // one gross error leaves the fit
    cal = rp::calibrate_distance(c, d);
    EXPECT_EQ(cal.rejected, 1);
    EXPECT_NEAR(cal.a1, 1.716e-4, 1e-12);
    EXPECT_THROW(rp::calibrate_distance({1000, 1000, 1000}, {0.1, 0.1, 0.1}), std::invalid_argument);
}

TEST(RangeSensor, CountsFollowTheSpeedOfSound) {
    rp::DistanceCalibration cal;
    cal.a1 = 1e-4;
    cal.a2 = 0.0;
    cal.temperature_c = 20.0;
    EXPECT_DOUBLE_EQ(rp::distance_of_count(cal, 1000, NAN), 0.1);
    EXPECT_NEAR(rp::distance_of_count(cal, 1000, 0.0), 0.1 * 331.3 / rp::speed_of_sound_mps(20.0), 1e-15);
}

TEST(RangeSensor, LayoutErrorsNameFileAndSensor) {
    const std::string ok = write_file("ok.yaml",
        "sensors:\n  - {id: a, kind: ultrasonic, wheel: left, x_m: 0.5, y_m: 0.8, "
                                                 "height_m: 0.3, pitch_deg: 0, beam_half_angle_deg: 12}\n");
    const auto layout = rp::read_range_layout(ok);
    ASSERT_EQ(layout.size(), 1u);
    EXPECT_EQ(layout[0].kind, rp::RangeKind::Ultrasonic);
    const std::string bad = write_file("bad.yaml",
        "sensors:\n  - {id: a, kind: radar, wheel: left, x_m: 0.5, y_m: 0.8, "
                                                   "height_m: 0.3}\n");
    try {
        rp::read_range_layout(bad);
        FAIL();
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("bad.yaml"), std::string::npos);
        EXPECT_NE(std::string(e.what()).find("sensor 'a'"), std::string::npos);
    }
}

TEST(RangeSensor, ReadingErrorsNameFileAndLine) {
    const auto layout = one_laser();
    const auto expect_error = [&](const std::string& body, const std::string& fragment) {
        const std::string path = write_file("r.csv", "t,sensor,count\n" + body);
        rp::RangeReadingReader reader(path, layout);
        rp::RangeReadingReader::Reading r;
        try {
            while (reader.next(r)) {
            }
            FAIL() << "no error for " << body;
        } catch (const std::runtime_error& e) {
            EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("r.csv:3:"), std::string::npos) << e.what();
        }
    };
    expect_error("0.0,l1,10\n0.1,zz,10\n", "unknown sensor id 'zz'");
    expect_error("0.2,l1,10\n0.1,l1,10\n", "time goes backwards");
    expect_error("0.0,l1,10\n0.1,l1,nan\n", "not a finite number");
    expect_error("0.0,l1,10\n0.1,l1,5000\n", "outside the layout's range");
}

// A reader refusing a file's header closes the file (it leaked one descriptor per refused file, found by fuzzing:
// a long-lived process reading many bad files ran out of descriptors).
TEST(RangeSensor, AReadingsFileWithABadHeaderIsClosed) {
    const auto open_descriptors = [] {
        return std::distance(fs::directory_iterator("/proc/self/fd"), fs::directory_iterator{});
    };
    const auto layout = one_laser();
    const std::string path = write_file("no_header.csv", "time,id,value\n0.0,l1,10\n");
    const auto before = open_descriptors();
    for (int k = 0; k < 50; ++k) EXPECT_THROW(rp::RangeReadingReader(path, layout), std::runtime_error);
    EXPECT_EQ(open_descriptors(), before);
}

TEST(RangeSensor, ReadingsOutsideTheMotionTableNameTheReadingsFile) {
    const auto layout = one_laser();
    const std::string motion = write_file("m.csv", "t,speed,yaw_rate\n0,1,0\n1,1,0\n");
    const std::string readings = write_file("late.csv", "t,sensor,distance\n0.5,l1,0.3\n1.5,l1,0.3\n");
    try {
        rp::read_range_samples(readings, layout, {}, rp::RangeMotion(rp::MotionTable::read_csv(motion)));
        FAIL();
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("late.csv:3"), std::string::npos) << e.what();
    }
}

TEST(RangeSensor, PlacementKnownAnswer) {
    const auto layout = one_laser(0.5, 0.3);
    const std::string readings = write_file("p.csv", "t,sensor,distance\n10.0,l1,0.30\n10.5,l1,0.28\n");
    const auto s = rp::read_range_samples(readings, layout, {}, rp::RangeMotion(2.0, 0.0));
    ASSERT_EQ(s.size(), 2u);
    EXPECT_NEAR(s[0].s_m, 0.5, 1e-12);  // the start: the axle at 0, the beam 0.5 m ahead
    EXPECT_NEAR(s[1].s_m, 1.5, 1e-12);
    EXPECT_NEAR(s[1].z_m, 0.02, 1e-12);
    EXPECT_NEAR(s[1].time_to_wheel_s, 0.25, 1e-12);
}

TEST(RangeSensor, MotionTableDistanceIsTheExactIntegral) {
    const std::string motion = write_file("acc.csv", "t,speed,yaw_rate\n0,0,0\n2,4,0.2\n");
    const rp::MotionTable table = rp::MotionTable::read_csv(motion);
    EXPECT_NEAR(table.distance_m(1.0), 1.0, 1e-12);  // v = 2t → t²
    EXPECT_NEAR(table.heading_rad(2.0), 0.2, 1e-12);
}

TEST(RangeSensor, IcpAndCrossCorrelationFindAKnownShift) {
    const rp::ReferenceProfile ref = bench_like();
    const RunXz run = xz_of(run_over(ref, 0.5, 0.4321));
    const rp::RunShift r = rp::register_run(run.x, run.z, ref.x_m, ref.z_m, 0.5, 0.3);
    EXPECT_NEAR(r.shift_m, 0.4321, 0.001);
    EXPECT_NEAR(r.xcorr_shift_m, 0.4321, 0.002);
    EXPECT_LT(r.rms_m, 0.001);
}

// A reference whose heights lean by 5 mm/m against the run's (a fused map's levelled datum): with the tilt free
// (and the cross-correlation detrended) the shift is found as on the exact reference; a shift and an offset alone
// take part of the lean for a shift.
TEST(RangeSensor, IcpFitsTheTiltOfALeaningReference) {
    const rp::ReferenceProfile ref = bench_like();
    const RunXz run = xz_of(run_over(ref, 0.5, 0.4321));
    std::vector<double> leaning = ref.z_m;
    for (std::size_t i = 0; i < leaning.size(); ++i) leaning[i] += 0.005 * ref.x_m[i];
    const rp::RunShift tilted = rp::register_run(run.x, run.z, ref.x_m, leaning, 0.5, 0.3, true);
    EXPECT_NEAR(tilted.shift_m, 0.4321, 0.001);
    EXPECT_NEAR(tilted.xcorr_shift_m, 0.4321, 0.002);  // the partial correlation given x
    EXPECT_LT(tilted.rms_m, 0.001);
    const rp::RunShift rigid = rp::register_run(run.x, run.z, ref.x_m, leaning, 0.5, 0.3, false);
    EXPECT_GT(std::abs(rigid.shift_m - 0.4321), 0.005);  // 17 mm here
    EXPECT_GT(rigid.rms_m, 3.0 * tilted.rms_m);
}

TEST(RangeSensor, OffsetCalibrationExactOnNoiseFreeRuns) {
    const rp::ReferenceProfile ref = bench_like();
    const double b1 = -0.02, b2 = 0.45;
    const std::vector<std::vector<rp::RangeSample>> runs = {run_over(ref, 0.2, b1 * 0.2 + b2), run_over(ref, 1.0,
        b1 * 1.0 + b2)};
    const rp::OffsetCalibration o = rp::calibrate_offset(runs, {"slow", "fast"}, {ref}, 0.5, 0.3);
    EXPECT_NEAR(o.b1_s, b1, 0.002);
    EXPECT_NEAR(o.b2_m, b2, 0.002);  // point-to-point ICP on a 0.5 mm target spacing: about 1 mm per shift
    EXPECT_NEAR(o.b1_xcorr_s, b1, 0.003);
    EXPECT_THROW(rp::calibrate_offset({runs[0], runs[0]}, {"a", "b"}, {ref}, 0.5, 0.3), std::invalid_argument);
}

TEST(RangeSensor, ProfilerWindowsAndBins) {
    const auto layout = one_laser(0.5, 0.3);
    std::string text = "t,sensor,distance\n";
    for (int i = 0; i < 20000; ++i) {  // 10 m/s for 20 s at 1 kHz: 200 m
        const double t = i * 0.001;
        const double s = 10.0 * t + 0.5;
        text += std::to_string(t) + ",l1," + std::to_string(0.3 - 0.01 * std::sin(2 * M_PI * s / 5.0)) + "\n";
    }
    const std::string readings = write_file("long.csv", text);
    rp::RangeProfiler profiler(layout, {});
    std::vector<rp::RangeWindow> windows;
    const auto n = profiler.run(readings, rp::RangeMotion(10.0, 0.0),
        [&](const rp::RangeWindow& w) { windows.push_back(w); });
    EXPECT_EQ(n, 20000);
    ASSERT_EQ(windows.size(), 6u);  // 0.5 … 200.5 m in 40 m windows
    const rp::Profile& p = windows[1].left;
    ASSERT_EQ(p.z.size(), 400u);
    EXPECT_NEAR(p.z[25], 0.01 * std::sin(2 * M_PI * p.s[25] / 5.0), 1e-3);
    EXPECT_EQ(windows[1].reason, "no right-wheel samples");
    EXPECT_TRUE(windows[1].left.roughness.iri.value.has_value());
}
