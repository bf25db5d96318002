// SPDX-License-Identifier: BSD-3-Clause
// Internal: points bucketed into square columns in x, y (a counting sort), so that the points near a place are
// found by visiting the few columns around it.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace roadpreview {

class ColumnGrid {
public:
    struct Point {
        float x, y, z;
        std::int32_t index;  ///< the caller's
    };

    ColumnGrid() = default;
    /// Columns `edge` wide (> 0), wider when the points spread so far that there would be more than
    /// max(4096, 4 × points) of them.
    ColumnGrid(std::vector<Point> points, double edge);

    /// Grids the points that fill(buffer) appends to an emptied buffer, reusing every buffer of the grid.
    template <class Fill>
    void rebuild(double edge, Fill&& fill) {
        points_.clear();
        fill(points_);
        build(edge);
    }

    /// Calls visit(p) for every point p of the columns that overlap [x_lo, x_hi] × [y_lo, y_hi]: those inside
    /// it and some around it, for the caller to test.
    template <class Visit>
    void visit_columns(double x_lo, double x_hi, double y_lo, double y_hi, Visit&& visit) const {
        for_columns(x_lo, x_hi, y_lo, y_hi, [&](std::size_t c) {
            for (std::uint32_t k = start_[c]; k < start_[c + 1]; ++k) visit(points_[k]);
        });
    }

    /// Calls visit(p, q) once for each point p and each point q after it in the grid's order that lies in a
    /// column overlapping [p.x − reach, p.x + reach] × [p.y − reach, p.y + reach]: every pair of points closer than
    /// `reach` once, and some farther, for the caller to test.
    template <class Visit>
    void visit_pairs(double reach, Visit&& visit) const {
        for (std::size_t c = 0; c + 1 < start_.size(); ++c) {
            for (std::uint32_t k = start_[c]; k < start_[c + 1]; ++k) {
                const Point& p = points_[k];
                for_columns(p.x - reach, p.x + reach, p.y - reach, p.y + reach, [&](std::size_t d) {
                    if (d < c) return;  // p was visited with the points of that column
                    for (std::uint32_t m = d == c ? k + 1 : start_[d]; m < start_[d + 1]; ++m) visit(p, points_[m]);
                });
            }
        }
    }

private:
    // Calls visit(c) for each column c that overlaps [x_lo, x_hi] × [y_lo, y_hi], in the grid's order.
    template <class Visit>
    void for_columns(double x_lo, double x_hi, double y_lo, double y_hi, Visit&& visit) const {
        if (points_.empty() || x_hi < x0_ || x_lo > x1_ || y_hi < y0_ || y_lo > y1_) return;
        const std::size_t ix1 = column(std::min(x_hi, x1_), x0_), iy1 = column(std::min(y_hi, y1_), y0_);
        for (std::size_t ix = column(std::max(x_lo, x0_), x0_); ix <= ix1; ++ix)
            for (std::size_t iy = column(std::max(y_lo, y0_), y0_); iy <= iy1; ++iy) visit(ix * ny_ + iy);
    }

    void build(double edge);
    std::size_t column(double v, double origin) const { return static_cast<std::size_t>((v - origin) / edge_); }

    double x0_ = 0.0, x1_ = 0.0, y0_ = 0.0, y1_ = 0.0, edge_ = 1.0;
    std::size_t ny_ = 0;
    std::vector<std::uint32_t> start_;  // column c holds points_[start_[c] … start_[c + 1])
    std::vector<Point> points_;
    std::vector<std::uint32_t> key_, next_;  // scratch of build, kept for rebuild
    std::vector<Point> sorted_;
};

}  // namespace roadpreview
