// SPDX-License-Identifier: BSD-3-Clause
// Foreground, grid, dilation, labelling and per-object geometry of one cycle (docs/method.md, "Roadside").
#include "roadpreview/roadside/objects.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>

#include "core/text.hpp"

namespace roadpreview::roadside {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr long long kMaxGridCells = 16LL << 20;  // 16 Mi cells (1.6 km² at 0.1 m): larger is a units error

// Length along the heading ≥ width: swaps the sides and turns the heading by 90° when needed; heading in (−π/2, π/2].
Box normalised(Box b) {
    if (b.width_m > b.length_m) {
        std::swap(b.width_m, b.length_m);
        b.heading_rad += kPi / 2.0;
    }
    while (b.heading_rad > kPi / 2.0) b.heading_rad -= kPi;
    while (b.heading_rad <= -kPi / 2.0) b.heading_rad += kPi;
    return b;
}

Box min_area_box(const std::vector<Point2>& points) {
    const double ox = points[0].x_m, oy = points[0].y_m;  // float precision near the points, not the site origin
    std::vector<cv::Point2f> pts;
    pts.reserve(points.size());
    for (const auto& p : points) pts.emplace_back(static_cast<float>(p.x_m - ox), static_cast<float>(p.y_m - oy));
    const cv::RotatedRect r = cv::minAreaRect(pts);
    return normalised({r.center.x + ox, r.center.y + oy, r.size.width, r.size.height, r.angle * kPi / 180.0});
}

}  // namespace

std::array<std::array<double, 2>, 4> Box::corners() const {
    const double c = std::cos(heading_rad), s = std::sin(heading_rad);
    const double a = length_m / 2.0, b = width_m / 2.0;
    std::array<std::array<double, 2>, 4> out{};
    const double signs[4][2] = {{1, 1}, {-1, 1}, {-1, -1}, {1, -1}};
    for (int i = 0; i < 4; ++i) {
        const double u = signs[i][0] * a, v = signs[i][1] * b;
        out[i] = {x_m + c * u - s * v, y_m + s * u + c * v};
    }
    return out;
}

void BackgroundModel::learn(const LaserScan& scan) {
    if (frozen_) return;
    if (samples_.empty()) samples_.resize(scan.ranges_m.size());
    if (scan.ranges_m.size() != samples_.size())
        throw std::invalid_argument(scan.source + ": " + std::to_string(scan.ranges_m.size()) +
                                    " beams while learning a background of " + std::to_string(samples_.size()));
    for (std::size_t i = 0; i < samples_.size(); ++i) samples_[i].push_back(scan.ranges_m[i]);
    ++scans_;
}

void BackgroundModel::freeze() {
    median_m_.assign(samples_.size(), NAN);
    for (std::size_t i = 0; i < samples_.size(); ++i) {
        auto& v = samples_[i];
        const auto valid_end = std::partition(v.begin(), v.end(), [](float r) { return std::isfinite(r); });
        const auto valid = static_cast<std::size_t>(valid_end - v.begin());
        if (2 * valid <= v.size()) continue;  // mostly no return: nothing behind this beam
        const auto mid = v.begin() + static_cast<std::ptrdiff_t>(valid / 2);
        std::nth_element(v.begin(), mid, valid_end);
        median_m_[i] = *mid;
    }
    samples_.clear();
    samples_.shrink_to_fit();
    frozen_ = true;
}

std::vector<bool> BackgroundModel::foreground(const LaserScan& scan, double margin_m) const {
    if (scan.ranges_m.size() != median_m_.size())
        throw std::invalid_argument(scan.source + ": " + std::to_string(scan.ranges_m.size()) +
                                    " beams, the background was learned with " + std::to_string(median_m_.size()));
    std::vector<bool> fg(median_m_.size());
    for (std::size_t i = 0; i < fg.size(); ++i) {
        const float r = scan.ranges_m[i];
        fg[i] = std::isfinite(r) && (!std::isfinite(median_m_[i]) || r < median_m_[i] - margin_m);
    }
    return fg;
}

void scan_points(const LaserScan& scan, const Pose2& pose, const std::vector<bool>& mask, std::vector<Point2>& out) {
    const double c = std::cos(pose.yaw_rad), s = std::sin(pose.yaw_rad);
    for (std::size_t i = 0; i < scan.ranges_m.size(); ++i) {
        const float r = scan.ranges_m[i];
        if (!std::isfinite(r) || (!mask.empty() && !mask[i])) continue;
        const double a = scan.angle_rad(i);
        const double lx = r * std::cos(a), ly = r * std::sin(a);
        out.push_back({pose.x_m + c * lx - s * ly, pose.y_m + s * lx + c * ly, scan.scanner});
    }
}

