// SPDX-License-Identifier: BSD-3-Clause
// Internal: points bucketed into square columns in x, y, each column ordered by z, so that the points inside a
// box are found by visiting the few columns it overlaps and one z range in each.
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

    /// Calls visit(p) for every point p with x_lo ≤ p.x ≤ x_hi, y_lo ≤ p.y ≤ y_hi and z_lo ≤ p.z ≤ z_hi.
    template <class Visit>
    void visit(double x_lo, double x_hi, double y_lo, double y_hi, double z_lo, double z_hi, Visit&& visit) const {
        if (points_.empty() || x_hi < x0_ || x_lo > x1_ || y_hi < y0_ || y_lo > y1_) return;
        const std::size_t ix1 = column(std::min(x_hi, x1_), x0_), iy1 = column(std::min(y_hi, y1_), y0_);
        for (std::size_t ix = column(std::max(x_lo, x0_), x0_); ix <= ix1; ++ix) {
            for (std::size_t iy = column(std::max(y_lo, y0_), y0_); iy <= iy1; ++iy) {
                const std::size_t c = ix * ny_ + iy;
                const auto last = points_.begin() + start_[c + 1];
                auto p = std::lower_bound(points_.begin() + start_[c], last, z_lo,
                                          [](const Point& q, double z) { return q.z < z; });
                for (; p != last && p->z <= z_hi; ++p)
                    if (p->x >= x_lo && p->x <= x_hi && p->y >= y_lo && p->y <= y_hi) visit(*p);
            }
        }
    }

private:
    std::size_t column(double v, double origin) const { return static_cast<std::size_t>((v - origin) / edge_); }

    double x0_ = 0.0, x1_ = 0.0, y0_ = 0.0, y1_ = 0.0, edge_ = 1.0;
    std::size_t ny_ = 0;
    std::vector<std::uint32_t> start_;  // column c holds points_[start_[c] … start_[c + 1])
    std::vector<Point> points_;
};

}  // namespace roadpreview
