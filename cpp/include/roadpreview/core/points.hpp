// SPDX-License-Identifier: BSD-3-Clause
// A read-only N×3 view of float xyz rows inside an N×C row-major buffer (C ≥ 3), so N×3 and N×4 clouds
// (KITTI x,y,z,intensity; numpy arrays) are read in place without a copy, and what a source states about the
// points' errors.
#pragma once

#include <cstdint>

#include <Eigen/Core>

namespace roadpreview {

using PointsView = Eigen::Map<const Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>, Eigen::Unaligned,
                              Eigen::OuterStride<>>;

/// View `rows` points whose xyz are the first three of `stride` floats per row.
inline PointsView points_view(const float* data, Eigen::Index rows, Eigen::Index stride) {
    return PointsView(data, rows, 3, Eigen::OuterStride<>(stride));
}

/// What a source states about its points' errors (docs/method.md §12, §3), one entry per point each, or nullptr when
/// unknown: each point's range variance (m², Frame::range_variances), which sets a floor under the noise of the
/// profiles' bins and the map's cells; its error group (Frame::error_groups): points of one group share their error,
/// so a bin or cell counts them as one measurement when it rates its median; and its LiDAR beam (Frame::beams),
/// whose elevation error (ProfileConfig::beam_sigma_deg) all of the beam's points share.
struct PointErrors {
    // implicit: range variances alone (a const float*) pass as before
    PointErrors(const float* range_variances = nullptr, const std::int32_t* groups = nullptr,
                const std::int32_t* beam_of_point = nullptr)
        : range_variances_m2(range_variances), error_groups(groups), beams(beam_of_point) {}
    const float* range_variances_m2;
    const std::int32_t* error_groups;
    const std::int32_t* beams;
};

}  // namespace roadpreview
