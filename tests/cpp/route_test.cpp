// SPDX-License-Identifier: BSD-3-Clause
// RouteBuilder: frames' profiles stitched along the drive (docs/method.md §10), their segments and files.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <roadpreview/route/route.hpp>

namespace rp = roadpreview;

namespace {

constexpr double kDs = 0.1;
constexpr double kPi = 3.14159265358979323846;

double road(double d) { return 0.01 * std::sin(2.0 * kPi * d / 7.0); }

// A frame at drive distance `at_m` that saw 30 m of the road ahead of each wheel, shifted by `offset`.
rp::Result frame(int index, double at_m, double offset) {
    rp::Result r;
    r.frame = index;
    r.timestamp = 0.1 * index;
    r.speed_mps = 10.0;
    r.path.status = rp::PathStatus::Straight;
    r.path.direction = 1.0;
    for (rp::Profile* p : {&r.left, &r.right}) {
        p->ds = kDs;
        for (int k = 0; k < 300; ++k) {
            const double s = (k + 0.5) * kDs;
            p->s.push_back(s);
            p->z.push_back(road(at_m + s) + offset);
            p->count.push_back(3);
            p->spread.push_back(0.0);
        }
    }
    return r;
}

}  // namespace

TEST(Route, KnownRoadIsStitchedWholeWhateverEachFrameOffset) {
    rp::RouteBuilder route{rp::Config{}};
    const std::vector<double> offsets = {0.02, -0.03, 0.05, 0.0, 0.01};
    for (int f = 0; f < 5; ++f) route.add(frame(f, f * 1.0, offsets[f]));
    EXPECT_NEAR(route.distance_m(), 4.0, 1e-12);
    const rp::StitchedProfile p = route.left();
    ASSERT_EQ(p.z.size(), 340u);
    for (std::size_t j = 0; j < p.z.size(); ++j) EXPECT_NEAR(p.z[j], road((j + 0.5) * kDs) + offsets[0], 1e-12) << j;
    EXPECT_EQ(p.frames[0], 1);
    EXPECT_EQ(p.frames[45], 5);
    EXPECT_EQ(p.count[45], 15);
}

// Frame `r` with bins [first, last) of the left wheel empty and those of [first + 2, last - 2) blocked (or not).
rp::Result with_obstacle(rp::Result r, int first, int last, bool blocked) {
    r.left.blocked.assign(r.left.z.size(), 0);
    for (int k = first; k < last; ++k) {
        r.left.z[static_cast<std::size_t>(k)] = std::numeric_limits<double>::quiet_NaN();
        r.left.count[static_cast<std::size_t>(k)] = 0;
        r.left.blocked[static_cast<std::size_t>(k)] = blocked && k >= first + 2 && k < last - 2;
    }
    return r;
}

TEST(Route, NoGapIsFilledAcrossAnObstacleAFrameSawUnlessAnotherSawRoadThere) {
    for (const bool blocked : {false, true}) {
        rp::RouteBuilder route{rp::Config{}};
        route.add(with_obstacle(frame(0, 0.0, 0.0), 98, 107, blocked));  // 0.9 m empty: within max_gap_m
        const rp::StitchedProfile p = route.left();
        for (int j = 98; j < 107; ++j) {
            EXPECT_EQ(std::isnan(p.z[static_cast<std::size_t>(j)]), blocked) << j;
            EXPECT_EQ(p.blocked[static_cast<std::size_t>(j)], blocked && j >= 100 && j < 105) << j;
        }
    }
    rp::RouteBuilder route{rp::Config{}};
    route.add(with_obstacle(frame(0, 0.0, 0.0), 98, 107, true));
    route.add(frame(1, 1.0, 0.0));  // saw road over the whole stretch: the obstacle moved on
    const rp::StitchedProfile p = route.left();
    for (int j = 98; j < 107; ++j) {
        EXPECT_NEAR(p.z[static_cast<std::size_t>(j)], road((j + 0.5) * kDs), 1e-12) << j;
        EXPECT_EQ(p.blocked[static_cast<std::size_t>(j)], 0) << j;
    }
}

