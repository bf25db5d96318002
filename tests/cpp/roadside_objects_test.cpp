// SPDX-License-Identifier: BSD-3-Clause
// Roadside objects and tracks: site file checks, homography, background, grid labelling, L-shape boxes,
// gated assignment, Kalman tracking, latency compensation, a scanner dropping out, WGS84 and the output line.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <string>

#include "roadpreview/roadside/extrinsics.hpp"
#include "roadpreview/roadside/processor.hpp"
#include "track_layout.hpp"

namespace rs = roadpreview::roadside;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

const char* kSite = R"(
origin: {lat_deg: 49.0, lon_deg: 8.4, height_m: 110.0, heading_deg: 90}
scanners:
  - {name: south, x_m: 0, y_m: -10, yaw_deg: 90, beams: 361, start_angle_deg: -90, step_deg: 0.5}
  - {name: north, x_m: 0, y_m: 10, yaw_deg: -90, beams: 361, start_angle_deg: -90, step_deg: 0.5}
camera:
  points: [[0, 480, -10, -5], [720, 480, 10, -5], [720, 100, 10, 5], [0, 100, -10, 5]]
processing: {background_s: 0.5}
)";

// A 361-beam scan of the scanner at `pose` seeing a wall at `wall_m` and an axis-aligned box (or nothing).
rs::LaserScan synthetic_scan(const rs::Pose2& pose, double t, int scanner, double box_x = NAN, double box_y = 0.0,
                             double length = 4.5, double width = 1.8) {
    rs::LaserScan s;
    s.time_s = t;
    s.scanner = scanner;
    s.start_angle_rad = -90.0 * kDeg;
    s.step_rad = 0.5 * kDeg;
    s.source = "synthetic";
    for (int i = 0; i < 361; ++i) {
        const double a = pose.yaw_rad + s.angle_rad(i), dx = std::cos(a), dy = std::sin(a);
        double r = 30.0;  // background: a circle of walls at 30 m
        if (std::isfinite(box_x)) {  // slab intersection with the box
            double t0 = 0.0, t1 = 1e9;
            const double lo[2] = {box_x - length / 2 - pose.x_m, box_y - width / 2 - pose.y_m};
            const double hi[2] = {box_x + length / 2 - pose.x_m, box_y + width / 2 - pose.y_m};
            const double d[2] = {dx, dy};
            for (int k = 0; k < 2; ++k) {
                if (std::abs(d[k]) < 1e-12) {
                    if (lo[k] > 0 || hi[k] < 0) t0 = 1e9;
                    continue;
                }
                const double a0 = lo[k] / d[k], a1 = hi[k] / d[k];
                t0 = std::max(t0, std::min(a0, a1));
                t1 = std::min(t1, std::max(a0, a1));
            }
            if (t0 <= t1 && t0 > 0 && t0 < r) r = t0;
        }
        s.ranges_m.push_back(static_cast<float>(r));
    }
    return s;
}

std::vector<rs::Point2> points_of(std::initializer_list<std::pair<double, double>> xy) {
    std::vector<rs::Point2> out;
    for (auto [x, y] : xy) out.push_back({x, y, 0});
    return out;
}

}  // namespace

