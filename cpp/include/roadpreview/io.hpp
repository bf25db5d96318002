// SPDX-License-Identifier: BSD-3-Clause
// Frame reader: KITTI .bin (float32 x, y, z, intensity) and PCD files, or directories of them.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace roadpreview {

using PointMatrix = Eigen::Matrix<float, Eigen::Dynamic, 4, Eigen::RowMajor>;

struct Frame {
    PointMatrix points;  ///< sensor frame x, y, z, intensity (0 when the file has none)
    std::string source;  ///< the file it came from
};

/// Reads one .bin or .pcd file. Throws std::runtime_error naming the file on any problem.
Frame read_frame(const std::string& path);

/// Expands INPUT arguments: files are kept in order, directories contribute their .bin/.pcd files
/// sorted by name. Throws std::runtime_error for a missing path, an unsupported extension or an empty dir.
std::vector<std::string> expand_inputs(const std::vector<std::string>& inputs);

}  // namespace roadpreview
