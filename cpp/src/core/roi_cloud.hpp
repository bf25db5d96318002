// SPDX-License-Identifier: BSD-3-Clause
// Internal: the one per-frame copy of the cloud — base-frame points of the front ROI, stored as a PCL
// cloud so that RANSAC (and later clustering) use it in place, and viewed as N×3 floats by everything else.
// The points are ordered by square cells of the ROI (a counting sort, stable: input order within a cell), so
// that every later stage reads memory in spatial order whatever the order of the input rows.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "roadpreview/core/config.hpp"
#include "roadpreview/core/frames.hpp"
#include "roadpreview/core/points.hpp"

namespace roadpreview {

// The cells of the ROI: square columns about the clustering's reach and the obstacles' ground columns wide, so that
// neighbours in space are neighbours in memory (a huge ROI gets wider columns rather than millions of empty ones),
// cut into slabs of base-frame height, so that within a column the road comes before what stands on it and a test
// for ground or not ground sees long runs of equal answers, whatever the order of the input rows.
class RoiCells {
public:
    static constexpr double kCellEdgeM = 1.0;
    static constexpr double kMaxCellsPerSide = 128.0;  // at most 128 × 128 columns × kSlabs cells: 2 MB of counts
    static constexpr double kSlabLowM = -1.0, kSlabM = 0.1;  // below kSlabLowM: the first slab
    static constexpr std::uint32_t kSlabs = 32;                // from kSlabLowM + (kSlabs - 1)·kSlabM up: the last one

    RoiCells() = default;
    explicit RoiCells(const GroundConfig& g)
        : x_lo_(g.roi_x_min_m), y_lo_(-g.roi_y_abs_max_m),
          // a factor: multiplications, not divisions, per point
          per_m_(1.0 / std::max({kCellEdgeM, (g.roi_x_max_m - x_lo_) / (kMaxCellsPerSide - 1.0),
                                 -2.0 * y_lo_ / (kMaxCellsPerSide - 1.0)})),
          x_last_(index(g.roi_x_max_m, x_lo_)), y_last_(index(-y_lo_, y_lo_)) {}

    std::uint32_t cells() const { return columns() * kSlabs; }

    // min: a coordinate rounded to float may lie just beyond the ROI (just before it truncates to cell 0).
    std::uint32_t cell(float x, float y, float z) const {
        const double above = std::max(0.0, (static_cast<double>(z) - kSlabLowM) * (1.0 / kSlabM));
        return column(x, y) * kSlabs + std::min(static_cast<std::uint32_t>(std::min(above, 1e6)), kSlabs - 1);
    }

    /// The columns overlapping [x_lo, x_hi] × [y_lo, y_hi]: calls visit(column) for each (those beyond the ROI's
    /// edge columns fall into them).
    template <class Visit>
    void visit_columns(double x_lo, double x_hi, double y_lo, double y_hi, Visit&& visit) const {
        const std::uint32_t ix1 = x_index(x_hi), iy0 = y_index(y_lo), iy1 = y_index(y_hi);
        for (std::uint32_t ix = x_index(x_lo); ix <= ix1; ++ix)
            for (std::uint32_t iy = iy0; iy <= iy1; ++iy) visit(ix * (y_last_ + 1) + iy);
    }

private:
    std::uint32_t columns() const { return (x_last_ + 1) * (y_last_ + 1); }
    std::uint32_t column(double x, double y) const { return x_index(x) * (y_last_ + 1) + y_index(y); }
    std::uint32_t x_index(double x) const { return std::min(index(x, x_lo_), x_last_); }
    std::uint32_t y_index(double y) const { return std::min(index(y, y_lo_), y_last_); }
    std::uint32_t index(double v, double lo) const {
        return static_cast<std::uint32_t>(std::clamp((v - lo) * per_m_, 0.0, 1e9));
    }

