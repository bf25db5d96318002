// SPDX-License-Identifier: BSD-3-Clause
// A read-only N×3 view of float xyz rows inside an N×C row-major buffer (C ≥ 3), so N×3 and N×4 clouds
// (KITTI x,y,z,intensity; numpy arrays) are read in place without a copy.
#pragma once

#include <Eigen/Core>

namespace roadpreview {

using PointsView = Eigen::Map<const Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>, Eigen::Unaligned,
                              Eigen::OuterStride<>>;

/// View `rows` points whose xyz are the first three of `stride` floats per row.
inline PointsView points_view(const float* data, Eigen::Index rows, Eigen::Index stride) {
    return PointsView(data, rows, 3, Eigen::OuterStride<>(stride));
}

}  // namespace roadpreview