namespace {

struct Cell {
    int row, col;
};

// Points (indices into `cell`) split into groups whose dilated cells cannot touch: a gap of more than 2d + 1 empty
// rows or columns between two groups leaves their dilated squares apart, so each group is labelled on a grid of its
// own bounding box — not one grid over the bounding box of everything, which for two cars 60 m apart held 360,000
// cells and took a millisecond. Splits by columns, then rows, until no gap is left.
std::vector<std::vector<std::size_t>> separate_groups(const std::vector<Cell>& cell, int dilation_cells) {
    std::vector<std::size_t> all(cell.size());
    for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
    std::vector<std::pair<std::vector<std::size_t>, bool>> pending{{std::move(all), false}};  // (points, by row?)
    std::vector<std::vector<std::size_t>> done;
    while (!pending.empty()) {
        std::vector<std::size_t> group = std::move(pending.back().first);
        const bool by_row = pending.back().second;
        pending.pop_back();
        const auto key = [&](std::size_t i) { return by_row ? cell[i].row : cell[i].col; };
        std::sort(group.begin(), group.end(), [&](std::size_t a, std::size_t b) { return key(a) < key(b); });
        std::size_t first = 0;
        for (std::size_t k = 1; k <= group.size(); ++k) {
            if (k < group.size() && key(group[k]) - key(group[k - 1]) <= 2 * dilation_cells + 1) continue;
            std::vector<std::size_t> part(group.begin() + static_cast<std::ptrdiff_t>(first),
                                          group.begin() + static_cast<std::ptrdiff_t>(k));
            if (first == 0 && k == group.size()) {  // no gap this way
                if (by_row) done.push_back(std::move(part));
                else pending.push_back({std::move(part), true});
            } else {
                pending.push_back({std::move(part), !by_row});  // a part may split again the other way
            }
            first = k;
        }
    }
    return done;
}

// One component of a group: where it first appears in raster order (row, then column) and its cells.
struct Component {
    Cell first;
    int cells;
};

}  // namespace

GridLabels label_points(const std::vector<Point2>& points, double cell_m, int dilation_cells) {
    if (!(cell_m > 0.0) || !std::isfinite(cell_m))
        throw std::invalid_argument("label_points: the cell must be a finite size > 0 m, got " + std::to_string(cell_m));
    if (dilation_cells < 0)
        throw std::invalid_argument("label_points: the dilation must be >= 0 cells, got " + std::to_string(dilation_cells));
    GridLabels g;
    g.cell_m = cell_m;
    g.cells.assign(1, 0);
    if (points.empty()) return g;
    double x_min = points[0].x_m, x_max = x_min, y_min = points[0].y_m, y_max = y_min;
    for (const auto& p : points) {
        x_min = std::min(x_min, p.x_m), x_max = std::max(x_max, p.x_m);
        y_min = std::min(y_min, p.y_m), y_max = std::max(y_max, p.y_m);
    }
    const int margin_cells = dilation_cells + 1;
    const double margin = margin_cells * cell_m;
    g.x0_m = x_min - margin;
    g.y0_m = y_min - margin;
    const double cols = std::floor((x_max + margin - g.x0_m) / cell_m) + 1;
    const double rows = std::floor((y_max + margin - g.y0_m) / cell_m) + 1;
    if (!(rows * cols <= static_cast<double>(kMaxGridCells)))
        throw std::invalid_argument("foreground spans " + number_text(x_max - x_min) + " × " +
                                    number_text(y_max - y_min) + " m: too large a grid at cell " +
                                    number_text(cell_m) + " m");
    std::vector<Cell> cell(points.size());
    for (std::size_t i = 0; i < points.size(); ++i)
        cell[i] = {static_cast<int>((points[i].y_m - g.y0_m) / cell_m), static_cast<int>((points[i].x_m - g.x0_m) / cell_m)};

    // Each group on its own grid (its cells' box and the dilation margin); the components of all groups numbered
    // by their first cell in raster order over the whole area, whatever order the groups came in.
    std::vector<Component> components;
    std::vector<std::pair<std::size_t, std::size_t>> point_component;  // (point, index into components)
    for (const auto& group : separate_groups(cell, dilation_cells)) {
        int r0 = cell[group[0]].row, r1 = r0, c0 = cell[group[0]].col, c1 = c0;
        for (const auto i : group) {
            r0 = std::min(r0, cell[i].row), r1 = std::max(r1, cell[i].row);
            c0 = std::min(c0, cell[i].col), c1 = std::max(c1, cell[i].col);
        }
        r0 -= margin_cells, c0 -= margin_cells;
        cv::Mat occupied = cv::Mat::zeros(r1 + margin_cells - r0 + 1, c1 + margin_cells - c0 + 1, CV_8U);
        for (const auto i : group) occupied.at<std::uint8_t>(cell[i].row - r0, cell[i].col - c0) = 255;
        cv::Mat dilated = occupied;
        if (dilation_cells > 0) {
            const int k = 2 * dilation_cells + 1;
            cv::dilate(occupied, dilated, cv::getStructuringElement(cv::MORPH_RECT, {k, k}));
        }
        cv::Mat labels, stats, centroids;
        const int n = cv::connectedComponentsWithStats(dilated, labels, stats, centroids, 8, CV_32S);
        const std::size_t base = components.size();
        for (int l = 1; l < n; ++l) components.push_back({{-1, -1}, stats.at<int>(l, cv::CC_STAT_AREA)});
        for (int r = 0; r < labels.rows; ++r)  // the first cell of each component
            for (int c = 0; c < labels.cols; ++c)
                if (const int l = labels.at<std::int32_t>(r, c); l > 0 && components[base + l - 1].first.row < 0)
                    components[base + l - 1].first = {r + r0, c + c0};
        for (const auto i : group)
            point_component.push_back({i, base + labels.at<std::int32_t>(cell[i].row - r0, cell[i].col - c0) - 1});
    }
    std::vector<std::size_t> order(components.size());
    for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
        return std::tie(components[a].first.row, components[a].first.col) <
               std::tie(components[b].first.row, components[b].first.col);
    });
    std::vector<std::int32_t> label_of(components.size());
    g.components = static_cast<int>(components.size());
    for (std::size_t rank = 0; rank < order.size(); ++rank) {
        label_of[order[rank]] = static_cast<std::int32_t>(rank + 1);
        g.cells.push_back(components[order[rank]].cells);
    }
    g.point_label.resize(points.size());
    for (const auto& [i, k] : point_component) g.point_label[i] = label_of[k];
    return g;
}

