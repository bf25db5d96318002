// SPDX-License-Identifier: BSD-3-Clause
// Numbers read from text inputs: decimal notation only, whatever the locale.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <locale>
#include <random>
#include <vector>

#include "core/text.hpp"
#include "roadpreview/fusion/fusion.hpp"

namespace rp = roadpreview;

TEST(ParseNumber, ReadsDecimalNotation) {
    EXPECT_EQ(rp::parse_number("1.5"), 1.5);
    EXPECT_EQ(rp::parse_number("-2e3"), -2000.0);
    EXPECT_EQ(rp::parse_number("+0.25"), 0.25);
    EXPECT_EQ(rp::parse_number(".5"), 0.5);
    EXPECT_EQ(rp::parse_number("7"), 7.0);
    EXPECT_TRUE(std::isinf(*rp::parse_number("inf")));
    EXPECT_TRUE(std::isnan(*rp::parse_number("nan")));
}

TEST(ParseNumber, RefusesWhatStrtodWouldTakeOrCutShort) {
    // strtod reads "0x10" as 16 and stops at the comma of "1,5" (or, under a decimal-comma locale, at a point).
    for (const char* token : {"0x10", "1,5", "1.5abc", " 1.5", "1.5 ", "", "+", "+-1", "++1", "-", "e5", "1e400"})
        EXPECT_FALSE(rp::parse_number(token).has_value()) << '"' << token << '"';
}

TEST(ParseNumber, ReadsBackEveryNumberWrittenWith17Digits) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> mantissa(-1.0, 1.0);
    std::uniform_int_distribution<int> exponent(-300, 300);
    for (int i = 0; i < 10000; ++i) {
        const double v = std::ldexp(mantissa(rng), exponent(rng));
        EXPECT_EQ(rp::parse_number(rp::number_text(v, 17)), v) << rp::number_text(v, 17);
    }
}

namespace {

struct DecimalComma : std::numpunct<char> {
    char do_decimal_point() const override { return ','; }
};

}  // namespace

TEST(ParseNumber, PosesReadTheSameUnderADecimalCommaLocale) {
    // A program may set a global C++ locale whose decimal point is a comma: streams made after it read "0.5" as 0.
    const auto path = std::filesystem::temp_directory_path() / "roadpreview_text_test_poses.txt";
    std::ofstream(path) << "1 0 0 0.5 0 1 0 0.25 0 0 1 0\n";
    const std::locale before = std::locale::global(std::locale(std::locale::classic(), new DecimalComma));
    std::vector<rp::Pose2> poses;
    EXPECT_NO_THROW(poses = rp::read_kitti_poses(path.string()));
    std::locale::global(before);
    ASSERT_EQ(poses.size(), 1u);
    EXPECT_EQ(poses[0].x_m, 0.5);
    EXPECT_EQ(poses[0].y_m, 0.25);
}