TEST(RoadsideSite, ParsesAndRefusesBadFiles) {
    const rs::Site site = rs::parse_site(kSite, "site.yaml");
    ASSERT_EQ(site.scanners.size(), 2u);
    EXPECT_EQ(site.scanners[1].name, "north");
    EXPECT_NEAR(site.scanners[1].pose.yaw_rad, -kPi / 2, 1e-12);
    ASSERT_TRUE(site.camera);
    double x = 0, y = 0;
    ASSERT_TRUE(rs::image_to_site(site.camera->homography, 360, 480, x, y));
    EXPECT_NEAR(x, 0.0, 1e-6);
    EXPECT_NEAR(y, -5.0, 1e-6);
    EXPECT_DOUBLE_EQ(site.settings.background_s, 0.5);
    auto error_of = [](const std::string& text) {
        try {
            rs::parse_site(text, "bad.yaml");
        } catch (const std::runtime_error& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    EXPECT_NE(error_of("origin: {lat_deg: 1, lon_deg: 2}\nscanners: []\n").find("missing scanners"), std::string::npos);
    EXPECT_NE(error_of("origin: {lat_deg: 1, lon_deg: 2}\nscanners: [{x_m: 1, yaw: 3}]\n").find("unknown key 'yaw'"),
              std::string::npos);
    EXPECT_NE(error_of("origin: {lat_deg: 1, lon_deg: 2}\nscanners: [{x_m: .nan}]\n").find("x_m must be finite"),
              std::string::npos);
    const std::string collinear = "origin: {lat_deg: 1, lon_deg: 2}\nscanners: [{x_m: 0}]\ncamera:\n  points: "
                                  "[[0, 0, 0, 0], [1, 1, 1, 1], [2, 2, 2, 2], [3, 3, 3, 3]]\n";
    EXPECT_NE(error_of(collinear).find("collinear"), std::string::npos);
    EXPECT_NE(error_of("origin: {lat_deg: 1, lon_deg: 2}\nscanners: [{x_m: 0}]\ncamera:\n  points: [[0, 0, 0, 0]]\n")
                  .find("at least 4"),
              std::string::npos);
}

TEST(RoadsideGeo, SiteFrameRoundTripsThroughWgs84) {
    rs::SiteOrigin o{49.0, 8.4, 110.0, 90.0};  // x east
    const rs::SiteGeodesy geo(o);
    const rs::LatLon p = geo.to_wgs84(100.0, 0.0);
    EXPECT_NEAR(p.lat_deg, 49.0, 1e-6);
    EXPECT_GT(p.lon_deg, 8.4);
    // 100 m east at 49° N: Δlon = 100 / (cos φ · N) with N the WGS84 prime-vertical radius.
    const double a = 6378137.0, e2 = 6.69437999014e-3, phi = 49.0 * kDeg;
    const double n = a / std::sqrt(1 - e2 * std::sin(phi) * std::sin(phi));
    EXPECT_NEAR((p.lon_deg - 8.4) * kDeg * n * std::cos(phi), 100.0, 0.01);
    const rs::LatLon q = geo.to_wgs84(0.0, 50.0);  // y is north when x is east
    EXPECT_GT(q.lat_deg, 49.0);
    double x = 0, y = 0;
    geo.to_site(q.lat_deg, q.lon_deg, x, y);
    EXPECT_NEAR(x, 0.0, 1e-6);
    EXPECT_NEAR(y, 50.0, 1e-6);
}

TEST(RoadsideGrid, LabelsDilatedComponents) {
    // Two clusters 0.25 m apart merge with a 1-cell dilation at 0.1 m; a third 2 m away stays apart.
    const auto pts = points_of({{0.0, 0.0}, {0.05, 0.0}, {0.3, 0.0}, {2.3, 0.0}, {2.35, 0.05}, {2.4, 0.0}});
    const auto g = rs::label_points(pts, 0.1, 1);
    EXPECT_EQ(g.components, 2);
    EXPECT_EQ(g.point_label[0], g.point_label[2]);
    EXPECT_NE(g.point_label[0], g.point_label[3]);
    EXPECT_EQ(rs::label_points(pts, 0.1, 0).components, 3);
    const auto objects = rs::grid_objects(pts, g, 3);
    ASSERT_EQ(objects.size(), 2u);
    EXPECT_NEAR(objects[0].centroid_x_m, 0.35 / 3, 1e-12);
    EXPECT_EQ(rs::grid_objects(pts, g, 4).size(), 0u);
    EXPECT_EQ(rs::label_points({}, 0.1, 1).components, 0);
}

// Groups far apart are labelled on grids of their own; the labels are those of one grid over everything: two
// occupied cells join when their dilated squares touch (rows and columns at most 2d + 1 apart), a component's
// cells are the union of its squares, and components are numbered by their first cell in raster order.
TEST(RoadsideGrid, SeparateGroupsAreLabelledAsOneGridWouldLabelThem) {
    std::mt19937 rng(3);
    for (int scene = 0; scene < 40; ++scene) {
        const double cell = scene % 2 ? 0.1 : 0.25;
        const int d = scene % 4;
        std::uniform_real_distribution<double> centre(-30.0, 30.0), offset(-1.5, 1.5);
        std::vector<rs::Point2> pts;
        for (int cluster = 0; cluster < 6; ++cluster) {
            const double cx = centre(rng), cy = scene % 3 ? centre(rng) : cx;  // a diagonal row in every third
            for (int k = 0; k < 25; ++k) pts.push_back({cx + offset(rng), cy + offset(rng), 0});
        }
        const rs::GridLabels g = rs::label_points(pts, cell, d);
        // The plain answer: cells of every point, joined while their squares touch.
        std::vector<std::pair<int, int>> at(pts.size());
        for (std::size_t i = 0; i < pts.size(); ++i)
            at[i] = {static_cast<int>((pts[i].y_m - g.y0_m) / cell), static_cast<int>((pts[i].x_m - g.x0_m) / cell)};
        std::vector<std::size_t> root(pts.size());
        for (std::size_t i = 0; i < root.size(); ++i) root[i] = i;
        const auto find = [&](std::size_t i) {
            while (root[i] != i) i = root[i] = root[root[i]];
            return i;
        };
        for (std::size_t i = 0; i < pts.size(); ++i)
            for (std::size_t j = i + 1; j < pts.size(); ++j)
                if (std::abs(at[i].first - at[j].first) <= 2 * d + 1 && std::abs(at[i].second - at[j].second) <= 2 * d + 1)
                    root[find(i)] = find(j);
        std::map<std::size_t, std::set<std::pair<int, int>>> squares;  // per component: its dilated cells
        for (std::size_t i = 0; i < pts.size(); ++i)
            for (int r = -d; r <= d; ++r)
                for (int c = -d; c <= d; ++c) squares[find(i)].insert({at[i].first + r, at[i].second + c});
        std::vector<std::pair<std::pair<int, int>, std::size_t>> first;  // raster-first cell → component
        for (const auto& [component, cells] : squares) first.push_back({*cells.begin(), component});
        std::sort(first.begin(), first.end());
        ASSERT_EQ(g.components, static_cast<int>(first.size())) << "scene " << scene;
        for (std::size_t rank = 0; rank < first.size(); ++rank) {
            const std::size_t component = first[rank].second;
            EXPECT_EQ(g.cells[rank + 1], static_cast<int>(squares[component].size())) << "scene " << scene;
            for (std::size_t i = 0; i < pts.size(); ++i)
                if (find(i) == component) {
                    ASSERT_EQ(g.point_label[i], static_cast<int>(rank + 1)) << "scene " << scene;
                }
        }
    }
}

TEST(RoadsideGrid, LShapeFindsTheCarsSidesWhereTheMbrIsTheSame) {
    // Two sides of a 4.5 × 1.8 m car turned by 30°, seen from its corner.
    std::vector<rs::Point2> pts;
    const double h = 30 * kDeg, c = std::cos(h), s = std::sin(h);
    for (int i = 0; i <= 45; ++i) pts.push_back({c * i * 0.1, s * i * 0.1, 0});
    for (int i = 1; i <= 18; ++i) pts.push_back({-s * i * 0.1, c * i * 0.1, 0});
    const rs::Box b = rs::fit_l_shape(pts);
    EXPECT_NEAR(b.heading_rad, h, 1.01 * kDeg);
    EXPECT_NEAR(b.length_m, 4.5, 0.05);
    EXPECT_NEAR(b.width_m, 1.8, 0.05);
    const rs::Box centre_truth{c * 2.25 - s * 0.9, s * 2.25 + c * 0.9, 4.5, 1.8, h};
    EXPECT_NEAR(std::hypot(b.x_m - centre_truth.x_m, b.y_m - centre_truth.y_m), 0.0, 0.05);
}

TEST(RoadsideAssignment, MinimisesCostWithinTheGate) {
    // Greedy would pair (0,0) at 1; the optimum is (0,1)+(1,0) = 2 + 2 < 1 + 10.
    EXPECT_EQ(rs::assign({{1, 2}, {2, 10}}, 20), (std::vector<std::pair<int, int>>{{0, 1}, {1, 0}}));
    // Gate: the (1,0) pair is refused; more rows than columns.
    EXPECT_EQ(rs::assign({{1, 9}, {5, 9}, {9, 0.5}}, 4), (std::vector<std::pair<int, int>>{{0, 0}, {2, 1}}));
    EXPECT_TRUE(rs::assign({{INFINITY}}, 4).empty());
    EXPECT_TRUE(rs::assign({}, 4).empty());
}

TEST(RoadsideTracking, KeepsIdsAndEstimatesVelocity) {
    rs::Tracker tracker(rs::TrackerSettings{});
    for (int k = 0; k < 40; ++k) {
        const double t = k / 37.5;
        std::vector<rs::Measurement> m(2);
        m[0].t_s = m[1].t_s = t;
        m[0].object.l_shape = {10.0 * t, 0.0, 0.5, 0.5, 0.0};        // 10 m/s along x
        m[1].object.l_shape = {20.0 - 1.5 * t, 5.0, 0.5, 0.5, 0.0};  // a pedestrian at 1.5 m/s
        tracker.update(t, m);
    }
    ASSERT_EQ(tracker.tracks().size(), 2u);
    EXPECT_EQ(tracker.tracks()[0].id, 1);
    EXPECT_EQ(tracker.tracks()[1].id, 2);
    EXPECT_NEAR(tracker.tracks()[0].x(2), 10.0, 0.05);
    EXPECT_NEAR(tracker.tracks()[1].x(2), -1.5, 0.05);
    // Prediction to a later common time: latency compensation of the output.
    EXPECT_NEAR(tracker.predicted(tracker.tracks()[0], 39 / 37.5 + 0.1)(0), 10.0 * (39 / 37.5 + 0.1), 0.02);
    tracker.update(3.0, {});  // long silence: both dropped
    EXPECT_TRUE(tracker.tracks().empty());
}

#ifdef ROADPREVIEW_TEST_AVX_LAYOUT
// A program built with -mavx sees the library's Track as the library does (its Eigen members were 32-byte aligned
// there: the state at byte 32, not 16, and every later member moved).
TEST(RoadsideTracking, TrackHasOneLayoutWhateverTheVectorInstructions) {
    EXPECT_TRUE(track_layout_here() == track_layout_avx());
    EXPECT_EQ(track_layout_here().align, alignof(double));
}
#endif

TEST(RoadsideProcessor, TracksACarFromTwoScannersAndReportsADropout) {
    rs::Site site = rs::parse_site(kSite, "site.yaml");
    rs::Processor p(site);
    std::vector<rs::Cycle> cycles;
    const double speed = 8.0;
    for (int k = 0; k < 150; ++k) {
        const double t = k / 37.5;
        const bool moving = t > 0.6;
        const double x = -15.0 + speed * (t - 0.6);
        for (int s = 0; s < 2; ++s) {
            if (s == 1 && k > 120) continue;  // the north scanner drops out
            auto scan = synthetic_scan(site.scanners[s].pose, t + 0.005 * s, s, moving ? x : NAN, 1.0);
            for (auto& c : p.push(scan)) cycles.push_back(c);
        }
    }
    for (auto& c : p.finish()) cycles.push_back(c);
    ASSERT_FALSE(cycles.empty());
    int with_car = 0;
    for (const auto& c : cycles) {
        if (c.objects.size() != 1) continue;
        ++with_car;
        const auto& o = c.objects[0];
        EXPECT_EQ(o.id, 1);
        const double truth_x = -15.0 + speed * (c.t_s - 0.6);
        if (o.age_s > 0.5) {
            EXPECT_NEAR(o.x_m, truth_x, 0.15) << "t " << c.t_s;  // predicted to the cycle time
            EXPECT_NEAR(o.y_m, 1.0, 0.15);
            // After the filter settles; within 5 %: passing between the scanners, the visible sides change.
            if (o.age_s > 0.7) {
                EXPECT_NEAR(o.speed_mps, speed, 0.05 * speed) << "t " << c.t_s;
            }
            EXPECT_EQ(o.cls, "car");
        }
    }
    EXPECT_GT(with_car, 70);
    const auto& last = cycles.back();
    EXPECT_TRUE(last.scanners[0].active);
    EXPECT_FALSE(last.scanners[1].active);  // says so
    const auto line = nlohmann::json::parse(rs::cycle_to_json(last));
    EXPECT_EQ(line["scanners"][1]["active"], false);
    ASSERT_EQ(line["objects"].size(), 1u);
    EXPECT_EQ(line["objects"][0]["source"], "laser");
    EXPECT_EQ(line["objects"][0]["mbr_wgs84_deg"].size(), 4u);
    const auto geo = nlohmann::json::parse(rs::cycles_to_geojson({last}));
    EXPECT_EQ(geo["features"].size(), 2u);
}

TEST(RoadsideProcessor, RefusesAScanWhoseLayoutDisagreesWithTheSite) {
    rs::Processor p(rs::parse_site(kSite, "site.yaml"));
    auto scan = synthetic_scan({0, -10, kPi / 2}, 0.0, 0);
    scan.ranges_m.pop_back();
    try {
        p.push(scan);
        FAIL() << "no error";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("360 beams, the site says 361"), std::string::npos) << e.what();
    }
    scan = synthetic_scan({0, -10, kPi / 2}, 0.0, 5);
    EXPECT_THROW(p.push(scan), std::runtime_error);  // no scanner 5 in the site
}

TEST(RoadsideProcessor, NanAndOutOfRangeReturnsAreNoReturn) {
    rs::Processor p(rs::parse_site(kSite, "site.yaml"));
    for (int k = 0; k < 40; ++k) {
        auto scan = synthetic_scan({0, -10, kPi / 2}, k / 37.5, 0);
        scan.ranges_m[10] = NAN, scan.ranges_m[11] = -1.0f, scan.ranges_m[12] = 1e6f;
        for (const auto& c : p.push(scan)) EXPECT_TRUE(c.objects.empty());
    }
    const auto cycles = p.finish();
    ASSERT_FALSE(cycles.empty());
    EXPECT_EQ(cycles.back().scanners[0].invalid_ranges, 120);  // NaN, −1 and 1e6, every scan
}

TEST(RoadsideProcessor, AScanAtNoFiniteTimeIsAnErrorNamingIt) {
    rs::Processor p(rs::parse_site(kSite, "site.yaml"));
    p.push(synthetic_scan({0, -10, kPi / 2}, 0.0, 0));
    for (const float t : {NAN, INFINITY}) {
        auto scan = synthetic_scan({0, -10, kPi / 2}, t, 0);
        scan.source = "scans.csv:7";
        try {
            p.push(scan);
            FAIL() << "no error for t = " << t;
        } catch (const std::runtime_error& e) {
            EXPECT_EQ(std::string(e.what()), "scans.csv:7: the scan's time is not a finite number");
        }
    }
}

namespace {

// Range from (x, y) along direction a to the walls of the room [−10, 10] × [−6, 6] and a 1 × 1 m pillar at (3, 2).
double room_range(double x, double y, double a) {
    const double dx = std::cos(a), dy = std::sin(a);
    double r = 1e9;
    for (double wall : {-10.0, 10.0})
        if (std::abs(dx) > 1e-12 && (wall - x) / dx > 0) r = std::min(r, (wall - x) / dx);
    for (double wall : {-6.0, 6.0})
        if (std::abs(dy) > 1e-12 && (wall - y) / dy > 0) r = std::min(r, (wall - y) / dy);
    double t0 = 0.0, t1 = 1e9;
    const double lo[2] = {2.5 - x, 1.5 - y}, hi[2] = {3.5 - x, 2.5 - y}, d[2] = {dx, dy};
    for (int k = 0; k < 2; ++k) {
        if (std::abs(d[k]) < 1e-12) continue;
        t0 = std::max(t0, std::min(lo[k] / d[k], hi[k] / d[k]));
        t1 = std::min(t1, std::max(lo[k] / d[k], hi[k] / d[k]));
    }
    if (t0 <= t1 && t0 > 0) r = std::min(r, t0);
    return r;
}

std::vector<rs::LaserScan> room_scans(const rs::Pose2& pose, int n, unsigned seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 0.01);
    std::vector<rs::LaserScan> out;
    for (int k = 0; k < n; ++k) {
        rs::LaserScan s;
        s.start_angle_rad = -90 * kDeg, s.step_rad = 0.5 * kDeg;
        for (int i = 0; i < 361; ++i) s.ranges_m.push_back(static_cast<float>(room_range(pose.x_m, pose.y_m, pose.yaw_rad + s.angle_rad(i)) + noise(rng)));
        out.push_back(s);
    }
    return out;
}

}  // namespace

TEST(RoadsideExtrinsics, IcpRecoversTheSecondScannersPose) {
    const rs::Pose2 fixed{-8.0, -4.0, 30 * kDeg}, truth{7.0, 3.0, -150 * kDeg};
    const auto a = room_scans(fixed, 10, 1), b = room_scans(truth, 10, 2);
    const rs::Pose2 guess{truth.x_m + 0.4, truth.y_m - 0.3, truth.yaw_rad + 3 * kDeg};
    const rs::ExtrinsicsResult r = rs::register_scanners(a, fixed, b, guess, 1.5);
    EXPECT_TRUE(r.converged);
    EXPECT_NEAR(r.pose.x_m, truth.x_m, 0.03);
    EXPECT_NEAR(r.pose.y_m, truth.y_m, 0.03);
    EXPECT_NEAR(r.pose.yaw_rad, truth.yaw_rad, 0.3 * kDeg);
    EXPECT_LT(r.fitness_m2, 0.01);
    EXPECT_THROW(rs::register_scanners({}, fixed, b, guess), std::invalid_argument);
}
