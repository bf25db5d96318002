// SPDX-License-Identifier: BSD-3-Clause
// The world background of a moving scanner: a scanner driving through a walled yard while a walker crosses it.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "roadpreview/roadside/processor.hpp"
#include "roadpreview/roadside/world_background.hpp"

namespace rs = roadpreview::roadside;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kYardM = 10.0;          // walls on x, y = ±10 m
constexpr double kWalkerRadiusM = 0.25;  // legs and hips
constexpr int kScans = 100;              // 10 s at 10 Hz, the scanner from x = −5 m to +5 m along y = 0

rs::Pose2 scanner_pose(int k) { return {-5.0 + 0.1 * k, 0.0, 0.0}; }

// The walker crosses the yard at x = 6 m, from y = −5 to +5 m during scans 40 … 60 (5 m/s); absent otherwise.
bool walker_at(int k, double& x, double& y) {
    if (k < 40 || k > 60) return false;
    x = 6.0, y = -5.0 + 0.5 * (k - 40);
    return true;
}

// Range along a ray from inside the yard to its walls, or to the walker's disc when nearer.
double ray_range(const rs::Pose2& p, double a, int k) {
    const double dx = std::cos(a), dy = std::sin(a);
    double r = 1e9;
    if (std::abs(dx) > 1e-12) r = std::min(r, ((dx > 0 ? kYardM : -kYardM) - p.x_m) / dx);
    if (std::abs(dy) > 1e-12) r = std::min(r, ((dy > 0 ? kYardM : -kYardM) - p.y_m) / dy);
    double wx = 0.0, wy = 0.0;
    if (walker_at(k, wx, wy)) {
        const double cx = wx - p.x_m, cy = wy - p.y_m, b = dx * cx + dy * cy;
        const double disc = b * b - (cx * cx + cy * cy - kWalkerRadiusM * kWalkerRadiusM);
        if (disc >= 0.0 && b - std::sqrt(disc) > 0.0) r = std::min(r, b - std::sqrt(disc));
    }
    return r;
}

rs::LaserScan yard_scan(int k) {
    rs::LaserScan s;
    s.time_s = 0.1 * k;
    s.start_angle_rad = -kPi / 2;
    s.step_rad = kPi / 360;
    s.pose = scanner_pose(k);
    s.source = "yard#" + std::to_string(k);
    for (int b = 0; b < 361; ++b) s.ranges_m.push_back(static_cast<float>(ray_range(*s.pose, s.angle_rad(b), k)));
    return s;
}

std::vector<rs::LaserScan> yard_scans() {
    std::vector<rs::LaserScan> scans;
    for (int k = 0; k < kScans; ++k) scans.push_back(yard_scan(k));
    return scans;
}

std::vector<rs::Pose2> poses_of(const std::vector<rs::LaserScan>& scans) {
    std::vector<rs::Pose2> poses;
    for (const auto& s : scans) poses.push_back(*s.pose);
    return poses;
}

bool on_walker(const rs::LaserScan& s, std::size_t b, int k) {
    double wx = 0.0, wy = 0.0;
    if (!walker_at(k, wx, wy)) return false;
    const double a = s.pose->yaw_rad + s.angle_rad(b), r = s.ranges_m[b];
    return std::hypot(s.pose->x_m + r * std::cos(a) - wx, s.pose->y_m + r * std::sin(a) - wy) < kWalkerRadiusM + 1e-3;
}

}  // namespace

