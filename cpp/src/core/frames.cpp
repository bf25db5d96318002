// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/core/frames.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/parallel.hpp"
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

// Rows are transformed and cropped on several threads in runs of at least this many (fewer do not repay a thread).
constexpr Eigen::Index kRowsPerThread = 16384;
constexpr int kMaxRowParts = 8;

// Rows [first, last) of `input` in the base frame, the ROI points among them stored from `at` on in input order,
// then given their cells. Written without a branch on the ROI test (a point is always stored, then kept or
// overwritten, so one slot beyond the kept ones is written): in an unordered cloud that branch would be
// mispredicted half of the time. Returns how many were kept; `finite` counts the finite rows.
std::size_t roi_points(PointsView input, Eigen::Index first, Eigen::Index last, const RigidTransform& T,
                       const GroundConfig& g, const RoiCells& grid, RoiCloud::Candidate* at, std::int64_t& finite) {
    std::size_t kept = 0;
    finite = 0;
    for (Eigen::Index i = first; i < last; ++i) {
        const double p[3] = {input(i, 0), input(i, 1), input(i, 2)};
        const double sum = p[0] + p[1] + p[2];  // finite iff all three are: a float sum cannot overflow a double
        const bool is_finite = sum - sum == 0.0;
        double b[3];
        transform_point(T, p, b);
        finite += is_finite;
        const float x = static_cast<float>(b[0]), y = static_cast<float>(b[1]), z = static_cast<float>(b[2]);
        at[kept] = {x, y, z, 0, static_cast<std::int32_t>(i)};
        kept += is_finite & (b[0] >= g.roi_x_min_m) & (b[0] <= g.roi_x_max_m) & (std::abs(b[1]) <= g.roi_y_abs_max_m);
    }
    for (std::size_t k = 0; k < kept; ++k) at[k].cell = grid.cell(at[k].x, at[k].y, at[k].z);
    return kept;
}

}  // namespace

void crop_roi(PointsView input, const RigidTransform& T, const GroundConfig& g, RoiCloud& out, int threads) {
    out.cells = RoiCells(g);
    const RoiCells& grid = out.cells;
    // The rows in `parts` runs, each stored from its own offset (one slot of room each), then closed up in order.
    const int parts = input.rows() >= kRowsPerThread * 2 ? std::clamp(threads, 1, kMaxRowParts) : 1;
    auto& scratch = out.scratch;
    scratch.resize(static_cast<std::size_t>(input.rows()) + static_cast<std::size_t>(parts));
    std::size_t kept[kMaxRowParts] = {};
    std::int64_t finite[kMaxRowParts] = {};
    const auto row_of = [&](int part) { return input.rows() * part / parts; };
    const auto slot_of = [&](int part) {
        return static_cast<std::size_t>(row_of(part)) + static_cast<std::size_t>(part);
    };
    parallel_for(parts, parts, [&](int part, int) {
        kept[part] = roi_points(input, row_of(part), row_of(part + 1), T, g, grid, scratch.data() + slot_of(part),
                                finite[part]);
    });
    std::size_t total = kept[0];
    out.finite = finite[0];
    for (int part = 1; part < parts; ++part) {
        std::copy_n(scratch.begin() + static_cast<std::ptrdiff_t>(slot_of(part)), kept[part],
                    scratch.begin() + static_cast<std::ptrdiff_t>(total));
        total += kept[part];
        out.finite += finite[part];
    }
    // A stable counting sort of the kept points by cell: column, then slab.
    auto& start = out.cell_start;
    start.assign(grid.cells() + 1, 0);
    for (std::size_t k = 0; k < total; ++k) ++start[scratch[k].cell + 1];
    for (std::uint32_t c = 0; c < grid.cells(); ++c) start[c + 1] += start[c];
    auto& pts = out.cloud->points;
    pts.resize(total);
    out.input_index.resize(total);
    out.input_order.resize(total);
    for (std::size_t k = 0; k < total; ++k) {
        const RoiCloud::Candidate& c = scratch[k];
        const std::uint32_t at = start[c.cell]++;
        pts[at] = pcl::PointXYZ(c.x, c.y, c.z);
        out.input_index[at] = c.row;
        out.input_order[k] = static_cast<std::int32_t>(at);
    }
    std::copy_backward(start.begin(), start.end() - 1, start.end());  // each cell's end → the next cell's start
    start[0] = 0;
    out.cloud->width = static_cast<std::uint32_t>(pts.size());
    out.cloud->height = 1;
}

BeamErrors::BeamErrors(const ProfileConfig& p)
    : others_(p.beam_sigma_deg * M_PI / 180.0), counted_(beam_errors_counted(p)) {
    for (const double sigma_deg : p.beam_sigmas_deg) listed_.push_back(sigma_deg * M_PI / 180.0);
}

void roi_point_errors(const PointErrors& errors, const RigidTransform& T, const BeamErrors& beams, RoiCloud& roi) {
    const std::int32_t* beam = beams.counted() ? errors.beams : nullptr;
    roi.error_group.clear();
    if (errors.error_groups)
        for (const std::int32_t row : roi.input_index) roi.error_group.push_back(errors.error_groups[row]);
    else if (beam)  // a beam with an error of its own groups its points; a point of no such beam is on its own
        for (const std::int32_t row : roi.input_index)
            roi.error_group.push_back(beam[row] >= 0 && beams.sigma_rad(beam[row]) > 0.0 ? beam[row] : -1 - row);
    roi.height_variance.clear();
    if (!errors.range_variances_m2 && !beam) return;
    roi.height_variance.resize(roi.input_index.size());
    for (std::size_t i = 0; i < roi.input_index.size(); ++i) {
        const auto& p = roi.cloud->points[i];
        const std::int32_t row = roi.input_index[i];
        const double dx = p.x - T.t[0], dy = p.y - T.t[1], dz = p.z - T.t[2];
        const double horizontal = dx * dx + dy * dy, squared_range = horizontal + dz * dz;
        const double sigma = beam ? beams.sigma_rad(beam[row]) : 0.0;
        double variance = horizontal * sigma * sigma;
        if (errors.range_variances_m2) {
            const double uz2 = squared_range > 0.0 ? dz * dz / squared_range : 1.0;
            const double v = errors.range_variances_m2[row];
            variance += std::isfinite(v) && v > 0.0 ? uz2 * v : 0.0;
        }
        roi.height_variance[i] = static_cast<float>(variance);
    }
}

}  // namespace roadpreview
