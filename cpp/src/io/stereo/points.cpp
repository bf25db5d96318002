// SPDX-License-Identifier: BSD-3-Clause
// Disparity → depth → points in the camera frame, with each point's range variance; the rows that see the road.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "roadpreview/core/frames.hpp"
#include "roadpreview/io/stereo.hpp"

namespace roadpreview {

int first_road_row(const StereoCalibration& calib, const Extrinsics& camera, int rows, const StereoConfig& cfg) {
    const RigidTransform T = to_rigid_transform(camera);
    const double target[3] = {cfg.max_depth_m, 0.0, cfg.road_rise_m};  // base frame
    double local[3];  // camera frame: R^T·(target − t)
    for (int r = 0; r < 3; ++r)
        local[r] = T.R[0][r] * (target[0] - T.t[0]) + T.R[1][r] * (target[1] - T.t[1]) + T.R[2][r] * (target[2] - T.t[2]);
    if (local[0] <= 0.0) return 0;  // the point is behind the camera: keep every row
    const double row = calib.cy_px - calib.fy_px * local[2] / local[0];
    return static_cast<int>(std::clamp(std::floor(row), 0.0, static_cast<double>(rows)));
}

StereoPoints disparity_to_points(const DisparityImage& disparity, int first_row, const StereoCalibration& calib,
                                 const StereoConfig& cfg, const GreyImage* grey) {
    const Eigen::Index rows = disparity.rows(), cols = disparity.cols();
    if (grey && (grey->rows() != rows || grey->cols() != cols))
        throw std::invalid_argument("the grey image (" + std::to_string(grey->cols()) + "x" + std::to_string(grey->rows()) +
                                    ") and the disparity image (" + std::to_string(cols) + "x" + std::to_string(rows) +
                                    ") differ in size");
    if (!(calib.baseline_m > 0.0 && calib.fx_px > 0.0 && calib.fy_px > 0.0))
        throw std::invalid_argument(calib.source + ": baseline and focal lengths must be > 0");
    const double fb = calib.fx_px * calib.baseline_m;       // px·m: z = fb / d
    const double min_disparity = fb / cfg.max_depth_m;      // nearer than max_depth_m
    const double sigma_factor = cfg.disparity_sigma_px / fb;  // σ_z = z²·σ_d/(f·B)
    // Error groups: tiles of twice the correlation lengths, the extent that holds about one independent error
    const Eigen::Index tile_cols = std::max<Eigen::Index>(1, std::lround(2.0 * cfg.error_correlation_along_px));
    const Eigen::Index tile_rows = std::max<Eigen::Index>(1, std::lround(2.0 * cfg.error_correlation_across_px));
    const Eigen::Index tiles_per_row = (cols + tile_cols - 1) / tile_cols;
    StereoPoints out;
    const Eigen::Index first = std::clamp<Eigen::Index>(first_row, 0, rows);
    // A usable disparity: finite (NaN compares false; +inf, a point at the camera's centre, is no measurement) and
    // at least that of max_depth_m.
    const auto usable = [&](double d) { return d >= min_disparity && d < INFINITY; };
    Eigen::Index valid = 0;
    for (Eigen::Index v = first; v < rows; ++v)
        for (Eigen::Index u = 0; u < cols; ++u) valid += usable(disparity(v, u));
    out.points.resize(valid, 4);
    out.range_variances.resize(static_cast<std::size_t>(valid));
    out.pixels.resize(static_cast<std::size_t>(valid));
    out.error_groups.resize(static_cast<std::size_t>(valid));
    Eigen::Index i = 0;
    for (Eigen::Index v = first; v < rows; ++v) {
        for (Eigen::Index u = 0; u < cols; ++u) {
            const double d = disparity(v, u);
            if (!usable(d)) continue;
            const double z = fb / d;
            const double right = (static_cast<double>(u) - calib.cx_px) * z / calib.fx_px;
            const double down = (static_cast<double>(v) - calib.cy_px) * z / calib.fy_px;
            out.points(i, 0) = static_cast<float>(z);
            out.points(i, 1) = static_cast<float>(-right);
            out.points(i, 2) = static_cast<float>(-down);
            out.points(i, 3) = grey ? (*grey)(v, u) : 0.0f;
            const double sigma_range = sigma_factor * z * std::sqrt(z * z + right * right + down * down);  // σ_z·r/z
            out.range_variances[static_cast<std::size_t>(i)] = static_cast<float>(sigma_range * sigma_range);
            out.pixels[static_cast<std::size_t>(i)] = static_cast<std::int32_t>(v * cols + u);
            out.error_groups[static_cast<std::size_t>(i)] =
                static_cast<std::int32_t>(v / tile_rows * tiles_per_row + u / tile_cols);
            ++i;
        }
    }
    return out;
}

}  // namespace roadpreview
