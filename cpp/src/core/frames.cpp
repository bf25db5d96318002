// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/core/frames.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/roi_cloud.hpp"

namespace roadpreview {

RigidTransform to_rigid_transform(const Extrinsics& e) {
    const double cr = std::cos(e.roll_rad), sr = std::sin(e.roll_rad);
    const double cp = std::cos(e.pitch_rad), sp = std::sin(e.pitch_rad);
    const double cy = std::cos(e.yaw_rad), sy = std::sin(e.yaw_rad);
    // Rz(yaw) · Ry(pitch) · Rx(roll)
    return RigidTransform{{{cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr},
                           {sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr},
                           {-sp, cp * sr, cp * cr}},
                          {e.x_m, e.y_m, e.z_m}};
}

GroundConfig roi_facing(const GroundConfig& g, double direction) {
    if (direction >= 0.0) return g;
    GroundConfig behind = g;
    behind.roi_x_min_m = -g.roi_x_max_m;
    behind.roi_x_max_m = -g.roi_x_min_m;
    return behind;
}

SensorRoi sensor_roi(const Config& cfg, double direction) {
    const GroundConfig g = roi_facing(cfg.ground, direction);
    return {effective_extrinsics(cfg), g.roi_x_min_m, g.roi_x_max_m, g.roi_y_abs_max_m};
}

// The slab test on the ray's horizontal projection: the parameter interval inside each pair of bounds,
// intersected, must hold some t ≥ 0.
bool ray_reaches(const SensorRoi& roi, const RigidTransform& T, const double origin[3], const double direction[3]) {
    double o[3];
    transform_point(T, origin, o);
    double lo = 0.0, hi = std::numeric_limits<double>::infinity();
    const double bounds[2][2] = {{roi.x_min_m, roi.x_max_m}, {-roi.y_abs_max_m, roi.y_abs_max_m}};
    for (int axis = 0; axis < 2; ++axis) {
        const double d = T.R[axis][0] * direction[0] + T.R[axis][1] * direction[1] + T.R[axis][2] * direction[2];
        const double a = bounds[axis][0], b = bounds[axis][1];
        if (!std::isfinite(d) || !std::isfinite(o[axis])) return false;  // no ray: a broken table or calibration
        if (d == 0.0) {
            if (o[axis] < a || o[axis] > b) return false;
            continue;
        }
        const double t1 = (a - o[axis]) / d, t2 = (b - o[axis]) / d;
        lo = std::max(lo, std::min(t1, t2));
        hi = std::min(hi, std::max(t1, t2));
    }
    return lo <= hi;
}

namespace {

// ROI cells: columns about the clustering's reach and the obstacles' ground columns wide, so that neighbours in
// space are neighbours in memory (a huge ROI gets wider columns rather than millions of empty ones), cut into
// slabs of base-frame height, so that within a column the road comes before what stands on it and a test for
// ground or not ground sees long runs of equal answers, whatever the order of the input rows.
constexpr double kCellEdgeM = 1.0;
constexpr double kMaxCellsPerSide = 128.0;  // at most 128 × 128 columns × kSlabs cells: 2 MB of counts
constexpr double kSlabLowM = -1.0, kSlabM = 0.1;  // below kSlabLowM: the first slab
constexpr std::uint32_t kSlabs = 32;                // from kSlabLowM + (kSlabs - 1)·kSlabM up: the last one

// The finite rows of `input` in the base frame, the ROI points among them kept in `scratch` in input order.
// Written without a branch on the ROI test (a point is always stored, then kept or overwritten): in an
// unordered cloud that branch would be mispredicted half of the time. Returns how many were kept.
std::size_t roi_points(PointsView input, const RigidTransform& T, const GroundConfig& g, RoiCloud& out) {
    auto& scratch = out.scratch;
    scratch.resize(static_cast<std::size_t>(input.rows()) + 1);
    std::size_t kept = 0;
    std::int64_t finite = 0;
    for (Eigen::Index i = 0; i < input.rows(); ++i) {
        const double p[3] = {input(i, 0), input(i, 1), input(i, 2)};
        const double sum = p[0] + p[1] + p[2];  // finite iff all three are: a float sum cannot overflow a double
        const bool is_finite = sum - sum == 0.0;
        double b[3];
        transform_point(T, p, b);
        finite += is_finite;
        scratch[kept] = {static_cast<float>(b[0]), static_cast<float>(b[1]), static_cast<float>(b[2]), 0,
                         static_cast<std::int32_t>(i)};
        kept += is_finite & (b[0] >= g.roi_x_min_m) & (b[0] <= g.roi_x_max_m) & (std::abs(b[1]) <= g.roi_y_abs_max_m);
    }
    out.finite = finite;
    return kept;
}

}  // namespace

void crop_roi(PointsView input, const RigidTransform& T, const GroundConfig& g, RoiCloud& out) {
    const std::size_t kept = roi_points(input, T, g, out);
    // A stable counting sort of the kept points by cell: column, then slab.
    const double x_lo = g.roi_x_min_m, y_lo = -g.roi_y_abs_max_m;
    const double edge = std::max({kCellEdgeM, (g.roi_x_max_m - x_lo) / (kMaxCellsPerSide - 1.0),
                                  -2.0 * y_lo / (kMaxCellsPerSide - 1.0)});
    const double per_m = 1.0 / edge;  // multiplications, not divisions, per point: a cell is only an order
    const auto cell = [per_m](double v, double lo) { return static_cast<std::uint32_t>((v - lo) * per_m); };
    const std::uint32_t x_last = cell(g.roi_x_max_m, x_lo), y_last = cell(-y_lo, y_lo);
    const std::uint32_t cells = (x_last + 1) * (y_last + 1) * kSlabs;
    const auto slab = [](float z) {
        const double above = std::max(0.0, (static_cast<double>(z) - kSlabLowM) * (1.0 / kSlabM));
        return std::min(static_cast<std::uint32_t>(std::min(above, 1e6)), kSlabs - 1);
    };
    auto& scratch = out.scratch;
    auto& start = out.cell_start;
    start.assign(cells + 1, 0);
    for (std::size_t k = 0; k < kept; ++k) {
        RoiCloud::Candidate& c = scratch[k];
        // min: a coordinate rounded to float may lie just beyond the ROI (just before it truncates to cell 0)
        const std::uint32_t column =
            std::min(cell(c.x, x_lo), x_last) * (y_last + 1) + std::min(cell(c.y, y_lo), y_last);
        c.cell = column * kSlabs + slab(c.z);
        ++start[c.cell + 1];
    }
    for (std::uint32_t c = 0; c < cells; ++c) start[c + 1] += start[c];
    auto& pts = out.cloud->points;
    pts.resize(kept);
    out.input_index.resize(kept);
    out.input_order.resize(kept);
    for (std::size_t k = 0; k < kept; ++k) {
        const RoiCloud::Candidate& c = scratch[k];
        const std::uint32_t at = start[c.cell]++;
        pts[at] = pcl::PointXYZ(c.x, c.y, c.z);
        out.input_index[at] = c.row;
        out.input_order[k] = static_cast<std::int32_t>(at);
    }
    out.cloud->width = static_cast<std::uint32_t>(pts.size());
    out.cloud->height = 1;
}

void roi_point_errors(const PointErrors& errors, const RigidTransform& T, RoiCloud& roi) {
    roi.error_group.clear();
    if (errors.error_groups)
        for (const std::int32_t row : roi.input_index) roi.error_group.push_back(errors.error_groups[row]);
    roi.height_variance.clear();
    if (!errors.range_variances_m2) return;
    roi.height_variance.resize(roi.input_index.size());
    for (std::size_t i = 0; i < roi.input_index.size(); ++i) {
        const auto& p = roi.cloud->points[i];
        const double dx = p.x - T.t[0], dy = p.y - T.t[1], dz = p.z - T.t[2];
        const double squared_range = dx * dx + dy * dy + dz * dz;
        const double uz2 = squared_range > 0.0 ? dz * dz / squared_range : 1.0;
        const double v = errors.range_variances_m2[roi.input_index[i]];
        roi.height_variance[i] = static_cast<float>(std::isfinite(v) && v > 0.0 ? uz2 * v : 0.0);
    }
}

}  // namespace roadpreview
