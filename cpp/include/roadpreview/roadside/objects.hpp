// SPDX-License-Identifier: BSD-3-Clause
// Per cycle: each scanner's foreground against its learned background, an occupancy grid of the foreground
// points of all scanners, dilation and connected components (OpenCV), and per component its centroid, minimum
// area rectangle and an L-shape box (docs/method.md, "Roadside").
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "roadpreview/roadside/scan.hpp"
#include "roadpreview/roadside/site.hpp"

namespace roadpreview::roadside {

struct Point2 {
    double x_m = 0.0, y_m = 0.0;
    int scanner = 0;
};

/// An oriented rectangle: centre, axes along `heading_rad` (length) and across (width).
struct Box {
    double x_m = 0.0, y_m = 0.0, length_m = 0.0, width_m = 0.0, heading_rad = 0.0;
    std::array<std::array<double, 2>, 4> corners() const;
};

struct ScanObject {
    double centroid_x_m = 0.0, centroid_y_m = 0.0;  ///< mean of the object's points
    Box mbr;                                          ///< cv::minAreaRect of the points (length ≥ width)
    Box l_shape;                                      ///< rectangle fitted to the visible sides (length ≥ width)
    int points = 0;
    int cells = 0;                                    ///< grid cells of the component (after dilation)
    std::uint32_t scanners = 0;                       ///< bit i: scanner i saw it
    std::vector<Point2> members;                      ///< its points
};

/// Per-beam background of one scanner: the median range of each beam over the learning scans (no return when
/// most of them had none). A beam returning `margin_m` or more in front of it is foreground.
class BackgroundModel {
public:
    void learn(const LaserScan& scan);
    void freeze();  ///< computes the medians; later scans are classified
    bool frozen() const { return frozen_; }
    int learned_scans() const { return scans_; }
    /// Foreground flags per beam; throws std::invalid_argument when the beam count differs from the learned one.
    std::vector<bool> foreground(const LaserScan& scan, double margin_m) const;
    const std::vector<float>& background_m() const { return median_m_; }

private:
    std::vector<std::vector<float>> samples_;
    std::vector<float> median_m_;
    int scans_ = 0;
    bool frozen_ = false;
};

/// Beam endpoints in the site frame, for the beams flagged (all valid beams when `mask` is empty).
void scan_points(const LaserScan& scan, const Pose2& pose, const std::vector<bool>& mask, std::vector<Point2>& out);

/// Components of a grid: cell (row, col) of point p is (floor((y − y0)/cell), floor((x − x0)/cell)).
struct GridLabels {
    double x0_m = 0.0, y0_m = 0.0, cell_m = 0.1;
    int components = 0;                     ///< components excluding the background label 0
    std::vector<int> cells;                 ///< per label 1 … components (0 unused): its cells after dilation
    std::vector<std::int32_t> point_label;  ///< per input point
};

/// Occupancy grid of the points, dilated by a (2r+1)² square (cv::dilate), labelled with 8-connectivity
/// (cv::connectedComponentsWithStats), components numbered in raster order (row, then column) of their first cell.
/// The grid covers the points' bounding box plus the dilation margin; groups of points too far apart to touch are
/// labelled on grids of their own, so the work follows the occupied area, not the spread.
GridLabels label_points(const std::vector<Point2>& points, double cell_m, int dilation_cells);

/// Rectangle of the points whose sides best fit them as seen from outside (search over orientations in 1°
/// steps, maximising the closeness of each point to its nearer rectangle edge); length ≥ width.
Box fit_l_shape(const std::vector<Point2>& points);

/// Objects of a labelled grid; components with fewer than `min_points` points are dropped.
std::vector<ScanObject> grid_objects(const std::vector<Point2>& points, const GridLabels& grid, int min_points);

}  // namespace roadpreview::roadside