Box fit_l_shape(const std::vector<Point2>& points) {
    if (points.empty()) throw std::invalid_argument("fit_l_shape: no points to fit a box to");
    if (points.size() < 3) return min_area_box(points);
    const double d0 = 0.01;  // m: closeness saturates here so that one exact point does not dominate
    double best_score = -1.0;
    Box best;
    std::vector<double> c1(points.size()), c2(points.size());
    for (int step = 0; step < 90; ++step) {
        const double th = step * kPi / 180.0, c = std::cos(th), s = std::sin(th);
        for (std::size_t i = 0; i < points.size(); ++i) {
            c1[i] = c * points[i].x_m + s * points[i].y_m;
            c2[i] = -s * points[i].x_m + c * points[i].y_m;
        }
        const auto [lo1, hi1] = std::minmax_element(c1.begin(), c1.end());
        const auto [lo2, hi2] = std::minmax_element(c2.begin(), c2.end());
        double score = 0.0;
        for (std::size_t i = 0; i < points.size(); ++i) {
            const double d1 = std::min(*hi1 - c1[i], c1[i] - *lo1), d2 = std::min(*hi2 - c2[i], c2[i] - *lo2);
            score += 1.0 / std::max(std::min(d1, d2), d0);
        }
        if (score > best_score) {
            best_score = score;
            const double m1 = (*lo1 + *hi1) / 2.0, m2 = (*lo2 + *hi2) / 2.0;
            best = {c * m1 - s * m2, s * m1 + c * m2, *hi1 - *lo1, *hi2 - *lo2, th};
        }
    }
    return normalised(best);
}

std::vector<ScanObject> grid_objects(const std::vector<Point2>& points, const GridLabels& grid, int min_points) {
    std::vector<std::vector<Point2>> members(static_cast<std::size_t>(grid.components) + 1);
    for (std::size_t i = 0; i < points.size(); ++i) members[static_cast<std::size_t>(grid.point_label[i])].push_back(points[i]);
    std::vector<ScanObject> out;
    for (std::size_t label = 1; label < members.size(); ++label) {
        const auto& m = members[label];
        if (static_cast<int>(m.size()) < min_points) continue;
        ScanObject o;
        o.points = static_cast<int>(m.size());
        o.cells = grid.cells[label];
        for (const auto& p : m) {
            o.centroid_x_m += p.x_m / o.points;
            o.centroid_y_m += p.y_m / o.points;
            o.scanners |= 1u << (p.scanner & 31);
        }
        o.mbr = min_area_box(m);
        o.l_shape = fit_l_shape(m);
        o.members = m;
        out.push_back(std::move(o));
    }
    return out;
}

}  // namespace roadpreview::roadside