    double x_lo_ = 0.0, y_lo_ = 0.0, per_m_ = 1.0;
    std::uint32_t x_last_ = 0, y_last_ = 0;
};

struct RoiCloud {
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud{new pcl::PointCloud<pcl::PointXYZ>};
    std::vector<std::int32_t> input_index;  ///< input row of each ROI point
    std::vector<std::int32_t> input_order;  ///< the ROI points' positions in the order of their input rows
    std::int64_t finite = 0;                ///< input rows with finite x, y, z
    std::vector<float> height_variance;     ///< m² per ROI point (from its range variance); empty when unknown
    std::vector<std::int32_t> error_group;  ///< each ROI point's input error group; empty when unknown

    Eigen::Index size() const { return static_cast<Eigen::Index>(input_index.size()); }
    PointsView view() const {  // pcl::PointXYZ is x, y, z + one padding float
        static_assert(sizeof(pcl::PointXYZ) == 4 * sizeof(float));
        return points_view(cloud->points.empty() ? nullptr : cloud->points[0].data, size(), 4);
    }

    /// Calls visit(k) for every ROI point k of the cells' columns that overlap [x_lo, x_hi] × [y_lo, y_hi]: those
    /// inside it and some around it, for the caller to test.
    template <class Visit>
    void visit_columns(double x_lo, double x_hi, double y_lo, double y_hi, Visit&& visit) const {
        if (input_index.empty()) return;
        cells.visit_columns(x_lo, x_hi, y_lo, y_hi, [&](std::uint32_t column) {
            const std::uint32_t first = cell_start[column * RoiCells::kSlabs];
            const std::uint32_t last = cell_start[(column + 1) * RoiCells::kSlabs];
            for (std::uint32_t k = first; k < last; ++k) visit(static_cast<Eigen::Index>(k));
        });
    }

    // Scratch of crop_roi, kept so that a stream of frames allocates nothing once the buffers have grown.
    struct Candidate {
        float x, y, z;
        std::uint32_t cell;
        std::int32_t row;
    };
    std::vector<Candidate> scratch;
    RoiCells cells;                        ///< the cells the points are ordered by
    std::vector<std::uint32_t> cell_start;  ///< cell c holds points cell_start[c] … cell_start[c + 1]
};

/// Transform, drop non-finite rows (counted), crop to the ROI and order the points by cell; reuses `out`'s
/// buffers. The rows are transformed on up to `threads` threads (the same answer for any number).
void crop_roi(PointsView input, const RigidTransform& T, const GroundConfig& g, RoiCloud& out, int threads = 1);

/// The LiDAR beams' elevation errors, σ in radians: ProfileConfig::beam_sigmas_deg for the beams it lists,
/// beam_sigma_deg for the others.
class BeamErrors {
public:
    BeamErrors() = default;
    explicit BeamErrors(const ProfileConfig& p);
    /// Whether any beam's error is counted (some σ > 0).
    bool counted() const { return counted_; }
    double sigma_rad(std::int32_t beam) const {
        return beam >= 0 && static_cast<std::size_t>(beam) < listed_.size() ? listed_[static_cast<std::size_t>(beam)]
                                                                             : others_;
    }

private:
    double others_ = 0.0;
    std::vector<double> listed_;
    bool counted_ = false;
};

/// Each ROI point's height variance (none: cleared): from its input row's range variance, an error along the line of
/// sight from the sensor (at T's origin) moving the point by u_z per metre, u the ray's direction; plus, with its
/// beam known and its beam's error counted, that beam's elevation error, which moves it by its horizontal distance d
/// from the sensor per radian (d²·σ²). And its error group (none: cleared): its input row's, else, while the beams'
/// errors are counted, its beam if that beam's σ > 0 (−1 − its input row, a group of its own, if not, or if its beam
/// is unknown: < 0).
void roi_point_errors(const PointErrors& errors, const RigidTransform& T, const BeamErrors& beams, RoiCloud& roi);

}  // namespace roadpreview
