// SPDX-License-Identifier: BSD-3-Clause
// The world background of a moving scanner (docs/method.md, "Roadside: a moving scanner"): free space by filling
// each scan's polygon of shortened beams (cv::fillPoly), returns by stamping each scan's return cells dilated by the
// hit radius (cv::dilate), both counted once per scan.
#include "roadpreview/roadside/world_background.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

#include "core/text.hpp"

namespace roadpreview::roadside {
namespace {

constexpr long long kMaxGridCells = 16LL << 20;  // 16 Mi cells (670 km² at 0.2 m … 0.67 km²): larger is a units error
constexpr int kShift = 4;                        // fixed-point bits of the polygon vertices (1/16 cell)

void check_settings(const WorldBackgroundSettings& s) {
    if (!(s.cell_m >= 0.01) || !(s.free_margin_m >= 0.0) || !(s.max_range_m > s.free_margin_m) ||
        s.min_free_scans < 1 || s.hit_radius_cells < 0 || s.hit_radius_cells > 50 || !(s.max_hit_ratio > 0.0) ||
        !(s.max_hit_s > 0.0) || !std::isfinite(s.max_range_m))
        throw std::invalid_argument("world background: settings out of range (cell_m ≥ 0.01, free_margin_m ≥ 0, "
                                    "max_range_m > free_margin_m, min_free_scans ≥ 1, hit_radius_cells 0..50, "
                                    "max_hit_ratio > 0, max_hit_s > 0)");
}

using GridPosition = WorldBackground::GridPosition;

// A polygon vertex in fixed point: cv::fillPoly fills the pixels whose centres (cell + 0.5) lie inside.
cv::Point vertex(const GridPosition& g) {
    const auto fixed = [](double cells) { return static_cast<int>(std::lround((cells - 0.5) * (1 << kShift))); };
    return {fixed(g.col), fixed(g.row)};
}

// The cell holding a grid position.
cv::Point cell_of(const GridPosition& g) {
    return {static_cast<int>(std::floor(g.col)), static_cast<int>(std::floor(g.row))};
}

// The median interval between consecutive scan times; the scans must advance.
double scan_period(const std::vector<LaserScan>& scans) {
    std::vector<double> t, dt;
    for (const auto& s : scans) t.push_back(s.time_s);
    std::sort(t.begin(), t.end());
    for (std::size_t i = 1; i < t.size(); ++i) dt.push_back(t[i] - t[i - 1]);
    if (dt.empty()) return 1.0;  // one scan: any period; nothing else can hit
    std::nth_element(dt.begin(), dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2), dt.end());
    const double period = dt[dt.size() / 2];
    if (!(period > 0.0) || !std::isfinite(period))
        throw std::invalid_argument(scans.front().source + ": the scans for a world background do not advance in time "
                                    "(median interval " + number_text(period) + " s)");
    return period;
}

}  // namespace

