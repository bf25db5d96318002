// Motion input: the motion CSV (interpolation, errors) and the IMU yaw rate in the base frame.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <vector>

#include <roadpreview/paths/motion.hpp>

namespace rp = roadpreview;

namespace {

std::string write(const std::string& name, const std::string& text) {
    const std::string path = testing::TempDir() + name;
    std::ofstream(path) << text;
    return path;
}

std::string error_of(const std::string& path) {
    try {
        rp::MotionTable::read_csv(path);
    } catch (const std::runtime_error& e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST(Motion, CsvIsInterpolatedLinearlyInTime) {
    const auto table = rp::MotionTable::read_csv(write("m.csv", "# drive\nyaw_rate, t, speed, note\n0.0, 10, 2, a\n0.2, 12, 4, b\n"));
    const rp::Motion m = table.at(10.5);
    EXPECT_DOUBLE_EQ(m.speed_mps, 2.5);
    EXPECT_DOUBLE_EQ(m.yaw_rate_rps, 0.05);
    EXPECT_DOUBLE_EQ(table.at(12).speed_mps, 4.0);
    EXPECT_DOUBLE_EQ(table.at(10).yaw_rate_rps, 0.0);
    try {
        table.at(12.5);
        FAIL() << "no error outside the table";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("m.csv"), std::string::npos);
        EXPECT_NE(std::string(e.what()).find("outside"), std::string::npos);
    }
}

TEST(Motion, BadCsvNamesTheFileAndLine) {
    EXPECT_NE(error_of(write("h.csv", "time,speed,yaw_rate\n0,1,0\n1,1,0\n")).find("column 't'"), std::string::npos);
    EXPECT_NE(error_of(write("n.csv", "t,speed,yaw_rate\n0,1,0\n1,x,0\n")).find("n.csv:3"), std::string::npos);
    EXPECT_NE(error_of(write("o.csv", "t,speed,yaw_rate\n0,1,0\n0,1,0\n")).find("increase"), std::string::npos);
    EXPECT_NE(error_of(write("s.csv", "t,speed,yaw_rate\n0,1,0\n")).find("two rows"), std::string::npos);
    EXPECT_NE(error_of(write("k.csv", "t,speed,yaw_rate\n0,1,0\n1,3600,0\n")).find("k.csv:3: speed must be within"),
              std::string::npos);  // km/h for m/s: refused where it is read, not by the estimator frames later
    EXPECT_NE(error_of(testing::TempDir() + "absent.csv").find("absent.csv: cannot read the motion file: no such file"),
              std::string::npos);
    EXPECT_NE(error_of(testing::TempDir()).find("cannot read the motion file: a directory, not a file"), std::string::npos);
    EXPECT_NE(error_of("/dev/zero").find("/dev/zero: cannot read the motion file: not a regular file"), std::string::npos);
}

TEST(Motion, SamplesInMemoryAreCheckedLikeAFileAndLookedUpTheSameWay) {
    const auto table = rp::MotionTable::from_samples({10.0, 12.0}, {2.0, 4.0}, {0.0, 0.2}, "bag: /odom");
    EXPECT_DOUBLE_EQ(table.at(10.5).speed_mps, 2.5);
    EXPECT_DOUBLE_EQ(table.at(10.5).yaw_rate_rps, 0.05);
    EXPECT_DOUBLE_EQ(table.distance_m(12.0), 6.0);
    EXPECT_EQ(table.times(), (std::vector<double>{10.0, 12.0}));
    const auto error = [](std::vector<double> t, std::vector<double> v, std::vector<double> w) -> std::string {
        try {
            rp::MotionTable::from_samples(std::move(t), std::move(v), std::move(w), "odo");
        } catch (const std::runtime_error& e) {
            return e.what();
        }
        return "";
    };
    EXPECT_NE(error({0.0, 1.0}, {1.0}, {0.0, 0.0}).find("odo: the motion table's columns differ"), std::string::npos);
    EXPECT_NE(error({0.0}, {1.0}, {0.0}).find("odo: the motion table needs at least two rows"), std::string::npos);
    EXPECT_NE(error({0.0, NAN}, {1.0, 1.0}, {0.0, 0.0}).find("non-finite"), std::string::npos);
    EXPECT_NE(error({0.0, 1.0}, {1.0, -2000.0}, {0.0, 0.0}).find("odo: the motion table's row 1: speed must be within"),
              std::string::npos);
    EXPECT_NE(error({1.0, 1.0}, {1.0, 1.0}, {0.0, 0.0}).find("odo: the motion table's times must increase (row 1"),
              std::string::npos);
    try {
        table.at(13.0);
        FAIL() << "no error outside the table";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("bag: /odom: frame time 13 s lies outside the table's span [10, 12] s"),
                  std::string::npos) << e.what();
    }
}

TEST(Motion, ImuYawRateIsTheGyroRotatedIntoTheBaseFrame) {
    EXPECT_FALSE(rp::imu_yaw_rate({}, rp::Extrinsics{}));
    rp::ImuSample a, b;
    a.angular_velocity = {0.0, 0.0, 0.1};
    b.angular_velocity = {0.0, 0.0, 0.3};
    EXPECT_NEAR(*rp::imu_yaw_rate({a, b}, rp::Extrinsics{}), 0.2, 1e-12);
    rp::Extrinsics yawed;  // a sensor turned about z still measures the same yaw rate
    yawed.yaw_rad = 1.0;
    EXPECT_NEAR(*rp::imu_yaw_rate({a}, yawed), 0.1, 1e-12);
    rp::Extrinsics upside_down;
    upside_down.roll_rad = M_PI;
    EXPECT_NEAR(*rp::imu_yaw_rate({a}, upside_down), -0.1, 1e-12);
    rp::Extrinsics pitched;  // pitched 90° down: the sensor's x axis points down, its −x is the base z
    pitched.pitch_rad = M_PI / 2;
    rp::ImuSample x;
    x.angular_velocity = {0.2, 0.0, 0.0};
    EXPECT_NEAR(*rp::imu_yaw_rate({x}, pitched), -0.2, 1e-12);
}
