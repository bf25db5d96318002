// SPDX-License-Identifier: BSD-3-Clause
// The background of a moving scanner whose scans carry poses (a robot's log with corrected poses): a world grid
// that counts, per cell, the scans that saw through it and the scans that ended a beam in it. A return where other
// scans mostly saw through, briefly interrupted, is foreground: something that passed (docs/method.md, "Roadside").
#pragma once

#include <cstdint>
#include <vector>

#include "roadpreview/roadside/scan.hpp"

namespace roadpreview::roadside {

/// Settings of the world background (the `world:` block of the site's `processing:`), with their defaults.
struct WorldBackgroundSettings {
    double cell_m = 0.2;          ///< world grid cell
    double free_margin_m = 0.3;   ///< a beam saw through the cells up to this much short of its return
    double max_range_m = 30.0;    ///< beams count (seen free and returns) up to this range; farther is not classified
    int min_free_scans = 10;      ///< a return is foreground only where at least this many scans saw through …
    int hit_radius_cells = 3;     ///< … and the scans with a return within this many cells (a (2r+1)² square) …
    double max_hit_ratio = 0.1;   ///< … are at most this share of them …
    double max_hit_s = 4.0;       ///< … and at most this long a stretch of the log's scanning (scans × period)
};

class WorldBackground {
public:
    /// Learns from every scan, each placed in the world by its pose (`poses[i]` for `scans[i]`). The scan period
    /// is the median interval of the scans' times. Throws std::invalid_argument for no scans, a size mismatch,
    /// scans that do not advance in time, or poses spread over more than the grid limit (a units error).
    WorldBackground(const std::vector<LaserScan>& scans, const std::vector<Pose2>& poses, WorldBackgroundSettings s);

    /// Foreground flags per beam of a scan at `pose` (a no return or a return beyond `max_range_m` is not).
    std::vector<bool> foreground(const LaserScan& scan, const Pose2& pose) const;

    int free_scans(double x_m, double y_m) const;  ///< scans that saw through the cell of (x, y); 0 off the grid
    int hit_scans(double x_m, double y_m) const;   ///< scans with a return in that cell or within the radius
    double scan_period_s() const { return period_s_; }
    int max_hit_scans() const;  ///< the hit limit in scans: max_hit_s / period, at least 1
    int width_cells() const { return width_; }
    int height_cells() const { return height_; }

    struct GridPosition {
        double col, row;  ///< in cells from the grid's corner, fractional
    };

private:
    GridPosition grid_position(double x_m, double y_m) const;
    long long cell_index(double x_m, double y_m) const;  ///< −1 off the grid
    WorldBackgroundSettings s_;
    double x0_m_ = 0.0, y0_m_ = 0.0, period_s_ = 0.0;
    int width_ = 0, height_ = 0;
    std::vector<std::int32_t> free_, hits_near_;  ///< row-major, height × width
};

}  // namespace roadpreview::roadside