TEST(WorldBackground, TheWalkerIsForegroundAndTheWallsAreNot) {
    const auto scans = yard_scans();
    const rs::WorldBackground world(scans, poses_of(scans), rs::WorldBackgroundSettings{});
    EXPECT_NEAR(world.scan_period_s(), 0.1, 1e-9);
    EXPECT_EQ(world.max_hit_scans(), 40);
    int walker_returns = 0, walker_foreground = 0, wall_foreground = 0;
    for (int k = 0; k < kScans; ++k) {
        const auto fg = world.foreground(scans[static_cast<std::size_t>(k)], *scans[static_cast<std::size_t>(k)].pose);
        for (std::size_t b = 0; b < fg.size(); ++b) {
            if (on_walker(scans[static_cast<std::size_t>(k)], b, k)) {
                ++walker_returns;
                walker_foreground += fg[b];
            } else {
                wall_foreground += fg[b];
            }
        }
    }
    EXPECT_GT(walker_returns, 150);  // 21 scans, 4–19 beams each
    EXPECT_GE(walker_foreground, 0.95 * walker_returns);
    EXPECT_EQ(wall_foreground, 0);
    // Where the walker crossed: seen free by the scans before and after it, hit by a few while it passed.
    EXPECT_GE(world.free_scans(6.0, 1.0), 70);
    EXPECT_LE(world.hit_scans(6.0, 1.0), 5);
    EXPECT_GE(world.hit_scans(kYardM - 0.05, 0.0), kScans);  // the far wall, straight ahead: every scan
    EXPECT_EQ(world.free_scans(kYardM + 5.0, 0.0), 0);         // beyond the wall
}

TEST(WorldBackground, RefusesWhatCannotMakeAGrid) {
    auto scans = yard_scans();
    auto poses = poses_of(scans);
    const rs::WorldBackgroundSettings s;
    EXPECT_THROW(rs::WorldBackground({}, {}, s), std::invalid_argument);
    EXPECT_THROW(rs::WorldBackground(scans, std::vector<rs::Pose2>(poses.begin(), poses.end() - 1), s),
                 std::invalid_argument);
    auto far = poses;
    far.back().x_m = 1e7;  // kilometres mistaken for metres, or a corrupt pose
    try {
        rs::WorldBackground(scans, far, s);
        FAIL() << "a 10,000 km grid was accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("too large"), std::string::npos) << e.what();
    }
    far.back().x_m = NAN;
    EXPECT_THROW(rs::WorldBackground(scans, far, s), std::invalid_argument);
    for (auto& scan : scans) scan.time_s = 0.0;  // a log without times, not timed by a rate
    try {
        rs::WorldBackground(scans, poses, s);
        FAIL() << "scans that do not advance in time were accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("yard#0"), std::string::npos) << e.what();
    }
    rs::WorldBackgroundSettings bad;
    bad.max_range_m = 0.1;  // shorter than the free margin
    EXPECT_THROW(rs::WorldBackground(yard_scans(), poses, bad), std::invalid_argument);
}

TEST(WorldBackground, TheProcessorTracksTheWalkerFromTheMovingScanner) {
    const char* site = R"(
origin: {lat_deg: 49.0, lon_deg: 8.4}
scanners: [{name: robot, max_range_m: 80}]
processing: {cycle_s: 0.1, confirm_hits: 3, scanner_timeout_s: 0.5, world: {max_range_m: 25}}
)";
    rs::Processor p(rs::parse_site(site, "yard.yaml"));
    const auto scans = yard_scans();
    try {
        p.push(scans.front());
        FAIL() << "a scan with a pose was classified without a world background";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("yard#0"), std::string::npos) << e.what();
    }
    rs::Processor fixed(rs::parse_site(site, "yard.yaml"));
    auto unposed = scans;
    for (auto& s : unposed) s.pose.reset();
    EXPECT_THROW(fixed.learn_world(unposed), std::invalid_argument);

    rs::Processor q(rs::parse_site(site, "yard.yaml"));
    q.learn_world(scans);
    std::vector<rs::Cycle> cycles;
    for (const auto& s : scans)
        for (auto& c : q.push(s)) cycles.push_back(std::move(c));
    for (auto& c : q.finish()) cycles.push_back(std::move(c));
    std::set<int> ids;
    double last_speed = 0.0, last_x = 0.0;
    // The world is learned at once: the first cycle closes one cycle after the first scan, not after a per-beam
    // background's learning time.
    ASSERT_FALSE(cycles.empty());
    EXPECT_NEAR(cycles.front().t_s, scans.front().time_s + q.site().settings.cycle_s, 1e-9);
    for (const auto& c : cycles)
        for (const auto& o : c.objects) ids.insert(o.id), last_speed = o.speed_mps, last_x = o.x_m;
    EXPECT_EQ(ids.size(), 1u);  // the walker, and nothing of the yard
    EXPECT_NEAR(last_speed, 5.0, 0.5);
    EXPECT_NEAR(last_x, 6.0, 0.3);
}
