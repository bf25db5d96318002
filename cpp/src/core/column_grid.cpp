// SPDX-License-Identifier: BSD-3-Clause
#include "core/column_grid.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

namespace roadpreview {

ColumnGrid::ColumnGrid(std::vector<Point> points, double edge) : points_(std::move(points)) { build(edge); }

void ColumnGrid::build(double edge) {
    if (!(edge > 0.0)) throw std::invalid_argument("ColumnGrid: the column edge must be positive");
    start_.clear();
    if (points_.empty()) return;
    x0_ = y0_ = std::numeric_limits<double>::infinity();
    x1_ = y1_ = -std::numeric_limits<double>::infinity();
    for (const Point& p : points_) {
        x0_ = std::min<double>(x0_, p.x), x1_ = std::max<double>(x1_, p.x);
        y0_ = std::min<double>(y0_, p.y), y1_ = std::max<double>(y1_, p.y);
    }
    const double side = std::floor(std::sqrt(std::max(4096.0, 4.0 * static_cast<double>(points_.size()))));
    edge_ = std::max({edge, (x1_ - x0_) / (side - 1.0), (y1_ - y0_) / (side - 1.0)});  // ≤ side columns a side
    const std::size_t nx = column(x1_, x0_) + 1;
    ny_ = column(y1_, y0_) + 1;
    // Counting sort by column.
    key_.resize(points_.size());
    start_.assign(nx * ny_ + 1, 0);
    for (std::size_t k = 0; k < points_.size(); ++k) {
        key_[k] = static_cast<std::uint32_t>(column(points_[k].x, x0_) * ny_ + column(points_[k].y, y0_));
        ++start_[key_[k] + 1];
    }
    for (std::size_t c = 0; c + 1 < start_.size(); ++c) start_[c + 1] += start_[c];
    sorted_.resize(points_.size());
    next_.assign(start_.begin(), start_.end() - 1);
    for (std::size_t k = 0; k < points_.size(); ++k) sorted_[next_[key_[k]]++] = points_[k];
    points_.swap(sorted_);
}

}  // namespace roadpreview