TEST(Route, SegmentsCoverTheStitchedRoadAndRunTheQuarterCarOverTheWholeStretch) {
    rp::RouteBuilder route{rp::Config{}};
    for (int f = 0; f < 5; ++f) route.add(frame(f, f * 1.0, 0.0));
    const auto segments = route.segments(10.0);
    ASSERT_EQ(segments.size(), 4u);  // 34 m: three of 10 m and one of 4 m
    EXPECT_DOUBLE_EQ(segments[3].start_m, 30.0);
    EXPECT_NEAR(segments[3].end_m, 34.0, 1e-9);
    const rp::StitchedProfile p = route.left();
    const std::vector<double> slopes = rp::iri_rectified_slope(p.z.data(), p.z.size(), kDs);
    const std::size_t lag = p.z.size() - slopes.size();
    double sum = 0.0;
    for (std::size_t j = 100; j < 200; ++j) sum += slopes[j - lag];
    ASSERT_TRUE(segments[1].left.iri.value);
    EXPECT_NEAR(*segments[1].left.iri.value, 1000.0 * sum / 100.0, 1e-9);
    EXPECT_FALSE(segments[0].left.iri.value);  // its first bins precede the moving average
    EXPECT_DOUBLE_EQ(segments[1].left.backed_fraction, 1.0);
    EXPECT_TRUE(segments[1].vehicle.roughness.iso_class.has_value());
    EXPECT_FALSE(segments[1].start.has_value());  // no poses
}

TEST(Route, PosesGiveDistanceAndPlace) {
    rp::RouteBuilder route{rp::Config{}};
    route.add(frame(0, 0.0, 0.0), rp::Pose2{5.0, 1.0, 0.0});
    route.add(frame(1, 3.0, 0.0), rp::Pose2{5.0, 4.0, 0.0});
    EXPECT_NEAR(route.distance_m(), 3.0, 1e-12);
    const auto segments = route.segments(2.0);
    ASSERT_TRUE(segments[0].end.has_value());
    EXPECT_NEAR(segments[0].end->y_m, 3.0, 1e-12);
    ASSERT_TRUE(segments[1].start.has_value());  // 2 m: driven
    EXPECT_FALSE(segments[1].end.has_value());   // 4 m: ahead of the last frame, where the drive never was
    EXPECT_THROW(route.add(frame(2, 4.0, 0.0)), std::invalid_argument);  // a pose for every frame or none
}

TEST(Route, TimeGoingBackAndBadLengthsAreErrors) {
    rp::RouteBuilder route{rp::Config{}};
    route.add(frame(3, 0.0, 0.0));
    EXPECT_THROW(route.add(frame(1, 0.0, 0.0)), std::invalid_argument);
    EXPECT_THROW(route.segments(0.0), std::invalid_argument);
    EXPECT_THROW(route.segments(std::nan("")), std::invalid_argument);
    EXPECT_THROW(route.segments(0.099), std::invalid_argument);  // shorter than a bin: no segment holds one
    EXPECT_EQ(route.segments(0.1).size(), route.left().z.size());
}

TEST(Route, ProfilesItCannotPlaceAreErrorsThatLeaveTheRouteAsItWas) {  // lines read back from files
    rp::RouteBuilder route{rp::Config{}};
    route.add(frame(0, 0.0, 0.0));
    const std::size_t bins = route.left().z.size();
    const auto expect_error = [&](const rp::Result& r, const std::string& start) {
        try {
            route.add(r);
            FAIL() << start;
        } catch (const std::invalid_argument& e) {
            EXPECT_EQ(std::string(e.what()).rfind(start, 0), 0u) << e.what();
        }
        EXPECT_EQ(route.frames(), 1u);
        EXPECT_EQ(route.left().z.size(), bins);
    };
    rp::Result far = frame(1, 1.0, 0.0);
    far.right.s.back() = 1e9;  // would have been drive bin 10¹⁰: gigabytes
    expect_error(far, "route: frame 1: a profile bin lies at 1e+09 m, beyond the profiles' reach (40 m)");
    rp::Result fast = frame(1, 1.0, 0.0);
    fast.speed_mps = 1e12;
    expect_error(fast, "route: frame 1 moves the drive on by 1e+11 m");
    rp::Result scale = frame(1, 1.0, 0.0);
    scale.path.status = rp::PathStatus::Arc;
    scale.path.icr_y = std::numeric_limits<double>::infinity();
    scale.path.left_radius = scale.path.right_radius = 10.0;
    expect_error(scale, "route: frame 1: the path's centre of rotation and wheel radii give no distance");
    // A wheel turning about a point 1 mm from it adds nothing; the other wheel is stitched.
    rp::Result tight = frame(1, 1.0, 0.0);
    tight.path.status = rp::PathStatus::Arc;
    tight.path.icr_y = 0.801;
    tight.path.left_radius = 0.001;
    tight.path.right_radius = 1.601;
    route.add(tight);
    EXPECT_EQ(route.frames(), 2u);
    EXPECT_EQ(route.left().frames[20], 1);  // drive 2.0–2.1 m: frame 0 only
    EXPECT_EQ(route.right().frames[20], 2);
}