WorldBackground::WorldBackground(const std::vector<LaserScan>& scans, const std::vector<Pose2>& poses,
                                 WorldBackgroundSettings s)
    : s_(s) {
    check_settings(s_);
    if (scans.empty()) throw std::invalid_argument("world background: no scans to learn from");
    if (scans.size() != poses.size())
        throw std::invalid_argument("world background: " + std::to_string(scans.size()) + " scans but " +
                                    std::to_string(poses.size()) + " poses");
    period_s_ = scan_period(scans);
    double x_lo = INFINITY, x_hi = -INFINITY, y_lo = INFINITY, y_hi = -INFINITY;
    for (std::size_t i = 0; i < poses.size(); ++i) {
        const Pose2& p = poses[i];
        if (!std::isfinite(p.x_m) || !std::isfinite(p.y_m) || !std::isfinite(p.yaw_rad))
            throw std::invalid_argument(scans[i].source + ": the scan's pose is not finite");
        x_lo = std::min(x_lo, p.x_m), x_hi = std::max(x_hi, p.x_m);
        y_lo = std::min(y_lo, p.y_m), y_hi = std::max(y_hi, p.y_m);
    }
    const double reach = s_.max_range_m + s_.cell_m;
    x0_m_ = x_lo - reach, y0_m_ = y_lo - reach;
    const double w = std::ceil((x_hi - x_lo + 2.0 * reach) / s_.cell_m), h = std::ceil((y_hi - y_lo + 2.0 * reach) / s_.cell_m);
    if (w * h > static_cast<double>(kMaxGridCells))
        throw std::invalid_argument(scans.front().source + ": the scans' poses span " + number_text(x_hi - x_lo) +
                                    " × " + number_text(y_hi - y_lo) + " m, too large for a world grid of " +
                                    number_text(s_.cell_m) + " m cells (poses in metres?)");
    width_ = static_cast<int>(w), height_ = static_cast<int>(h);
    free_.assign(static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_), 0);
    hits_near_.assign(free_.size(), 0);
    cv::Mat free(height_, width_, CV_32S, free_.data()), near(height_, width_, CV_32S, hits_near_.data());
    const int r = s_.hit_radius_cells;
    const cv::Mat kernel = cv::Mat::ones(2 * r + 1, 2 * r + 1, CV_8U);
    std::vector<cv::Point> polygon, returns;
    for (std::size_t i = 0; i < scans.size(); ++i) {
        const LaserScan& scan = scans[i];
        const Pose2& pose = poses[i];
        // The scan's polygon: its origin and every beam shortened by the margin (no return: out to the range limit).
        polygon.assign(1, vertex(grid_position(pose.x_m, pose.y_m)));
        returns.clear();
        for (std::size_t b = 0; b < scan.ranges_m.size(); ++b) {
            const double range = scan.ranges_m[b], a = pose.yaw_rad + scan.angle_rad(b);
            const bool hit = std::isfinite(range) && range > 0.0 && range <= s_.max_range_m;
            const double free_m = hit ? std::max(0.0, range - s_.free_margin_m) : s_.max_range_m;
            polygon.push_back(vertex(grid_position(pose.x_m + free_m * std::cos(a), pose.y_m + free_m * std::sin(a))));
            if (hit) returns.push_back(cell_of(grid_position(pose.x_m + range * std::cos(a), pose.y_m + range * std::sin(a))));
        }
        // Each count on a window around the scan (the grid reaches max_range_m + a cell beyond every pose).
        const cv::Point centre = cell_of(grid_position(pose.x_m, pose.y_m));
        const int half = static_cast<int>(std::ceil(s_.max_range_m / s_.cell_m)) + 1;
        const cv::Rect window =
            cv::Rect(centre.x - half, centre.y - half, 2 * half + 1, 2 * half + 1) & cv::Rect(0, 0, width_, height_);
        cv::Mat mask = cv::Mat::zeros(window.size(), CV_8U);
        for (auto& p : polygon) p -= cv::Point(window.x << kShift, window.y << kShift);
        cv::fillPoly(mask, std::vector<std::vector<cv::Point>>{polygon}, cv::Scalar(1), cv::LINE_8, kShift);
        cv::Mat free_window = free(window);
        cv::add(free_window, mask, free_window, cv::noArray(), CV_32S);
        mask.setTo(0);
        for (const auto& p : returns) {
            const cv::Point q = p - window.tl();
            if (q.inside(cv::Rect(0, 0, mask.cols, mask.rows))) mask.at<std::uint8_t>(q) = 1;
        }
        if (r > 0) cv::dilate(mask, mask, kernel);
        cv::Mat near_window = near(window);
        cv::add(near_window, mask, near_window, cv::noArray(), CV_32S);
    }
}

WorldBackground::GridPosition WorldBackground::grid_position(double x_m, double y_m) const {
    return {(x_m - x0_m_) / s_.cell_m, (y_m - y0_m_) / s_.cell_m};
}

long long WorldBackground::cell_index(double x_m, double y_m) const {
    const GridPosition g = grid_position(x_m, y_m);
    const double c = std::floor(g.col), r = std::floor(g.row);
    if (!(c >= 0.0 && c < width_ && r >= 0.0 && r < height_)) return -1;
    return static_cast<long long>(r) * width_ + static_cast<long long>(c);
}

int WorldBackground::free_scans(double x_m, double y_m) const {
    const long long k = cell_index(x_m, y_m);
    return k < 0 ? 0 : free_[static_cast<std::size_t>(k)];
}

int WorldBackground::hit_scans(double x_m, double y_m) const {
    const long long k = cell_index(x_m, y_m);
    return k < 0 ? 0 : hits_near_[static_cast<std::size_t>(k)];
}

int WorldBackground::max_hit_scans() const {
    return std::max(1, static_cast<int>(std::floor(s_.max_hit_s / period_s_ + 1e-9)));
}

std::vector<bool> WorldBackground::foreground(const LaserScan& scan, const Pose2& pose) const {
    std::vector<bool> fg(scan.ranges_m.size(), false);
    const int max_hits = max_hit_scans();
    for (std::size_t b = 0; b < fg.size(); ++b) {
        const double range = scan.ranges_m[b], a = pose.yaw_rad + scan.angle_rad(b);
        if (!(std::isfinite(range) && range > 0.0 && range <= s_.max_range_m)) continue;
        const long long k = cell_index(pose.x_m + range * std::cos(a), pose.y_m + range * std::sin(a));
        if (k < 0) continue;
        const int seen_free = free_[static_cast<std::size_t>(k)], hits = hits_near_[static_cast<std::size_t>(k)];
        fg[b] = seen_free >= s_.min_free_scans && hits <= std::min<double>(s_.max_hit_ratio * seen_free, max_hits);
    }
    return fg;
}

}  // namespace roadpreview::roadside