TEST(Route, ErdHeaderAndSamples) {
    rp::RouteBuilder route{rp::Config{}};
    route.add(frame(0, 0.0, 0.0));
    std::ostringstream erd;
    rp::write_profile_erd(erd, route.left(), "left", "test");
    std::istringstream in(erd.str());
    std::string line;
    std::getline(in, line);
    EXPECT_EQ(line, "ERDFILEV2.00");
    std::getline(in, line);
    EXPECT_NE(line.find("300,"), std::string::npos);
    EXPECT_NE(line.find("0.1000"), std::string::npos);
    while (std::getline(in, line) && line != "END") {
    }
    double first = 0.0;
    in >> first;
    EXPECT_NEAR(first, 1000.0 * road(0.05), 1e-3);
    rp::RouteBuilder empty{rp::Config{}};
    EXPECT_THROW(rp::write_profile_erd(erd, empty.left(), "left", "test"), std::runtime_error);
}

// A run's output lines stitch to the same drive as its results: what batch runs read back from Parquet.
TEST(Route, OutputLinesStitchLikeTheirResults) {
    rp::RouteBuilder from_results{rp::Config{}}, from_lines{rp::Config{}};
    for (int f = 0; f < 4; ++f) {
        rp::Result r = frame(f, f * 0.9, 0.01 * f);
        if (f == 2) {  // an arc: the wheels' arc lengths are scaled onto the drive
            r.path.status = rp::PathStatus::Arc;
            r.path.icr_y = 20.0, r.path.left_radius = 19.2, r.path.right_radius = 20.8;
        }
        r.left.z[7] = std::nan("");  // missing bins travel as null
        if (f == 1) r = with_obstacle(r, 20, 29, true);  // blocked bins travel too
        from_results.add(r);
        const rp::Result line = rp::route_input_from_json(rp::result_to_json(r), "line " + std::to_string(f));
        EXPECT_EQ(line.left.blocked, r.left.blocked);
        from_lines.add(line);
    }
    EXPECT_DOUBLE_EQ(from_lines.distance_m(), from_results.distance_m());
    const rp::StitchedProfile a = from_results.left(), b = from_lines.left();
    ASSERT_EQ(a.z.size(), b.z.size());
    for (std::size_t j = 0; j < a.z.size(); ++j) {
        if (std::isnan(a.z[j])) {
            EXPECT_TRUE(std::isnan(b.z[j])) << j;
        } else {
            EXPECT_DOUBLE_EQ(a.z[j], b.z[j]) << j;
        }
    }
    EXPECT_EQ(a.count, b.count);
    EXPECT_EQ(a.frames, b.frames);
    EXPECT_EQ(a.blocked, b.blocked);

    rp::Result stopped;
    stopped.status = rp::FrameStatus::VehicleStopped;
    const rp::Result back = rp::route_input_from_json(rp::result_to_json(stopped));
    EXPECT_EQ(back.status, rp::FrameStatus::VehicleStopped);
    EXPECT_TRUE(back.left.z.empty());
    try {
        rp::route_input_from_json("{\"source\": \"a.bin\"}", "part-0.parquet row 3");
        FAIL() << "a line without its motion accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("part-0.parquet row 3: the output line has no 'motion'"),
                  std::string::npos) << e.what();
    }
    EXPECT_THROW(rp::route_input_from_json("not json", "x"), std::invalid_argument);
    // A number beyond a double is nlohmann's out_of_range, not its parse_error: once it escaped as neither of ours.
    EXPECT_THROW(rp::route_input_from_json(R"({"motion": {"speed": 1e400}})", "x"), std::invalid_argument);
    EXPECT_THROW(rp::route_input_from_json(R"({"motion": {"speed": 5}, "reason": "gremlins"})", "x"),
                 std::invalid_argument);
}
